//! The grasp state machine (section 6.4, Figure 15).
//!
//! A pat on the shoulder launches the grasp: open the arms, approach the
//! object between them fast until a contact area senses it, close slowly
//! into pre-contact, load it with force, pull it to the chest and hold it;
//! another pat releases it. Closing slowly stalls where the proximity
//! reactions hold an arm back: if either arm sees the object then, the
//! grasp presses on (an object nearer one arm is pushed towards the
//! other), and only one seen by neither is missed. The pull ends only
//! when the chest is close *and* every contact area feels force (or the arms stall against the
//! object while one feels it: the object is what holds them back), so the
//! arms hold the object, not the chest alone; then the arms squeeze it
//! until both arms feel it and a cell feels the high force level (a chest
//! cell the medium one), or a chest cell the high level, or they can close
//! no further, and hold that pose, so the grip can
//! carry the object's weight once the person lets go (the chest may then
//! bear it harder: only pain ends the hold); loading that reaches the
//! closed pose with the object still near both arms (narrow or soft: the
//! taught pose is no tighter than the teacher made it) pulls it in too,
//! and a touch on the chest ends the contact phase like one on an arm (an
//! arm's bare surface pushed the object there); when a contact area that
//! felt it on squeezing or holding has not felt it for [`SLIP_S`], the
//! grasp pulls again, until both arms feel it with the chest seeing it
//! near (it was at the chest). A pull that stalls, or strains, with the object
//! still far from the chest lets go and hugs it again from the open pose,
//! where the pull left it ([`REGRIPS`] times, then it gives up).
//! Transitions are driven by tactile events (as
//! per-area levels) and trajectory events only. A state whose goal is
//! contact fails when its key pose is reached, or its motion stalls, before
//! the touch it waits for: then the grasp is cancelled and the robot backs
//! off to the open pose. A pat during the grasp, or force on a non-contact
//! area, cancels it too. Pain anywhere, in any state, cancels the
//! trajectory at once and evades every contact slowly.
//!
//! Entry directives (gains per area, trajectory) are in
//! [`States`]; the controller applies them.

use serde::Serialize;

use super::areas::AreaKind;
use super::events::{level, Events, Modality};
use super::params::{StateParams, States, Transitions};
use super::trajectory::TrajectoryEvent;

/// How long a contact area that held the object may feel nothing before
/// the grasp pulls again, s (a relaxing arm flickers at the lowest level).
pub const SLIP_S: f64 = 0.25;

/// How many times a grasp whose pull cannot bring the object to the chest
/// lets go and hugs it again before it gives up. Arms that met an object
/// far forward only at its sides squeeze those sides with bare surfaces no
/// cell feels, and friction alone drags it, ever slower; opening and
/// closing again meets it where the pull left it, nearer, with the
/// forearms further round it. A heavy box dragged over the person's hands
/// comes 1-3 cm nearer a hug: of the 100 anywhere-objects in MuJoCo
/// (noise seeds 0 and 1), four hugs held 4 and 5 more than two did, and
/// seven 3 more on each than four (wide boxes held after five to seven).
pub const REGRIPS: u8 = 7;

/// A state of the grasp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum State {
    /// At rest before the first grasp.
    Home,
    /// Opening the arms to make room.
    Open,
    /// Closing the arms fast until the object is near a contact area.
    Approach,
    /// Closing slowly into pre-contact on every contact area.
    Contact,
    /// Pressing until a contact area feels force.
    Load,
    /// Pulling the object to the chest.
    Pull,
    /// Squeezing it against the chest until a cell feels a high force.
    Squeeze,
    /// Holding the object against the chest.
    Hold,
    /// Letting the object go.
    Release,
    /// Backing off to the open pose after a failure or cancel.
    Cancel,
    /// Evading pain.
    Evade,
    /// At rest after a cancelled grasp.
    Cancelled,
    /// At rest after a completed grasp and release.
    Done,
}

impl State {
    /// Every state.
    pub const ALL: [State; 13] = [
        State::Home,
        State::Open,
        State::Approach,
        State::Contact,
        State::Load,
        State::Pull,
        State::Squeeze,
        State::Hold,
        State::Release,
        State::Cancel,
        State::Evade,
        State::Cancelled,
        State::Done,
    ];

