//! Kinesthetic teaching (sections 5.3 and 6.2): a person drives the robot
//! by touch and records named key poses.
//!
//! With force guidance the robot evades pushes on its skin; with proximity
//! guidance it evades a hand before it touches, about 5 cm away, which the
//! paper found the most pleasant way to teach. Either way the reactions go
//! through the sensory-motor map, so teaching needs no robot model. The
//! grasp uses four key poses: home, open, closed and pulled; each is also
//! explored as a tile of the sensory-motor map, so reactions near it are
//! mapped correctly.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::params::Guides;
use super::reaction::CellGains;
use super::ControlError;
use skin_model::file::read_text_capped;

/// The key poses of the grasp, in teaching order.
pub const KEY_POSES: [&str; 4] = ["home", "open", "closed", "pulled"];

/// How the robot is guided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Guidance {
    /// By pushing on the skin.
    Force,
    /// By approaching the skin.
    Proximity,
}

impl Guidance {
    /// The gains every cell gets while guiding.
    pub fn gains(self, guides: &Guides) -> CellGains {
        match self {
            Guidance::Force => guides.force,
            Guidance::Proximity => guides.proximity,
        }
    }
}

/// Named joint-space poses taught by touch.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct KeyPoses {
    poses: BTreeMap<String, Vec<f64>>,
}

impl KeyPoses {
    /// No poses.
    pub fn new() -> KeyPoses {
        KeyPoses::default()
    }

    /// Records (or replaces) a pose; all poses must have the same length
    /// and finite angles.
    pub fn record(&mut self, name: &str, pose: &[f64]) -> Result<(), ControlError> {
        if pose.iter().any(|q| !q.is_finite()) {
            return Err(ControlError::BadPose(name.to_owned()));
        }
        if let Some(other) = self.poses.values().next().filter(|p| p.len() != pose.len()) {
            return Err(ControlError::Dimension { expected: other.len(), got: pose.len() });
        }
        self.poses.insert(name.to_owned(), pose.to_vec());
        Ok(())
    }

    /// A pose by name.
    pub fn get(&self, name: &str) -> Result<&[f64], ControlError> {
        self.poses.get(name).map(Vec::as_slice).ok_or_else(|| ControlError::MissingPose(name.to_owned()))
    }

    /// The grasp's key poses not yet taught.
    pub fn missing(&self) -> Vec<&'static str> {
        KEY_POSES.into_iter().filter(|n| !self.poses.contains_key(*n)).collect()
    }

    /// All poses by name.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &[f64])> {
        self.poses.iter().map(|(n, p)| (n.as_str(), p.as_slice()))
    }

    /// Parses poses from TOML (`name = [angles]`).
    pub fn from_toml_str(text: &str) -> Result<KeyPoses, ControlError> {
        let raw: BTreeMap<String, Vec<f64>> = toml::from_str(text).map_err(ControlError::Toml)?;
        let mut poses = KeyPoses::new();
        for (name, pose) in &raw {
            poses.record(name, pose)?;
        }
        Ok(poses)
    }

    /// Reads poses from a TOML file.
    pub fn read(path: &Path) -> Result<KeyPoses, ControlError> {
        let text = read_text_capped(path, super::MAX_FILE_BYTES)
            .map_err(|source| ControlError::Read { path: path.display().to_string(), source })?;
        KeyPoses::from_toml_str(&text)
    }

    /// The poses as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(&self.poses).expect("poses serialize")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::params::Params;

    #[test]
    fn poses_record_round_trip_and_say_what_is_missing() {
        let mut k = KeyPoses::new();
        assert_eq!(k.missing(), KEY_POSES);
        k.record("home", &[0.1, -0.2]).unwrap();
        k.record("open", &[0.5, 0.2]).unwrap();
        assert!(matches!(k.record("closed", &[0.1]), Err(ControlError::Dimension { expected: 2, got: 1 })));
        assert!(k.record("closed", &[f64::NAN, 0.0]).is_err());
        assert_eq!(k.missing(), ["closed", "pulled"]);
        assert_eq!(KeyPoses::from_toml_str(&k.to_toml()).unwrap(), k);
        assert!(matches!(k.get("pulled"), Err(ControlError::MissingPose(_))));
        assert!(KeyPoses::from_toml_str("home = [0.0]\nopen = [1.0, 2.0]").is_err());
    }

    #[test]
    fn guidance_gains_come_from_the_parameters() {
        let p = Params::default();
        assert_eq!(Guidance::Force.gains(&p.guide).force.gain, 1.0);
        assert_eq!(Guidance::Proximity.gains(&p.guide).proximity.threshold, 0.01);
        assert_eq!(Guidance::Proximity.gains(&p.guide).force.gain, 0.0);
    }
}
