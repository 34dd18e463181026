//! The user's model with the calibrated skin on it, as MuJoCo writes it:
//! parsed by MuJoCo (mjSpec), each cell added as the world carries it
//! ([`cells`]), saved by MuJoCo's own XML writer, so that any MuJoCo
//! program loads the robot wearing its skin and reads the cells' sensors.

use std::path::{Path, PathBuf};

use mujoco_rs::error::MjEditError;
use nalgebra::Isometry3;

use super::{cells, load, MujocoError};
use crate::scene::SkinModel;

/// A cell to write: its name, the model body it sits on, and its pose in
/// that body's frame (z the outward normal, x y its accelerometer's).
#[derive(Clone, Debug)]
pub struct CellSite {
    /// Site name; its sensors are `name:acc`, `name:vel`, `name:range`, `name:touch0..2`.
    pub name: String,
    /// The model's body (as the skin names links).
    pub body: String,
    /// Pose in the body's frame.
    pub pose: Isometry3<f64>,
}

/// First guess of the written text's size, bytes per cell and for the model.
const BYTES_PER_CELL: usize = 2048;
const BYTES_FOR_MODEL: usize = 1 << 20;

/// The model at `path` (MJCF or URDF) wearing `cells`, as MJCF text.
pub struct ModelWithSkin {
    /// The text; mesh and texture folders are absolute, so it loads from any folder.
    pub xml: String,
    /// What differs from the user's model besides the cells, one sentence each.
    pub notes: Vec<String>,
}

/// The model at `path` with `cells` on it. Meshes MuJoCo cannot find are
/// left out as the world leaves them out (MuJoCo writes only what it
/// compiles), and said so.
pub fn model_with_skin(path: &Path, cells: &[CellSite]) -> Result<ModelWithSkin, MujocoError> {
    let mut spec = load::parse(path)?;
    let forces = SkinModel::default().force.positions();
    for cell in cells {
        cells::add(&mut spec, &cell.body, &cell.name, &cell.pose, &forces, cells::Carried::All, None)?;
    }
    let mut notes = Vec::new();
    let missing = load::drop_missing_meshes(&mut spec, path)?;
    if missing > 0 {
        notes.push(format!("{missing} meshes were not found: their geoms are specks in the written model"));
    }
    let folder = path.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let folder = std::fs::canonicalize(&folder).unwrap_or(folder);
    let compiler = spec.compiler_mut();
    let meshdir = folder.join(compiler.meshdir()).to_string_lossy().into_owned();
    let texturedir = folder.join(compiler.texturedir()).to_string_lossy().into_owned();
    compiler.set_meshdir(&meshdir);
    compiler.set_texturedir(&texturedir);
    spec.compile().map_err(|e| MujocoError::Compile(e.to_string()))?;
    let failed = |e: MjEditError| MujocoError::Compile(format!("MuJoCo cannot write the model with the skin: {e}"));
    let xml = match spec.save_xml_string(BYTES_FOR_MODEL + BYTES_PER_CELL * cells.len()) {
        Err(MjEditError::XmlBufferTooSmall { required_size }) => {
            spec.save_xml_string(required_size + 1).map_err(failed)
        }
        written => written.map_err(failed),
    }?;
    Ok(ModelWithSkin { xml, notes })
}
