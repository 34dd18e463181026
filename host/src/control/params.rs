//! The grasping parameters: Table 4 as an editable TOML file.
//!
//! The default set is `host/config/grasp.toml`, compiled in; a user edits a
//! copy and passes it to `skin grasp --config`. Every key is required and
//! unknown keys are refused, so a typo cannot silently keep a default.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::areas::AreaKind;
use super::events::Levels;
use super::reaction::CellGains;
use super::trajectory::{Motion, Timing};
use super::ControlError;
use skin_model::file::read_text_capped;

/// The default parameter file.
pub const DEFAULT_TOML: &str = include_str!("../../config/grasp.toml");

/// Everything the tactile controller and the grasp are tuned with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Control period, s.
    pub control_period_s: f64,
    /// Limit on each joint's commanded velocity (trajectory plus reactions), rad/s.
    pub max_joint_velocity: f64,
    /// Limit on each joint's velocity while evading pain, rad/s.
    pub evade_max_velocity: f64,
    /// Time constant of the reaction smoothing, s (0: none).
    pub smoothing_s: f64,
    /// Table 3.
    pub levels: Levels,
    /// Trajectory timing.
    pub timing: Timing,
    /// Levels that trigger grasp transitions.
    pub transitions: Transitions,
    /// Kinesthetic guidance gains.
    pub guide: Guides,
    /// Per-state directives.
    pub state: States,
}

/// Table 3 levels (0..=4) that move the grasp from state to state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transitions {
    /// Force on the pat area that counts as a pat.
    pub pat_force: u8,
    /// Proximity on any contact area that ends the approach.
    pub approach_proximity: u8,
    /// Proximity on every contact area that ends the contact phase.
    pub contact_proximity: u8,
    /// Force on a contact area that ends loading.
    pub load_force: u8,
    /// Proximity on the chest that ends the pull.
    pub chest_proximity: u8,
    /// Force on any cell that ends the squeeze (below pain).
    pub squeeze_force: u8,
    /// Force on the chest that ends the squeeze: its cells cannot move
    /// away, and arms that back off in Hold may press the object harder
    /// against it.
    pub squeeze_chest_force: u8,
    /// Force on a non-contact area that cancels a grasp.
    pub cancel_force: u8,
    /// The release ends when every contact area is below this proximity.
    pub release_proximity: u8,
}

/// Gains for driving the robot by touch (section 5.3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Guides {
    /// Force guidance (Table 4, F-guide).
    pub force: CellGains,
    /// Proximity guidance.
    pub proximity: CellGains,
}

/// The directives of each grasp state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct States {
    /// Home, done and cancelled.
    pub rest: StateParams,
    /// Opening the arms.
    pub open: StateParams,
    /// Closing the arms until the object is near.
    pub approach: StateParams,
    /// Closing slowly into pre-contact.
    pub contact: StateParams,
    /// Applying force.
    pub load: StateParams,
    /// Pulling the object to the chest.
    pub pull: StateParams,
    /// Squeezing it against the chest.
    pub squeeze: StateParams,
    /// Holding it.
    pub hold: StateParams,
    /// Letting it go.
    pub release: StateParams,
    /// Backing off after a failure or cancel.
    pub cancel: StateParams,
    /// Evading pain.
    pub evade: StateParams,
}

/// The entry directive of one state: trajectory and area gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateParams {
    /// Key pose to move to; none: no trajectory.
    #[serde(default)]
    pub pose: Option<String>,
    /// Maximum joint velocity of the trajectory, rad/s.
    #[serde(default)]
    pub max_velocity: Option<f64>,
    /// Postural accuracy of the trajectory, rad.
    #[serde(default)]
    pub accuracy: Option<f64>,
    /// Window over which this state's progress is judged, s; none: the
    /// common `timing.stall_window_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stall_window_s: Option<f64>,
    /// The arms (the joints each contact area moves) cover the way to the
    /// pose together, the one ahead waiting for the other, until the chest
    /// sees the object near.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub together: bool,
    /// Gains of every area not overridden below.
    pub all: CellGains,
    /// Gains of the pat area.
    #[serde(default)]
    pub pat: Option<CellGains>,
    /// Gains of the contact areas.
    #[serde(default)]
    pub contact: Option<CellGains>,
    /// Gains of the chest.
    #[serde(default)]
    pub chest: Option<CellGains>,
    /// Gains of the non-contact area.
    #[serde(default)]
    pub non_contact: Option<CellGains>,
}

