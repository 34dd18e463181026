//! The verdict on one grasp, by the simulator's truth.
//!
//! The controller reaching Hold is its own belief; what counts is what the
//! person at the robot sees: at the moment they pat to release, is the
//! object between the arms, against the chest, with both arms on it (see
//! [`skin_sim::scene::held`])? Anything else is a failure with a reason.

use serde::Serialize;

use crate::control::grasp::Cause;

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

/// What was seen of one grasp.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Seen {
    /// A cell felt pain-level force (the truth), or the controller evaded pain.
    pub pain: bool,
    /// The grasp was still running at the time limit.
    pub timed_out: bool,
    /// The controller reached Hold.
    pub reached_hold: bool,
    /// The truth when the person patted to release: held or not (none:
    /// never released).
    pub held_at_release: Option<bool>,
    /// The truth saw both arms on the object at some time.
    pub ever_gripped: bool,
    /// Why the controller cancelled, if it did.
    pub cancelled_by: Option<Cause>,
    /// The truth saw the object on the floor by the end.
    pub dropped: bool,
}

/// Held (`Ok`), or why not.
pub fn judge(seen: &Seen) -> Result<(), Failure> {
    if seen.pain {
        return Err(Failure::Pain);
    }
    if seen.timed_out {
        return Err(Failure::TimeOut);
    }
    if seen.dropped {
        return Err(Failure::Dropped);
    }
    let lost = if seen.ever_gripped { Failure::Slipped } else { Failure::Missed };
    match (seen.held_at_release, seen.cancelled_by) {
        (Some(true), _) => Ok(()),
        (Some(false), _) => Err(lost),
        (None, Some(Cause::ContactLost)) => Err(lost),
        (None, _) if seen.reached_hold => Err(lost),
        (None, Some(Cause::Reached | Cause::Stalled)) if !seen.ever_gripped => Err(Failure::Missed),
        (None, _) => Err(Failure::Cancelled),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_decides_and_each_failure_has_its_reason() {
        let held = Seen { reached_hold: true, held_at_release: Some(true), ever_gripped: true, ..Seen::default() };
        assert_eq!(judge(&held), Ok(()));
        // The controller believed it held; the truth says no.
        let believed = Seen { held_at_release: Some(false), ..held };
        assert_eq!(judge(&believed), Err(Failure::Slipped));
        assert_eq!(judge(&Seen { ever_gripped: false, ..believed }), Err(Failure::Missed));
        assert_eq!(judge(&Seen { pain: true, ..held }), Err(Failure::Pain), "pain fails even a hold");
        assert_eq!(judge(&Seen { dropped: true, ..believed }), Err(Failure::Dropped), "on the floor");
        let running = Seen { timed_out: true, ..Seen::default() };
        assert_eq!(judge(&running), Err(Failure::TimeOut));
        let closed_on_nothing = Seen { cancelled_by: Some(Cause::Reached), ..Seen::default() };
        assert_eq!(judge(&closed_on_nothing), Err(Failure::Missed));
        let lost = Seen { ever_gripped: true, cancelled_by: Some(Cause::ContactLost), ..Seen::default() };
        assert_eq!(judge(&lost), Err(Failure::Slipped));
        let lost_in_hold =
            Seen { reached_hold: true, ever_gripped: true, cancelled_by: Some(Cause::ContactLost), ..Seen::default() };
        assert_eq!(judge(&lost_in_hold), Err(Failure::Slipped));
        let patted = Seen { ever_gripped: true, cancelled_by: Some(Cause::Pat), ..Seen::default() };
        assert_eq!(judge(&patted), Err(Failure::Cancelled));
        let wrist = Seen { cancelled_by: Some(Cause::NonContactForce), ..Seen::default() };
        assert_eq!(judge(&wrist), Err(Failure::Cancelled));
    }

    #[test]
    fn names_match_the_json() {
        for f in Failure::ALL {
            assert_eq!(serde_json::to_value(f).unwrap(), f.name());
        }
    }
}
