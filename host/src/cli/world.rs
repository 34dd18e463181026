//! The simulated robot and skin an in-process job runs on: the built-in
//! HRP-2-like upper body or any URDF, with its skin, sensors and base.

use std::path::PathBuf;

use clap::ValueEnum;
use skin_model::robot::{hrp2, Link, Robot, UrdfError};
use skin_model::skin::{Skin, SkinError};
use skin_sim::accel::Bma250Config;
use skin_sim::world::{BaseConfig, World, WorldConfig};

/// Arguments that build the simulated world.
#[derive(clap::Args)]
pub struct SimArgs {
    /// Robot description; without it, the built-in HRP-2-like upper body (14 DoF, 74 cells).
    #[arg(long, value_name = "FILE")]
    pub urdf: Option<PathBuf>,
    /// Cells on every link with geometry or mass [default: 4; the built-in robot: its own 74-cell skin].
    #[arg(long, value_name = "N", conflicts_with = "skin", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    cells_per_link: Option<usize>,
    /// Skin file (TOML or JSON) listing the cells of each link with their poses.
    #[arg(long, value_name = "FILE")]
    skin: Option<PathBuf>,
    /// Lay the cells in wired patches one cell pitch apart, so the skin's
    /// neighbour tables follow its geometry (`skin calibrate` uses them).
    #[arg(long, conflicts_with = "skin")]
    patches: bool,
    /// Seed of everything random: skin placement, sensor errors, noise, sway.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Accelerometer noise relative to the BMA250 datasheet (0: noise-free).
    #[arg(long, default_value_t = 1.0, value_name = "X", allow_negative_numbers = true)]
    noise_scale: f64,
    /// How the static base sits in the world.
    #[arg(long, value_enum, default_value_t = Base::Standing)]
    pub base: Base,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Base {
    /// Upright and balancing, as HRP-2 stood in the paper.
    Standing,
    /// Lying on its back.
    Lying,
    /// Bolted down and perfectly still.
    Rigid,
}

/// Why the world cannot be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The URDF is unusable.
    #[error(transparent)]
    Urdf(#[from] UrdfError),
    /// The skin cannot be built.
    #[error(transparent)]
    Skin(#[from] SkinError),
    /// A flag value out of range.
    #[error("--noise-scale must be a finite number >= 0, not {0}")]
    NoiseScale(f64),
    /// The URDF file cannot be read again for export.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl SimArgs {
    /// The robot description as text: the file, or the built-in one.
    pub fn urdf_text(&self) -> Result<String, Error> {
        match &self.urdf {
            Some(path) => skin_model::file::read_text_capped(path, skin_model::robot::limits::MAX_BYTES)
                .map_err(|source| Error::Read { path: path.display().to_string(), source }),
            None => Ok(hrp2::urdf()),
        }
    }

    /// The robot as the description gives it (the built-in one in its start pose).
    pub fn robot(&self) -> Result<Robot, Error> {
        Ok(match &self.urdf {
            Some(path) => Robot::from_urdf_file(path)?,
            None => hrp2::robot(),
        })
    }

    /// The world: robot, skin, sensors and base.
    pub fn world(&self) -> Result<World, Error> {
        if !(self.noise_scale.is_finite() && self.noise_scale >= 0.0) {
            return Err(Error::NoiseScale(self.noise_scale));
        }
        let robot = self.robot()?;
        let count = |link: &Link| match (self.cells_per_link, &self.urdf) {
            (Some(n), _) => n,
            (None, None) => hrp2::skin_cells_on(&link.name),
            (None, Some(_)) => 4,
        };
        let skin = match &self.skin {
            Some(path) => Skin::from_file(&robot, path),
            None if self.patches => Skin::patches(&robot, count, self.seed),
            None => Skin::on_surfaces(&robot, count, self.seed),
        }?;
        let base = match self.base {
            Base::Standing => BaseConfig::standing(),
            Base::Lying => BaseConfig::lying(),
            Base::Rigid => BaseConfig::rigid(),
        };
        Ok(World::new(
            robot,
            skin,
            WorldConfig {
                base,
                accel: Bma250Config::default().with_noise_scale(self.noise_scale),
                seed: self.seed,
                ..WorldConfig::default()
            },
        ))
    }
}

/// Warns when the declared mounting clearance (m) is more than the
/// simulated skin keeps: the exploration takes the declaration at its word,
/// so cells closer to an axis may be merged into the wrong body part.
pub fn warn_clearance(world: &World, declared_m: f64) {
    let close: Vec<f64> = world.skin().cells().iter().map(|c| c.axis_clearance_m).filter(|&c| c < declared_m).collect();
    if let Some(closest) = close.iter().copied().min_by(f64::total_cmp) {
        eprintln!(
            "warning: --axis-clearance {declared_m} m is more than the simulated skin keeps: {} cells sit closer to a joint axis (the closest {:.1} mm); the exploration trusts the declaration and may put them on the wrong body part",
            close.len(),
            closest * 1e3
        );
    }
}