impl StateParams {
    /// The gains of an area kind.
    pub fn gains(&self, kind: AreaKind) -> CellGains {
        let own = match kind {
            AreaKind::Pat => self.pat,
            AreaKind::Contact => self.contact,
            AreaKind::Chest => self.chest,
            AreaKind::NonContact => self.non_contact,
        };
        own.unwrap_or(self.all)
    }

    /// The trajectory: key pose name and motion, if the state has one.
    pub fn motion(&self) -> Option<(&str, Motion)> {
        let pose = self.pose.as_deref()?;
        Some((pose, Motion { max_velocity: self.max_velocity?, accuracy: self.accuracy?, stop_at_target: true }))
    }

    /// The trajectory timing of this state: `common` with its own stall
    /// window, if it has one.
    pub fn timing(&self, common: Timing) -> Timing {
        Timing { stall_window_s: self.stall_window_s.unwrap_or(common.stall_window_s), ..common }
    }

    fn check(&self, state: &str) -> Result<(), ControlError> {
        // Keys about a trajectory need one.
        let about_trajectory = [
            (self.stall_window_s.is_some(), "`stall_window_s` judges a trajectory"),
            (self.together, "`together` keeps the arms together on a trajectory"),
        ];
        if let Some((_, what)) = about_trajectory.iter().find(|(given, _)| *given && self.pose.is_none()) {
            return Err(ControlError::Incomplete(format!("state.{state}: {what}: give `pose` too")));
        }
        if self.stall_window_s.is_some() {
            self.timing(Timing::default()).check().map_err(|e| in_state(state, e))?;
        }
        for kind in AreaKind::ALL {
            self.gains(kind).check().map_err(|e| in_state(state, e))?;
        }
        match (&self.pose, self.max_velocity, self.accuracy) {
            (None, None, None) => Ok(()),
            (Some(_), Some(_), Some(_)) => self.motion().expect("all set").1.check().map_err(|e| in_state(state, e)),
            _ => Err(ControlError::Incomplete(format!(
                "state.{state}: give `pose`, `max_velocity` and `accuracy` together, or none of them"
            ))),
        }
    }
}

fn in_state(state: &str, e: ControlError) -> ControlError {
    match e {
        ControlError::Range { what, value, expected } => {
            ControlError::Range { what: format!("state.{state}: {what}"), value, expected }
        }
        other => other,
    }
}

impl Default for Params {
    /// Table 4 (`host/config/grasp.toml`).
    fn default() -> Params {
        Params::from_toml_str(DEFAULT_TOML).expect("the built-in parameter file is valid")
    }
}

impl Params {
    /// Parses and checks a parameter file's text.
    pub fn from_toml_str(text: &str) -> Result<Params, ControlError> {
        let p: Params = toml::from_str(text).map_err(ControlError::Toml)?;
        p.check()?;
        Ok(p)
    }

    /// Reads and checks a parameter file.
    pub fn read(path: &Path) -> Result<Params, ControlError> {
        let text = read_text_capped(path, super::MAX_FILE_BYTES)
            .map_err(|source| ControlError::Read { path: path.display().to_string(), source })?;
        Params::from_toml_str(&text)
            .map_err(|e| ControlError::InFile { path: path.display().to_string(), source: Box::new(e) })
    }

