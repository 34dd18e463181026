//! The verdict on one grasp, by the simulator's truth.
//!
//! The controller reaching Hold is its own belief; what counts is what the
//! person at the robot sees: through the whole hold phase, the controller's
//! last stay in Hold before the pat that releases (where the person held
//! the object up, from when they let go), is the object between the arms,
//! against the chest, both arms on it and (where objects can be lifted)
//! carried by the robot alone (see [`skin_sim::scene::held`])?
//! Anything else is a failure with a reason, the robot time it was decided
//! and what decided it.
//!
//! Held says where the object is, not that it stays there: one the arms
//! hold but cannot carry slides down them, slowly enough to be between
//! them at the pat. Whether it had stopped sinking ([`settled`]) is
//! reported beside the verdict.

use serde::Serialize;

use skin_sim::scene::held::NotHeld;

use crate::control::grasp::Cause;

/// The window over which a held object must have stopped sinking, s: the
/// hold's last second before the release pat.
pub const REST_S: f64 = 1.0;
/// A settled object sinks no more than this over [`REST_S`], m: 2 mm/s, a
/// box still sinking so would be 12 cm down after a minute's hold.
pub const REST_M: f64 = 0.002;

/// Whether an object that sank `sank_m` over the hold's last [`REST_S`]
/// had stopped sinking.
pub fn settled(sank_m: f64) -> bool {
    sank_m <= REST_M
}

/// Why a grasp failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Failure {
    /// The arms never closed on the object from both sides.
    Missed,
    /// The arms had it, and lost it.
    Slipped,
    /// It fell to the floor (where objects can fall: MuJoCo).
    Dropped,
    /// A cell felt pain-level force.
    Pain,
    /// The grasp did not end in time.
    TimeOut,
    /// The controller gave up for another reason (a pat, force on a
    /// non-contact area, a motion that stalled after contact).
    Cancelled,
}

impl Failure {
    /// Every reason, in the order tables list them.
    pub const ALL: [Failure; 6] =
        [Failure::Missed, Failure::Slipped, Failure::Dropped, Failure::Pain, Failure::TimeOut, Failure::Cancelled];

    /// The reason's name, as in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Failure::Missed => "missed",
            Failure::Slipped => "slipped",
            Failure::Dropped => "dropped",
            Failure::Pain => "pain",
            Failure::TimeOut => "time_out",
            Failure::Cancelled => "cancelled",
        }
    }
}

/// What decided that a grasp failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Why {
    /// The truth: the object was not held, for this reason.
    NotHeld(NotHeld),
    /// The controller's transition, for this cause (pain evaded, a
    /// cancel).
    Controller(Cause),
    /// A force cell felt pain-level force.
    CellPain,
    /// The object pressed the robot's bare surface above the bound.
    BarePain,
    /// The grasp was still running at the time limit.
    TimeLimit,
    /// Nothing was put between the arms.
    NoObject,
}

/// When a grasp failed and what decided it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Failed {
    /// Robot time after the launching pat, s.
    pub time_s: f64,
    /// What decided it.
    pub why: Why,
}

impl std::fmt::Display for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Why::NotHeld(n) => f.write_str(n.describe()),
            Why::Controller(c) => write!(f, "the controller: {c:?}"),
            Why::CellPain => f.write_str("a force cell at the pain level"),
            Why::BarePain => f.write_str("bare surface pressed above the pain bound"),
            Why::TimeLimit => f.write_str("still running at the time limit"),
            Why::NoObject => f.write_str("nothing was put down"),
        }
    }
}

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "at {:.1} s: {}", self.time_s, self.why)
    }
}

/// What was seen of one grasp, each with its robot time after the
/// launching pat, s.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Seen {
    /// The first pain: the controller evading it, or the truth's force
    /// above the pain level on a cell or above the bound on bare surface.
    pub pain: Option<(f64, Why)>,
    /// The grasp was still running at the time limit.
    pub timed_out: Option<f64>,
    /// The controller reached Hold.
    pub reached_hold: bool,
    /// The first moment of the hold phase (the controller's last stay in
    /// Hold before the pat that releases, from when the person let go of
    /// the object's support) the truth did not call the object held, and
    /// why.
    pub lost_in_hold: Option<(f64, NotHeld)>,
    /// The truth when the person patted to release: held (none) or why
    /// not; no object at all is [`Why::NoObject`]. None: never released.
    pub at_release: Option<(f64, Result<(), Why>)>,
    /// The truth saw both arms on the object at some time.
    pub ever_gripped: bool,
    /// When and why the controller cancelled, if it did.
    pub cancelled_by: Option<(f64, Cause)>,
    /// When the truth first saw the object on the floor.
    pub dropped: Option<f64>,
    /// When the person took the object back into their hands (it came
    /// down resting on them as they lowered them).
    pub taken_back: Option<f64>,
    /// When the grasp ended.
    pub end_s: f64,
}

