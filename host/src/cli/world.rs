//! The simulated robot and skin an in-process job runs on: the built-in
//! HRP-2-like upper body or any URDF, with its skin, sensors and base, in
//! the built-in world or (`--mujoco`, a build with the `mujoco` feature)
//! in MuJoCo.

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
    /// A model (MJCF or URDF) run in MuJoCo instead of the built-in world: the skin laid on
    /// its collision geometry, MuJoCo's sensors as the cells' (a build with the `mujoco` feature).
    #[arg(long, value_name = "FILE", conflicts_with = "urdf")]
    pub mujoco: Option<PathBuf>,
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

/// What `--mujoco` says in a build without MuJoCo: how to get it. CI tests
/// with MuJoCo built in, so the text is checked here in every build.
#[cfg_attr(feature = "mujoco", allow(dead_code))]
const NO_MUJOCO: &str = "this skin was built without MuJoCo: run `cargo xtask install` (it installs the pinned MuJoCo library), then rebuild with `cargo build --release -p skin-host --features mujoco`";

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
    /// `--mujoco` asked of a build without MuJoCo.
    #[cfg(not(feature = "mujoco"))]
    #[error("{NO_MUJOCO}")]
    NoMujoco,
    /// MuJoCo cannot load the model or carry the skin.
    #[cfg(feature = "mujoco")]
    #[error(transparent)]
    Mujoco(#[from] skin_sim::mujoco::MujocoError),
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
    /// The MuJoCo model at `path` wearing `cells_per_link` cells per body
    /// laid in wired patches, seeded: what `skin sim-endpoint --mujoco` serves.
    pub fn mujoco_patches(path: PathBuf, cells_per_link: usize, seed: u64) -> SimArgs {
        SimArgs {
            urdf: None,
            mujoco: Some(path),
            cells_per_link: Some(cells_per_link),
            skin: None,
            patches: true,
            seed,
            noise_scale: 1.0,
            base: Base::Standing,
        }
    }

    /// The robot description as text: the file, or the built-in one.
    pub fn urdf_text(&self) -> Result<String, Error> {
        match &self.urdf {
            Some(path) => skin_model::file::read_text_capped(path, skin_model::robot::limits::MAX_BYTES)
                .map_err(|source| Error::Read { path: path.display().to_string(), source }),
            None => Ok(hrp2::urdf()),
        }
    }

    /// The robot as the description gives it (the built-in one in its
    /// start pose; a MuJoCo model's as MuJoCo compiled it).
    pub fn robot(&self) -> Result<Robot, Error> {
        if let Some(path) = &self.mujoco {
            return mujoco_robot(path);
        }
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
        #[cfg(feature = "mujoco")]
        let model = self.mujoco.as_deref().map(mujoco_model).transpose()?;
        #[cfg(feature = "mujoco")]
        let robot = match &model {
            Some(m) => m.robot().clone(),
            None => self.robot()?,
        };
        #[cfg(not(feature = "mujoco"))]
        let robot = self.robot()?;
        let builtin = self.urdf.is_none() && self.mujoco.is_none();
        let count = |link: &Link| match self.cells_per_link {
            Some(n) => n,
            None if builtin => hrp2::skin_cells_on(&link.name),
            None => 4,
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
        let cfg = WorldConfig {
            base,
            accel: Bma250Config::default().with_noise_scale(self.noise_scale),
            seed: self.seed,
            ..WorldConfig::default()
        };
        #[cfg(feature = "mujoco")]
        if let Some(model) = model {
            let world = model.world(skin, cfg)?;
            for note in world.mujoco_engine().map_or(&[][..], |e| e.notes()) {
                eprintln!("note: {note}");
            }
            return Ok(world);
        }
        Ok(World::new(robot, skin, cfg))
    }
}

/// A MuJoCo model, loaded.
#[cfg(feature = "mujoco")]
fn mujoco_model(path: &std::path::Path) -> Result<skin_sim::mujoco::Model, Error> {
    Ok(skin_sim::mujoco::Model::load(path)?)
}

/// The robot of a MuJoCo model, as MuJoCo compiled it.
#[cfg(feature = "mujoco")]
fn mujoco_robot(path: &std::path::Path) -> Result<Robot, Error> {
    Ok(mujoco_model(path)?.robot().clone())
}

/// Without MuJoCo in the build, `--mujoco` says how to get it.
#[cfg(not(feature = "mujoco"))]
fn mujoco_robot(_: &std::path::Path) -> Result<Robot, Error> {
    Err(Error::NoMujoco)
}

/// What the MuJoCo world assumed of its model (welded floating bases,
/// added servos, left-out meshes) for the JSON; `null` in the built-in world.
pub fn mujoco_json(world: &World) -> serde_json::Value {
    #[cfg(feature = "mujoco")]
    if let Some(engine) = world.mujoco_engine() {
        return serde_json::json!({"welded": engine.welded(), "notes": engine.notes()});
    }
    let _ = world;
    serde_json::Value::Null
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

/// What moves `world`'s robot, as the time it took is labelled: MuJoCo,
/// or the built-in world's kinematics.
pub fn engine_name(world: &World) -> &'static str {
    #[cfg(feature = "mujoco")]
    if world.mujoco_engine().is_some() {
        return "MuJoCo";
    }
    let _ = world;
    "kinematics"
}

#[cfg(test)]
mod tests {
    /// The message names the install and the rebuild, and both are real:
    /// xtask has the subcommand, the package has the feature.
    #[test]
    fn a_build_without_mujoco_names_the_install_and_the_rebuild() {
        let xtask = include_str!("../../../xtask/src/main.rs");
        assert!(xtask.contains("Some(\"install\") =>"), "the install the message names");
        let manifest = include_str!("../../Cargo.toml");
        assert!(manifest.contains("name = \"skin-host\""), "the package the rebuild names");
        assert!(manifest.contains("\nmujoco = ["), "the feature the rebuild names");
        assert!(super::NO_MUJOCO.contains("`cargo xtask install`"), "{}", super::NO_MUJOCO);
        assert!(
            super::NO_MUJOCO.contains("`cargo build --release -p skin-host --features mujoco`"),
            "{}",
            super::NO_MUJOCO
        );
    }
}