    /// Checks every value is usable.
    pub fn check(&self) -> Result<(), ControlError> {
        // Bounded above too: a period of 1e300 s or a gain of 1e38 is a
        // typo, and no robot's joints turn at more than 10 rad/s.
        for (what, v, max, expected) in [
            ("control_period_s", self.control_period_s, 0.1, "a period in (0, 0.1] s"),
            ("max_joint_velocity", self.max_joint_velocity, 10.0, "a velocity in (0, 10] rad/s"),
            ("evade_max_velocity", self.evade_max_velocity, 10.0, "a velocity in (0, 10] rad/s"),
        ] {
            if !(v > 0.0 && v <= max) {
                return Err(ControlError::Range { what: what.into(), value: v, expected });
            }
        }
        if !(0.0..=10.0).contains(&self.smoothing_s) {
            return Err(ControlError::Range {
                what: "smoothing_s".into(),
                value: self.smoothing_s,
                expected: "a time in [0, 10] s",
            });
        }
        self.levels.check()?;
        self.timing.check()?;
        let t = &self.transitions;
        // Any level, but a squeeze must end below pain, or every grasp
        // would end in evasion.
        const ANY: (u8, &str) = (4, "a level from 1 to 4");
        const BELOW_PAIN: (u8, &str) = (3, "a level from 1 to 3");
        for (what, level, (top, expected)) in [
            ("pat_force", t.pat_force, ANY),
            ("approach_proximity", t.approach_proximity, ANY),
            ("contact_proximity", t.contact_proximity, ANY),
            ("load_force", t.load_force, ANY),
            ("chest_proximity", t.chest_proximity, ANY),
            ("cancel_force", t.cancel_force, ANY),
            ("release_proximity", t.release_proximity, ANY),
            ("squeeze_force", t.squeeze_force, BELOW_PAIN),
            ("squeeze_chest_force", t.squeeze_chest_force, BELOW_PAIN),
        ] {
            if !(1..=top).contains(&level) {
                return Err(ControlError::Range {
                    what: format!("transitions.{what}"),
                    value: f64::from(level),
                    expected,
                });
            }
        }
        self.guide.force.check()?;
        self.guide.proximity.check()?;
        let s = &self.state;
        for (name, state) in [
            ("rest", &s.rest),
            ("open", &s.open),
            ("approach", &s.approach),
            ("contact", &s.contact),
            ("load", &s.load),
            ("pull", &s.pull),
            ("squeeze", &s.squeeze),
            ("hold", &s.hold),
            ("release", &s.release),
            ("cancel", &s.cancel),
            ("evade", &s.evade),
        ] {
            state.check(name)?;
        }
        Ok(())
    }

    /// The parameters as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("parameters serialize")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::reaction::Primitive;

    #[test]
    fn the_default_is_table_4() {
        let p = Params::default();
        assert_eq!(p.guide.force.force, Primitive::new(0.05, 1.0));
        let s = &p.state;
        assert_eq!(s.open.motion().map(|(n, m)| (n.to_owned(), m.max_velocity)), Some(("open".into(), 0.4)));
        assert_eq!(s.contact.gains(AreaKind::Contact).proximity, Primitive::new(0.01, 0.4));
        assert_eq!(s.contact.gains(AreaKind::NonContact).proximity.gain, 0.0);
        assert_eq!(s.load.gains(AreaKind::NonContact).proximity, Primitive::new(0.01, 0.01));
        assert_eq!(s.pull.gains(AreaKind::Contact).force, Primitive::new(0.10, 0.8));
        assert_eq!(s.pull.motion().map(|(n, m)| (n.to_owned(), m.max_velocity)), Some(("pulled".into(), 0.05)));
        assert!(s.hold.motion().is_none());
        assert_eq!(s.squeeze.motion().map(|(n, _)| n.to_owned()), Some("pulled".into()));
        assert_eq!(s.hold.gains(AreaKind::Contact).force, Primitive::new(0.30, 2.0), "Table 4: 0.10, 0.8");
        assert_eq!(s.release.gains(AreaKind::Contact).proximity, Primitive::new(0.01, 0.2));
        // The pull alone judges its progress over a longer window.
        assert_eq!(s.pull.timing(p.timing), Timing { stall_window_s: 3.0, ..p.timing });
        assert_eq!(s.approach.timing(p.timing), p.timing);
    }

    proptest::proptest! {
        /// Any text, or the default file with any value in place of one
        /// number, gives parameters or an error, never a panic; what is
        /// accepted passes the checks.
        #[test]
        fn any_file_gives_parameters_or_an_error(
            text in "\\PC{0,200}",
            at in 0usize..60,
            value in proptest::num::f64::ANY,
        ) {
            let _ = Params::from_toml_str(&text);
            let _ = crate::control::areas::parse_specs(&text);
            let _ = crate::control::teach::KeyPoses::from_toml_str(&text);
            let mut numbers = DEFAULT_TOML.match_indices(|c: char| c.is_ascii_digit()).map(|(i, _)| i);
            if let Some(i) = numbers.nth(at) {
                let end = DEFAULT_TOML[i..].find(|c: char| !(c.is_ascii_digit() || c == '.')).map_or(DEFAULT_TOML.len(), |e| i + e);
                let edited = format!("{}{value:?}{}", &DEFAULT_TOML[..i], &DEFAULT_TOML[end..]);
                if let Ok(p) = Params::from_toml_str(&edited) {
                    proptest::prop_assert!(p.check().is_ok());
                }
            }
        }
    }