    /// The state's name, as in JSON and traces.
    pub fn name(self) -> &'static str {
        match self {
            State::Home => "home",
            State::Open => "open",
            State::Approach => "approach",
            State::Contact => "contact",
            State::Load => "load",
            State::Pull => "pull",
            State::Squeeze => "squeeze",
            State::Hold => "hold",
            State::Release => "release",
            State::Cancel => "cancel",
            State::Evade => "evade",
            State::Cancelled => "cancelled",
            State::Done => "done",
        }
    }

    /// At rest: a pat launches a grasp.
    pub fn is_rest(self) -> bool {
        matches!(self, State::Home | State::Cancelled | State::Done)
    }

    /// Part of a running grasp, from opening to holding.
    pub fn is_grasping(self) -> bool {
        matches!(
            self,
            State::Open | State::Approach | State::Contact | State::Load | State::Pull | State::Squeeze | State::Hold
        )
    }

    /// The entry directive of the state.
    pub fn params(self, states: &States) -> &StateParams {
        match self {
            State::Home | State::Cancelled | State::Done => &states.rest,
            State::Open => &states.open,
            State::Approach => &states.approach,
            State::Contact => &states.contact,
            State::Load => &states.load,
            State::Pull => &states.pull,
            State::Squeeze => &states.squeeze,
            State::Hold => &states.hold,
            State::Release => &states.release,
            State::Cancel => &states.cancel,
            State::Evade => &states.evade,
        }
    }
}

/// Why a transition happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// A pat on the pat area.
    Pat,
    /// The trajectory reached its key pose.
    Reached,
    /// The trajectory stopped making progress.
    Stalled,
    /// A proximity level on the contact areas.
    Proximity,
    /// A force level on the contact areas.
    Force,
    /// Close contact on the chest.
    Chest,
    /// Pain-level force somewhere.
    Pain,
    /// Force on a non-contact area.
    NonContactForce,
    /// The contact areas no longer see the object.
    ContactLost,
    /// A contact area that held the object no longer feels it.
    Slipped,
    /// Every contact is gone.
    Clear,
    /// A cell felt the force the squeeze ends at.
    Squeezed,
}

impl Cause {
    /// The cause a trajectory event gives.
    fn of(e: TrajectoryEvent) -> Cause {
        match e {
            TrajectoryEvent::Reached => Cause::Reached,
            TrajectoryEvent::Stalled => Cause::Stalled,
        }
    }
}

/// One change of state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Transition {
    /// The state left.
    pub from: State,
    /// The state entered.
    pub to: State,
    /// When, s.
    pub time_s: f64,
    /// Why.
    pub cause: Cause,
}

/// The grasp state machine.
#[derive(Clone, Debug)]
pub struct Grasp {
    state: State,
    levels: Transitions,
    pat_down: bool,
    evaded_from: State,
    /// Most contact areas feeling force at once since the squeeze began.
    held_by: usize,
    /// Since when fewer contact areas feel it than held it, s.
    slipping_since_s: Option<f64>,
    /// Hugs begun again in this grasp ([`REGRIPS`]).
    regrips: u8,
    /// The pull was begun by a slip (squeezing or holding): the object was
    /// at the chest, and the arms need only feel it again.
    slip_pull: bool,
}

impl Grasp {
    /// At home.
    pub fn new(levels: Transitions) -> Grasp {
        Grasp {
            state: State::Home,
            levels,
            pat_down: false,
            evaded_from: State::Home,
            held_by: 0,
            slipping_since_s: None,
            regrips: 0,
            slip_pull: false,
        }
    }

    /// The current state.
    pub fn state(&self) -> State {
        self.state
    }

    /// Takes this period's touch levels and trajectory event; returns the
    /// transition, if any. Pain is checked first, in every state.
    pub fn step(&mut self, touch: &Events, trajectory: Option<TrajectoryEvent>, time_s: f64) -> Option<Transition> {
        let t = self.levels;
        let pat_now = touch.any(AreaKind::Pat, Modality::Force, t.pat_force);
        let pat = pat_now && !self.pat_down;
        self.pat_down = pat_now;
        let feeling = touch.count(AreaKind::Contact, Modality::Force, 1);
        let gripping = matches!(self.state, State::Squeeze | State::Hold);
        self.held_by = if gripping { self.held_by.max(feeling) } else { 0 };
        self.slipping_since_s = match self.slipping_since_s {
            _ if !gripping || feeling >= self.held_by => None,
            None => Some(time_s),
            since => since,
        };
        let slipped = self.slipping_since_s.is_some_and(|since| time_s - since >= SLIP_S);
        let (next, cause) = self.next(touch, trajectory, pat, slipped)?;
        if next == State::Evade {
            self.evaded_from = self.state;
        }
        if self.state.is_rest() {
            self.regrips = 0;
        } else if next == State::Open {
            self.regrips += 1;
        }
        self.slip_pull = next == State::Pull && cause == Cause::Slipped;
        let tr = Transition { from: self.state, to: next, time_s, cause };
        self.state = next;
        Some(tr)
    }