/// Held (`Ok`), or why not and when.
pub fn judge(seen: &Seen) -> Result<(), (Failure, Failed)> {
    let fail = |reason, time_s, why| Err((reason, Failed { time_s, why }));
    if let Some((t, why)) = seen.pain {
        return fail(Failure::Pain, t, why);
    }
    if let Some(t) = seen.timed_out {
        return fail(Failure::TimeOut, t, Why::TimeLimit);
    }
    if let Some(t) = seen.dropped {
        return fail(Failure::Dropped, t, Why::NotHeld(NotHeld::Fallen));
    }
    if let Some(t) = seen.taken_back {
        return fail(Failure::Slipped, t, Why::NotHeld(NotHeld::TakenBack));
    }
    if let Some((t, why)) = seen.lost_in_hold {
        return fail(Failure::Slipped, t, Why::NotHeld(why));
    }
    let lost = if seen.ever_gripped { Failure::Slipped } else { Failure::Missed };
    match (seen.at_release, seen.cancelled_by) {
        (Some((_, Ok(()))), _) => Ok(()),
        (Some((t, Err(why))), _) => fail(lost, t, why),
        (None, Some((t, c @ Cause::ContactLost))) => fail(lost, t, Why::Controller(c)),
        (None, Some((t, c))) if seen.reached_hold => fail(lost, t, Why::Controller(c)),
        (None, Some((t, c @ (Cause::Reached | Cause::Stalled)))) if !seen.ever_gripped => {
            fail(Failure::Missed, t, Why::Controller(c))
        }
        (None, Some((t, c))) => fail(Failure::Cancelled, t, Why::Controller(c)),
        // Neither released nor cancelled: the grasp ran out of time,
        // which is decided above.
        (None, None) => fail(Failure::TimeOut, seen.end_s, Why::TimeLimit),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_decides_and_each_failure_has_its_reason_and_time() {
        let held = Seen { reached_hold: true, at_release: Some((5.0, Ok(()))), ever_gripped: true, ..Seen::default() };
        assert_eq!(judge(&held), Ok(()));
        let failed = |seen: &Seen| judge(seen).unwrap_err();
        // The controller believed it held; the truth says no.
        let off = Why::NotHeld(NotHeld::OffChest);
        let believed = Seen { at_release: Some((5.0, Err(off))), ..held };
        assert_eq!(failed(&believed), (Failure::Slipped, Failed { time_s: 5.0, why: off }));
        assert_eq!(failed(&Seen { ever_gripped: false, ..believed }).0, Failure::Missed);
        // Held at release, but it sat on its support for a while in between.
        let resting = Seen { lost_in_hold: Some((3.2, NotHeld::Resting)), ..held };
        let why = Why::NotHeld(NotHeld::Resting);
        assert_eq!(failed(&resting), (Failure::Slipped, Failed { time_s: 3.2, why }));
        let pain = Seen { pain: Some((2.0, Why::BarePain)), ..held };
        assert_eq!(
            failed(&pain),
            (Failure::Pain, Failed { time_s: 2.0, why: Why::BarePain }),
            "pain fails even a hold"
        );
        let fell = Seen { dropped: Some(4.0), ..resting };
        assert_eq!(failed(&fell), (Failure::Dropped, Failed { time_s: 4.0, why: Why::NotHeld(NotHeld::Fallen) }));
        // The person took it back, and the experimenter's pat ended the grasp.
        let kept = Seen { taken_back: Some(3.5), cancelled_by: Some((3.6, Cause::Pat)), ..Seen::default() };
        let why = Why::NotHeld(NotHeld::TakenBack);
        assert_eq!(failed(&kept), (Failure::Slipped, Failed { time_s: 3.5, why }));
        let running = Seen { timed_out: Some(180.0), ..Seen::default() };
        assert_eq!(failed(&running), (Failure::TimeOut, Failed { time_s: 180.0, why: Why::TimeLimit }));
        let cancel = |t: f64, c: Cause| Some((t, c));
        let closed_on_nothing = Seen { cancelled_by: cancel(6.0, Cause::Reached), ..Seen::default() };
        let reached = Failed { time_s: 6.0, why: Why::Controller(Cause::Reached) };
        assert_eq!(failed(&closed_on_nothing), (Failure::Missed, reached));
        let lost = Seen { ever_gripped: true, cancelled_by: cancel(7.0, Cause::ContactLost), ..Seen::default() };
        assert_eq!(failed(&lost).0, Failure::Slipped);
        let lost_in_hold = Seen { reached_hold: true, ..lost };
        assert_eq!(failed(&lost_in_hold).0, Failure::Slipped);
        let patted = Seen { ever_gripped: true, cancelled_by: cancel(1.0, Cause::Pat), ..Seen::default() };
        assert_eq!(failed(&patted), (Failure::Cancelled, Failed { time_s: 1.0, why: Why::Controller(Cause::Pat) }));
        let wrist = Seen { cancelled_by: cancel(2.5, Cause::NonContactForce), ..Seen::default() };
        assert_eq!(failed(&wrist).0, Failure::Cancelled);
    }

    #[test]
    fn settled_is_at_most_2_mm_in_the_last_second() {
        assert!(settled(0.0) && settled(REST_M), "the bound itself is at rest");
        assert!(!settled(0.003), "3 mm down in the hold's last second: sliding");
    }

    #[test]
    fn why_reads_as_json() {
        let to = |w: Why| serde_json::to_value(w).unwrap();
        assert_eq!(to(Why::NotHeld(NotHeld::Resting)), serde_json::json!({ "not_held": "resting" }));
        assert_eq!(to(Why::Controller(Cause::ContactLost)), serde_json::json!({ "controller": "contact_lost" }));
        assert_eq!(to(Why::BarePain), "bare_pain");
    }

    #[test]
    fn names_match_the_json() {
        for f in Failure::ALL {
            assert_eq!(serde_json::to_value(f).unwrap(), f.name());
        }
    }
}