    #[test]
    fn the_file_round_trips() {
        let p = Params::default();
        assert_eq!(Params::from_toml_str(&p.to_toml()).unwrap(), p);
    }

    #[test]
    fn mistakes_are_refused_with_the_key() {
        let bad = DEFAULT_TOML.replace("max_joint_velocity = 0.5", "max_joint_velocity = -0.5");
        assert!(matches!(Params::from_toml_str(&bad), Err(ControlError::Range { .. })));
        for (from, to, says) in [
            (
                "control_period_s = 0.004",
                "control_period_s = 1e300",
                "control_period_s = 1e300 is out of range: expected a period in (0, 0.1] s",
            ),
            (
                "max_joint_velocity = 0.5",
                "max_joint_velocity = 1e38",
                "max_joint_velocity = 1e38 is out of range: expected a velocity in (0, 10] rad/s",
            ),
            (
                "smoothing_s = 0.0",
                "smoothing_s = nan",
                "smoothing_s = NaN is out of range: expected a time in [0, 10] s",
            ),
        ] {
            assert_eq!(Params::from_toml_str(&DEFAULT_TOML.replace(from, to)).unwrap_err().to_string(), says);
        }
        // Nested values are bounded above too, the key named.
        for (from, to, says) in [
            ("settle_s = 0.25", "settle_s = 1e300", "timing.settle_s = 1e300"),
            ("stall_window_s = 1.0", "stall_window_s = 1e9", "timing.stall_window_s = 1000000000"),
            ("stall_rad = 0.005", "stall_rad = 7.0", "timing.stall_rad = 7"),
            ("stall_window_s = 3.0", "stall_window_s = 0.0", "state.pull: timing.stall_window_s = 0"),
            (
                "force = { threshold = 0.05, gain = 1.0 }",
                "force = { threshold = 0.05, gain = 1e38 }",
                "force gain = 1e38",
            ),
            (
                "pose = \"pulled\"\nmax_velocity = 0.05",
                "pose = \"pulled\"\nmax_velocity = 1e30",
                "state.pull: max_velocity",
            ),
            (
                "pose = \"closed\"\nmax_velocity = 0.4\naccuracy = 0.01",
                "pose = \"closed\"\nmax_velocity = 0.4\naccuracy = 9.0",
                "state.approach: accuracy = 9",
            ),
        ] {
            let text = DEFAULT_TOML.replacen(from, to, 1);
            assert_ne!(text, DEFAULT_TOML, "{from}");
            let e = Params::from_toml_str(&text).unwrap_err().to_string();
            assert!(e.contains(says) && e.contains("out of range"), "{to}: {e}");
        }
        let typo = DEFAULT_TOML.replace("stall_rad", "stall_radians");
        let e = Params::from_toml_str(&typo).unwrap_err().to_string();
        assert!(e.contains("stall_radians"), "{e}");
        let idle = DEFAULT_TOML.replace("[state.hold]", "[state.hold]\nstall_window_s = 2.0");
        let e = Params::from_toml_str(&idle).unwrap_err().to_string();
        assert!(e.contains("state.hold") && e.contains("give `pose` too"), "{e}");
        let resting = DEFAULT_TOML.replace("[state.hold]", "[state.hold]\ntogether = true");
        let e = Params::from_toml_str(&resting).unwrap_err().to_string();
        assert!(e.contains("state.hold") && e.contains("give `pose` too"), "{e}");
        let half = DEFAULT_TOML.replace("pose = \"pulled\"", "");
        assert!(Params::from_toml_str(&half).unwrap_err().to_string().contains("state.pull"));
        let floor = DEFAULT_TOML.replace(
            "threshold = 0.10, gain = 0.8 } }\n\n[state.squeeze]",
            "threshold = 0.0, gain = 0.8 } }\n\n[state.squeeze]",
        );
        let e = Params::from_toml_str(&floor).unwrap_err().to_string();
        assert!(e.contains("state.pull"), "{e}");
        let level = DEFAULT_TOML.replace("load_force = 2", "load_force = 7");
        assert!(Params::from_toml_str(&level).is_err());
        let pain = DEFAULT_TOML.replace("squeeze_force = 3", "squeeze_force = 4");
        let e = Params::from_toml_str(&pain).unwrap_err().to_string();
        assert!(e.contains("transitions.squeeze_force") && e.contains("1 to 3"), "{e}");
        assert!(Params::from_toml_str("not toml [").is_err());
    }
}