    fn next(
        &self,
        touch: &Events,
        trajectory: Option<TrajectoryEvent>,
        pat: bool,
        slipped: bool,
    ) -> Option<(State, Cause)> {
        use AreaKind::{Chest, Contact, NonContact};
        use Modality::{Force, Proximity};
        use State::*;
        use TrajectoryEvent::{Reached, Stalled};
        let t = self.levels;
        let any = |k, m, l| touch.any(k, m, l);
        let every = |k, m, l| touch.every(k, m, l);
        if self.state != Evade && touch.highest(Force) >= level::PAIN {
            return Some((Evade, Cause::Pain));
        }
        let s = self.state;
        if s.is_rest() {
            return pat.then_some((Open, Cause::Pat));
        }
        if s.is_grasping() {
            if pat {
                return Some((if matches!(s, Squeeze | Hold) { Release } else { Cancel }, Cause::Pat));
            }
            if any(NonContact, Force, t.cancel_force) {
                return Some((Cancel, Cause::NonContactForce));
            }
        }
        let fail = |e: Option<TrajectoryEvent>| e.map(|e| (Cancel, Cause::of(e)));
        // The contact areas no longer see the object.
        let lost = !any(Contact, Proximity, t.approach_proximity);
        match s {
            Open => match trajectory {
                Some(Reached) => Some((Approach, Cause::Reached)),
                e => fail(e),
            },
            Approach => {
                if any(Contact, Proximity, t.approach_proximity) {
                    Some((State::Contact, Cause::Proximity))
                } else if trajectory == Some(Stalled) && any(Contact, Proximity, 1) {
                    Some((State::Contact, Cause::Stalled))
                } else {
                    fail(trajectory)
                }
            }
            State::Contact => {
                // The first touch ends the contact phase: from here force,
                // not the pre-contact sensor, is what matters. Force on the
                // chest is a touch too: an arm's bare surface has pushed the
                // object against the chest, where only pressing holds it.
                if any(Contact, Force, 1) {
                    Some((Load, Cause::Force))
                } else if any(Chest, Force, 1) {
                    Some((Load, Cause::Chest))
                } else if every(Contact, Proximity, t.contact_proximity) {
                    Some((Load, Cause::Proximity))
                } else if trajectory == Some(Stalled) && any(Contact, Proximity, 1) {
                    // Held back by its own evasion, an arm hovers at an
                    // object that stands nearer to it than to the other
                    // arm, which has closed without seeing it: pressing
                    // pushes the object towards the other arm.
                    Some((Load, Cause::Stalled))
                } else if trajectory == Some(Reached) && any(Chest, Proximity, t.contact_proximity) {
                    // A hug begun again where an earlier pull left the
                    // object at the chest, inside the closed pose: the pull
                    // closes the arms further on it.
                    Some((Pull, Cause::Reached))
                } else {
                    fail(trajectory)
                }
            }
            Load => {
                // One arm's force is enough: the pull's force reactions keep
                // it moderate while the trajectory brings the other arm in.
                // High force anywhere (the object pinned against the chest)
                // hands over to the pull too, which holds or gives up
                // before pain.
                if any(Contact, Force, t.load_force) || touch.highest(Force) >= level::HIGH {
                    Some((Pull, Cause::Force))
                } else if trajectory == Some(Reached) {
                    // The taught closed pose is no tighter than the teacher
                    // made it: a narrow or soft object still between both
                    // arms (each sees it as near as ended the approach, or
                    // one touches it) is pulled in, the pull closing the
                    // arms further; with nothing there, pressing failed.
                    let still_there = every(Contact, Proximity, t.approach_proximity) || any(Contact, Force, 1);
                    Some(if still_there { (Pull, Cause::Reached) } else { (Cancel, Cause::Reached) })
                } else {
                    None
                }
            }
            Pull => {
                // The object is against the chest when the chest sees it
                // close or feels it; held when both arms are on it too: one
                // arm and the chest alone pin the object, unless the object
                // is what stops the arms closing further. So an arm on it
                // that can pull it no closer, the chest seeing it near (the
                // contact level: nearer than where it was put down), ends
                // the pull too (a turned object may touch the chest
                // beside its cells, and an arm's bare surface may hold it
                // where no cell feels it).
                let stalled = trajectory == Some(Stalled);
                let chest_near = any(Chest, Proximity, t.contact_proximity);
                // After a slip the object was already against the chest
                // (perhaps beside its cells): near is close enough. Pulling
                // on until the chest saw it closer kept a box the arms
                // carried creeping down for 15 s, into the person's hands.
                let chest_close =
                    any(Chest, Proximity, t.chest_proximity) || any(Chest, Force, 1) || (self.slip_pull && chest_near);
                let both_arms = every(Contact, Force, 1);
                let one_arm = any(Contact, Force, 1);
                // Pulling against high force on an arm or the chest, the
                // object will not come closer: hold it if it is near the
                // chest, else let go before the force reaches pain and hug
                // it again where it is now ([`REGRIPS`] times, then give up).
                let straining = touch.highest(Force) >= level::HIGH;
                let again = |cause| Some((if self.regrips < REGRIPS { Open } else { Cancel }, cause));
                if (chest_close && both_arms) || ((stalled || straining) && chest_near && one_arm) {
                    Some((Squeeze, Cause::Chest))
                } else if straining {
                    again(Cause::Force)
                } else if lost && trajectory.is_some() {
                    // Squeezed between converging forearms, an object may
                    // shoot ahead of them to the chest: the arms pull on to
                    // the pulled pose, and it is lost only there.
                    Some((Cancel, Cause::ContactLost))
                } else if stalled {
                    again(Cause::Stalled)
                } else {
                    fail(trajectory)
                }
            }
            // The pull's force reaction leaves a light grip (Table 4's
            // threshold, about 0.8 N a force cell) that carries little
            // more than the object's own friction on its support: the
            // arms close on until a cell anywhere, the chest's too (whose
            // cells cannot move away), feels the squeeze level, then hold
            // that pose, once every arm feels it: a pull that ended
            // straining with one arm pins the object against the chest, and
            // the arm that never touched it holds nothing while the person
            // holds it up (`gen3_08`: 0 N on the left arm for 8 s). Only
            // the chest's high level ends the squeeze with one arm: the arm
            // pressing on pushed the object into the chest's cells, pain
            // within 0.1 s (`gen2_13`). Arms that can close no further hold
            // where they are. An arm that lost the object while the other
            // pressed on is pulled in again, as in Hold.
            Squeeze => {
                let squeezed = touch.highest(Force) >= t.squeeze_force || any(Chest, Force, t.squeeze_chest_force);
                if lost {
                    Some((Cancel, Cause::ContactLost))
                } else if slipped {
                    Some((Pull, Cause::Slipped))
                } else if (squeezed && every(Contact, Force, 1)) || any(Chest, Force, t.squeeze_force) {
                    Some((Hold, Cause::Squeezed))
                } else {
                    trajectory.map(|e| (Hold, Cause::of(e)))
                }
            }
            // The object is lost when the contact areas no longer see it;
            // when an arm that held it no longer feels it, pull again. A
            // chest pressed harder while held is the object's weight
            // settling into the arms once the person lets go: giving it up
            // at the high level dropped round objects the arms carry, and
            // easing the grip let them sink and wedge into a cell (pain).
            Hold => {
                if lost {
                    Some((Cancel, Cause::ContactLost))
                } else {
                    slipped.then_some((Pull, Cause::Slipped))
                }
            }
            Release => (!any(Contact, Force, 1) && !any(Contact, Proximity, t.release_proximity))
                .then_some((Done, Cause::Clear)),
            Cancel => trajectory.map(|e| (Cancelled, Cause::of(e))),
            Evade => (touch.highest(Force) == 0)
                .then_some((if self.evaded_from.is_rest() { self.evaded_from } else { Cancelled }, Cause::Clear)),
            Home | Cancelled | Done => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::areas::{parse_specs, Areas};
    use crate::control::cells::CellIndex;
    use crate::control::events::{Levels, TouchEvent};
    use crate::control::params::Params;
    use proptest::prelude::*;
    use skin_protocol::{Address, Sample};

    /// Cells: 1 pat, 2 left CA, 3 right CA, 4 chest, 5 non-contact.
    fn touch() -> Events {
        let ix = CellIndex::new(&[1, 2, 3, 4, 5].map(Address)).unwrap();
        let specs = parse_specs(
            "[[area]]\nname='pat'\nkind='pat'\ncells=[1]\n[[area]]\nname='left'\nkind='contact'\ncells=[2]\n\
             [[area]]\nname='right'\nkind='contact'\ncells=[3]\n[[area]]\nname='chest'\nkind='chest'\ncells=[4]",
        )
        .unwrap();
        Events::new(&Areas::resolve(&specs, &ix, |_| None).unwrap(), &Levels::default()).unwrap()
    }

    fn set(ev: &mut Events, cell: u16, proximity: f32, force: f32) {
        let s = Sample::new((proximity * 65535.0) as u16, [(force * 4095.0) as u16, 0, 0], [0; 3], 0, 0).unwrap();
        ev.sample(usize::from(cell - 1), Address(cell), &s, &mut Vec::<TouchEvent>::new());
    }

    struct Run {
        g: Grasp,
        ev: Events,
        time: f64,
    }

    impl Run {
        fn new() -> Run {
            Run { g: Grasp::new(Params::default().transitions), ev: touch(), time: 0.0 }
        }
        fn step(&mut self, e: Option<TrajectoryEvent>) -> State {
            self.time += 0.004;
            self.g.step(&self.ev, e, self.time);
            self.g.state()
        }
        /// Launched, opened, and closing slowly: the left arm saw the object.
        fn in_contact() -> Run {
            let mut r = Run::new();
            r.pat();
            r.step(Some(TrajectoryEvent::Reached));
            set(&mut r.ev, 2, 0.03, 0.0);
            assert_eq!(r.step(None), State::Contact);
            r
        }
        /// Closing slowly, then both arms press it: loaded and pulling.
        fn pulling() -> Run {
            let mut r = Run::in_contact();
            set(&mut r.ev, 2, 0.9, 0.15);
            set(&mut r.ev, 3, 0.9, 0.15);
            assert_eq!(r.step(None), State::Load);
            assert_eq!(r.step(None), State::Pull);
            r
        }
        /// Steps through [`SLIP_S`] in `state` (an arm may flicker), then
        /// once more: the state after the slip.
        fn after_a_slip(&mut self, state: State) -> State {
            for _ in 0..=(SLIP_S / 0.004) as usize {
                assert_eq!(self.step(None), state, "an arm may flicker");
            }
            self.step(None)
        }
        fn pat(&mut self) -> State {
            set(&mut self.ev, 1, 0.0, 0.2);
            let s = self.step(None);
            set(&mut self.ev, 1, 0.0, 0.0);
            self.step(None);
            s
        }
    }

    #[test]
    fn names_match_the_json() {
        for s in State::ALL {
            assert_eq!(serde_json::to_value(s).unwrap(), s.name());
        }
    }

    #[test]
    fn a_successful_grasp_and_release() {
        let mut r = Run::new();
        use TrajectoryEvent::*;
        assert_eq!(r.pat(), State::Open);
        assert_eq!(r.step(Some(Reached)), State::Approach);
        set(&mut r.ev, 2, 0.03, 0.0);
        assert_eq!(r.step(None), State::Contact);
        set(&mut r.ev, 3, 0.03, 0.0);
        assert_eq!(r.step(None), State::Contact, "pre-contact on both arms, still closing");
        assert_eq!(r.step(Some(Stalled)), State::Load, "held off by the proximity reactions: in pre-contact");
        set(&mut r.ev, 2, 0.9, 0.05);
        assert_eq!(r.step(None), State::Load, "a low force is not enough");
        set(&mut r.ev, 3, 0.9, 0.15);
        assert_eq!(r.step(None), State::Pull, "medium force on one arm");
        set(&mut r.ev, 4, 0.5, 0.0);
        assert_eq!(r.step(None), State::Pull);
        set(&mut r.ev, 2, 0.9, 0.0);
        set(&mut r.ev, 4, 0.85, 0.0);
        assert_eq!(r.step(None), State::Pull, "the chest is close, but only one arm feels the object");
        set(&mut r.ev, 2, 0.9, 0.08);
        assert_eq!(r.step(None), State::Squeeze, "both arms and the chest");
        set(&mut r.ev, 4, 0.85, 0.05);
        set(&mut r.ev, 3, 0.9, 0.25);
        assert_eq!(r.step(None), State::Squeeze, "a low force on the chest, a medium one on an arm");
        set(&mut r.ev, 3, 0.9, 0.31);
        assert_eq!(r.step(None), State::Hold, "a high force on an arm");
        set(&mut r.ev, 3, 0.9, 0.15);
        set(&mut r.ev, 2, 0.9, 0.0);
        assert_eq!(r.after_a_slip(State::Hold), State::Pull, "an arm lost it for {SLIP_S} s: pull again");
        set(&mut r.ev, 2, 0.9, 0.08);
        assert_eq!(r.step(None), State::Squeeze);
        assert_eq!(r.step(Some(TrajectoryEvent::Stalled)), State::Hold, "the arms close no further: hold there");
        set(&mut r.ev, 2, 0.9, 0.0);
        assert_eq!(r.step(Some(TrajectoryEvent::Stalled)), State::Hold, "no trajectory in Hold");
        assert_eq!(r.pat(), State::Release);
        for c in [2, 3, 4] {
            set(&mut r.ev, c, 0.011, 0.0);
        }
        assert_eq!(r.step(None), State::Done);
        assert_eq!(r.pat(), State::Open, "a new grasp can start");
    }

    #[test]
    fn the_chest_ends_the_squeeze_early_and_only_pain_ends_the_hold() {
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.9, 0.05);
        assert_eq!(r.step(None), State::Squeeze);
        set(&mut r.ev, 4, 0.9, 0.11);
        assert_eq!(r.step(None), State::Hold, "a medium force on the chest, whose cells cannot move away");
        set(&mut r.ev, 4, 0.9, 0.25);
        assert_eq!(r.step(None), State::Hold, "the chest may bear more");
        set(&mut r.ev, 4, 0.9, 0.31);
        assert_eq!(r.step(None), State::Hold, "the chest's force grew high while held: the object's weight");
        set(&mut r.ev, 4, 0.9, 0.46);
        assert_eq!(r.step(None), State::Evade, "pain");
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.9, 0.05);
        assert_eq!(r.step(None), State::Squeeze);
        assert_eq!(r.pat(), State::Release, "a pat while squeezing releases");
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.9, 0.35);
        assert_eq!(r.step(None), State::Squeeze, "pulled until the chest felt a high force");
        assert_eq!(r.step(None), State::Hold);
        assert_eq!(r.step(None), State::Hold, "pinned there by the pull");
    }

    #[test]
    fn an_arm_that_loses_the_object_while_squeezing_pulls_again() {
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.9, 0.05);
        assert_eq!(r.step(None), State::Squeeze);
        assert_eq!(r.step(None), State::Squeeze, "both arms feel it");
        set(&mut r.ev, 2, 0.9, 0.0);
        assert_eq!(r.after_a_slip(State::Squeeze), State::Pull, "pull again, not hold with one arm");
        set(&mut r.ev, 2, 0.9, 0.15);
        assert_eq!(r.step(None), State::Squeeze);
        assert_eq!(r.step(None), State::Squeeze, "both arms feel it again");
        set(&mut r.ev, 4, 0.9, 0.11);
        set(&mut r.ev, 2, 0.9, 0.05);
        assert_eq!(r.step(None), State::Hold, "squeezed");
        set(&mut r.ev, 2, 0.9, 0.0);
        assert_eq!(r.after_a_slip(State::Hold), State::Pull, "the arm that felt it while squeezing counts in Hold too");
    }

    #[test]
    fn the_squeeze_closes_until_every_arm_feels_the_object() {
        /// A pull that ended straining with the right arm alone, the chest
        /// close and feeling `chest`: squeezing.
        fn one_arm(chest: f32) -> Run {
            let mut r = Run::pulling();
            set(&mut r.ev, 2, 0.9, 0.0);
            set(&mut r.ev, 3, 0.9, 0.35);
            set(&mut r.ev, 4, 0.9, chest);
            assert_eq!(r.step(None), State::Squeeze, "one arm strains, the chest close");
            r
        }
        let mut r = one_arm(0.15);
        for _ in 0..1000 {
            assert_eq!(r.step(None), State::Squeeze, "the left arm never touched it: it closes on");
        }
        set(&mut r.ev, 2, 0.9, 0.05);
        assert_eq!(r.step(None), State::Hold, "both arms feel it");
        let mut r = one_arm(0.15);
        set(&mut r.ev, 4, 0.9, 0.31);
        assert_eq!(r.step(None), State::Hold, "the chest cannot move away: pressing on would hurt it");
        let mut r = one_arm(0.0);
        assert_eq!(r.step(Some(TrajectoryEvent::Stalled)), State::Hold, "it can close no further");
    }

    #[test]
    fn a_pull_after_a_slip_grips_again_when_the_chest_sees_the_object_near() {
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.9, 0.11);
        assert_eq!(r.step(None), State::Squeeze);
        assert_eq!(r.step(None), State::Hold, "the chest's medium force");
        // Held, then the left arm no longer feels it, and the chest sees
        // it only near (it leans beside the chest's cells).
        set(&mut r.ev, 4, 0.3, 0.0);
        set(&mut r.ev, 2, 0.9, 0.0);
        assert_eq!(r.after_a_slip(State::Hold), State::Pull);
        assert_eq!(r.step(None), State::Pull, "one arm feels it");
        set(&mut r.ev, 2, 0.9, 0.08);
        assert_eq!(r.step(None), State::Squeeze, "both again, the chest seeing it near: it was at the chest");
        let mut r = Run::pulling();
        set(&mut r.ev, 4, 0.3, 0.0);
        assert_eq!(r.step(None), State::Pull, "a first pull needs the chest close");
    }

    #[test]
    fn no_object_cancels_and_a_pat_or_the_wrist_cancels() {
        use TrajectoryEvent::*;
        let mut r = Run::new();
        r.pat();
        r.step(Some(Reached));
        assert_eq!(r.step(Some(Reached)), State::Cancel, "closed reached with nothing in between");
        assert_eq!(r.step(Some(Reached)), State::Cancelled);
        r.pat();
        assert_eq!(r.pat(), State::Cancel, "a pat during the grasp cancels it");
        r.step(Some(Stalled));
        assert_eq!(r.pat(), State::Open);
        set(&mut r.ev, 5, 0.0, 0.15);
        assert_eq!(r.step(None), State::Cancel, "force on the non-contact area cancels");
    }

    #[test]
    fn an_arm_held_back_by_an_object_nearer_it_presses_it_towards_the_other() {
        use TrajectoryEvent::*;
        let contact = |right: f32| {
            let mut r = Run::in_contact();
            set(&mut r.ev, 2, 0.05, 0.0);
            set(&mut r.ev, 3, right, 0.0);
            r
        };
        let mut r = contact(0.0);
        assert_eq!(r.step(Some(Stalled)), State::Load, "one arm hovers at it, the other sees nothing: press");
        let mut r = contact(0.0);
        set(&mut r.ev, 2, 0.0, 0.0);
        assert_eq!(r.step(Some(Stalled)), State::Cancel, "stalled with nothing seen: missed");
        let mut r = contact(0.0);
        assert_eq!(r.step(Some(Reached)), State::Cancel, "closed without touching it: missed");
        let mut r = contact(0.0);
        set(&mut r.ev, 4, 0.2, 0.0);
        assert_eq!(r.step(Some(Reached)), State::Pull, "closed short of it at the chest: close on it");
    }

    #[test]
    fn a_pull_that_cannot_bring_the_object_in_hugs_again_then_gives_up() {
        use TrajectoryEvent::*;
        let hug_again = |r: &mut Run| {
            assert_eq!(r.step(Some(Reached)), State::Approach, "opened: close on it again");
            assert_eq!(r.step(None), State::Contact);
            assert_eq!(r.step(None), State::Load);
            assert_eq!(r.step(None), State::Pull);
        };
        let mut r = Run::pulling();
        assert_eq!(r.step(Some(Stalled)), State::Open, "stalled far from the chest: let go");
        hug_again(&mut r);
        set(&mut r.ev, 3, 0.9, 0.31);
        assert_eq!(r.step(None), State::Open, "straining far from the chest: let go");
        set(&mut r.ev, 3, 0.9, 0.15);
        hug_again(&mut r);
        for _ in 2..REGRIPS {
            assert_eq!(r.step(Some(Stalled)), State::Open, "stalled again: let go again");
            hug_again(&mut r);
        }
        assert_eq!(r.step(Some(Stalled)), State::Cancel, "after {REGRIPS} hugs again: give up");
        r.step(Some(Reached));
        assert_eq!(r.pat(), State::Open);
        hug_again(&mut r);
        assert_eq!(r.step(Some(Stalled)), State::Open, "a new grasp hugs again as often");
        let mut r = Run::pulling();
        set(&mut r.ev, 2, 0.0, 0.0);
        set(&mut r.ev, 3, 0.0, 0.0);
        assert_eq!(r.step(None), State::Pull, "out of the arms' sight: pull on to the pulled pose");
        assert_eq!(r.step(Some(Stalled)), State::Cancel, "stalled with the object lost: nothing to hug");
        let mut r = Run::pulling();
        set(&mut r.ev, 2, 0.0, 0.0);
        set(&mut r.ev, 3, 0.0, 0.0);
        assert_eq!(r.step(Some(Reached)), State::Cancel, "pulled with the object lost: nothing pulled");
    }

    #[test]
    fn pain_evades_from_every_state_and_rest_comes_back() {
        let mut r = Run::new();
        set(&mut r.ev, 5, 0.0, 0.5);
        assert_eq!(r.step(None), State::Evade);
        set(&mut r.ev, 5, 0.0, 0.0);
        assert_eq!(r.step(None), State::Home, "pain at rest: back to rest");
        r.pat();
        set(&mut r.ev, 2, 0.0, 0.46);
        assert_eq!(r.step(None), State::Evade);
        assert_eq!(r.step(None), State::Evade, "until the contact is gone");
        set(&mut r.ev, 2, 0.0, 0.0);
        assert_eq!(r.step(None), State::Cancelled);
    }

    #[test]
    fn what_the_closed_pose_does_not_reach_is_pulled_in_and_the_chest_counts_as_a_touch() {
        use TrajectoryEvent::*;
        let load = |near: [f32; 2]| {
            let mut r = Run::new();
            r.pat();
            r.step(Some(Reached));
            set(&mut r.ev, 2, 0.2, 0.0);
            set(&mut r.ev, 3, 0.2, 0.0);
            assert_eq!(r.step(None), State::Contact);
            assert_eq!(r.step(None), State::Load, "both arms at the contact level");
            set(&mut r.ev, 2, near[0], 0.0);
            set(&mut r.ev, 3, near[1], 0.0);
            r
        };
        let mut r = load([0.05, 0.03]);
        assert_eq!(r.step(Some(Reached)), State::Pull, "closed, both arms still see it near: pull it in");
        let mut r = load([0.05, 0.0]);
        assert_eq!(r.step(Some(Reached)), State::Cancel, "closed with one arm seeing nothing: missed");
        let mut r = load([0.05, 0.03]);
        set(&mut r.ev, 4, 0.9, 0.35);
        assert_eq!(r.step(None), State::Pull, "high force on the chest ends the loading");

        let mut r = Run::in_contact();
        set(&mut r.ev, 4, 0.9, 0.05);
        assert_eq!(r.step(None), State::Load, "pushed against the chest by an arm no cell of which feels it");
        assert_eq!(r.step(None), State::Load, "a low force on the chest does not end the loading");
    }

    proptest! {
        /// Under any inputs: pain always means Evade; holding is reached
        /// only from pulling through the squeeze; releasing only from
        /// squeezing or holding; and the machine
        /// never enters a grasp state from rest except through Open.
        #[test]
        fn the_machine_keeps_its_invariants(
            steps in proptest::collection::vec((1u16..=5, 0.0f32..1.0, 0.0f32..0.6, 0u8..3), 1..300)
        ) {
            let mut r = Run::new();
            for (cell, p, f, e) in steps {
                set(&mut r.ev, cell, p, f);
                let before = r.g.state();
                let event = [None, Some(TrajectoryEvent::Reached), Some(TrajectoryEvent::Stalled)][usize::from(e)];
                let after = r.step(event);
                if r.ev.highest(Modality::Force) >= level::PAIN {
                    prop_assert_eq!(after, State::Evade);
                }
                if after != before {
                    match after {
                        State::Squeeze => prop_assert_eq!(before, State::Pull),
                        State::Hold => prop_assert_eq!(before, State::Squeeze),
                        State::Pull => prop_assert!(matches!(
                            before,
                            State::Contact | State::Load | State::Squeeze | State::Hold
                        )),
                        State::Release => prop_assert!(matches!(before, State::Squeeze | State::Hold)),
                        State::Done => prop_assert_eq!(before, State::Release),
                        s if s.is_grasping() && before.is_rest() => prop_assert_eq!(s, State::Open),
                        _ => {}
                    }
                }
            }
        }
    }
}
