//! Reading a model file with MuJoCo: names for every body and joint (so the
//! skin and the servos can refer to them), links of a URDF kept apart,
//! meshes MuJoCo cannot find left out, and the robot read from the
//! compiled model.

use std::path::{Path, PathBuf};

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::MjsBody;

use super::{tree, Model, MujocoError};

/// Radius of the stand-in for a geom whose mesh is missing: a speck that
/// neither collides nor weighs.
const SPECK_M: f64 = 1e-4;

pub(super) fn load(path: &Path) -> Result<Model, MujocoError> {
    let failed = |message: String| MujocoError::Load { path: path.display().to_string(), message };
    // MuJoCo finds included files and meshes beside the file it reads: a
    // link to a model (as `cargo xtask menagerie` makes) is read where the
    // model lives. The robot keeps the name the user gave.
    let name = path.file_stem().map_or_else(|| "robot".into(), |s| s.to_string_lossy().into_owned());
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let path = real.as_path();
    let mut spec = parse(path)?;
    let mut notes = Vec::new();
    let missing = drop_missing_meshes(&mut spec, path)?;
    if missing > 0 {
        notes.push(format!(
            "{missing} meshes were not found (package:// paths are not resolved): their geoms are left out, the skin lies on bones there and nothing collides with them"
        ));
    }
    let model = spec.compile().map_err(|e| failed(e.to_string()))?;
    let mut data = model.make_data();
    data.forward();
    let overlapping = exclude_overlaps(&mut spec, &model, &data);
    if overlapping > 0 {
        notes.push(format!(
            "{overlapping} pairs of the robot's bodies overlap in the start pose and never collide (their shapes approximate the links; a link would otherwise be stuck against its neighbour)"
        ));
    }
    let mut tree = tree::read(&model, &data, &name)?;
    drop(data);
    if !tree.narrowed.is_empty() {
        notes.push(format!(
            "{} joints move only within their position servo's control range, narrower than the joint's (a start pose outside it starts at its nearest end): {}",
            tree.narrowed.len(),
            tree.narrowed.join(", ")
        ));
    }
    let mut start_ctrl = Vec::new();
    if let Some((key, pose, ctrl)) = keyframe_home(&model, &tree) {
        tree.robot.set_home(&pose)?;
        start_ctrl = ctrl;
        notes.push(format!(
            "the robot starts in the model's keyframe \"{key}\" (its DoFs' positions, and its controls for the actuators the skin's world does not drive, as a gripper's; the model's reference pose is no pose its makers stand it in)"
        ));
    }
    Ok(Model { spec, compiled: model, tree, notes, start_ctrl })
}

/// The pose the model's makers start it in: its keyframe named "home",
/// else its first keyframe, as each DoF's position relative to the
/// reference pose, and the keyframe's controls (one per actuator of the
/// model); `None` for a model without keyframes.
fn keyframe_home(model: &MjModel, tree: &tree::Tree) -> Option<(String, Vec<f64>, Vec<f64>)> {
    let (qpos0, keys) = (model.qpos0(), model.key_qpos());
    let nq = qpos0.len();
    let count = keys.len().checked_div(nq).unwrap_or(0);
    let key =
        (0..count).find(|&k| model.id_to_name(MjtObjBase::mjOBJ_KEY, k) == Some("home")).or((count > 0).then_some(0))?;
    let qpos = &keys[key * nq..(key + 1) * nq];
    let pose = tree
        .dof_joint
        .iter()
        .map(|&j| {
            let a = model.jnt_qposadr()[j] as usize;
            qpos[a] - qpos0[a]
        })
        .collect();
    let name = model.id_to_name(MjtObjBase::mjOBJ_KEY, key).map_or_else(|| format!("#{key}"), str::to_owned);
    let nu = model.actuator_trntype().len();
    let ctrl = model.key_ctrl().get(key * nu..(key + 1) * nu).map_or_else(Vec::new, <[f64]>::to_vec);
    Some((name, pose, ctrl))
}

/// Excludes from collision every pair of bodies other than the world whose
/// geoms touch in the model's reference pose; returns how many pairs.
fn exclude_overlaps(spec: &mut MjSpec, model: &MjModel, data: &MjData<&MjModel>) -> usize {
    let mut pairs: Vec<(usize, usize)> = data
        .contact()
        .iter()
        .filter(|c| c.dist < 0.0)
        .map(|c| {
            let (a, b) =
                (model.geom_bodyid()[c.geom[0] as usize] as usize, model.geom_bodyid()[c.geom[1] as usize] as usize);
            (a.min(b), a.max(b))
        })
        .filter(|&(a, b)| a != 0 && a != b)
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    for &(a, b) in &pairs {
        let exclude = spec.add_exclude();
        exclude.set_bodyname1(&tree::name(model, MjtObjBase::mjOBJ_BODY, a));
        exclude.set_bodyname2(&tree::name(model, MjtObjBase::mjOBJ_BODY, b));
    }
    pairs.len()
}

/// The model file as MuJoCo parses it, a URDF's links kept apart and every
/// body and joint named, as the skin refers to them.
pub(super) fn parse(path: &Path) -> Result<MjSpec, MujocoError> {
    let failed = |message: String| MujocoError::Load { path: path.display().to_string(), message };
    if !path.is_file() {
        return Err(failed("no such file".into()));
    }
    let mut spec = MjSpec::from_xml(path).map_err(|e| failed(e.to_string()))?;
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("urdf")) {
        // MuJoCo fuses a URDF's fixed-joint links by default; the skin
        // names them.
        spec.compiler_mut().set_fusestatic(false);
    }
    name_unnamed(&mut spec);
    Ok(spec)
}

/// Names every unnamed body and joint `body<k>` / `joint<k>` (their order
/// in the model), so that sites and servos can be attached by name.
fn name_unnamed(spec: &mut MjSpec) {
    name_bodies(spec.world_body_mut(), &mut 0);
    for (k, joint) in spec.joint_iter_mut().enumerate() {
        if joint.name().is_empty() {
            let _ = joint.set_name(&format!("joint{k}"));
        }
    }
}

/// Names the unnamed bodies below `body`, depth first, counting in `k`.
fn name_bodies(body: &mut MjsBody, k: &mut usize) {
    for child in body.body_iter_mut() {
        *k += 1;
        if child.name().is_empty() {
            let _ = child.set_name(&format!("body{k}"));
        }
        name_bodies(child, k);
    }
}

/// Leaves out the meshes whose file MuJoCo would not find (a missing mesh
/// fails the whole compile): their geoms become specks that neither collide
/// nor weigh. Returns how many meshes were left out.
pub(super) fn drop_missing_meshes(spec: &mut MjSpec, path: &Path) -> Result<usize, MujocoError> {
    let base = path.parent().unwrap_or(Path::new("."));
    let meshdir = PathBuf::from(spec.compiler().meshdir());
    let missing: Vec<String> = spec
        .mesh_iter()
        .filter(|m| !m.file().is_empty() && !resolves(base, &meshdir, m.file()))
        .map(|m| m.name().to_owned())
        .collect();
    if missing.is_empty() {
        return Ok(0);
    }
    for geom in spec.geom_iter_mut() {
        if missing.iter().any(|m| m == geom.meshname()) {
            geom.set_meshname("");
            geom.set_type(MjtGeomBase::mjGEOM_SPHERE);
            *geom.size_mut() = [SPECK_M, 0.0, 0.0];
            geom.set_contype(0);
            geom.set_conaffinity(0);
            geom.set_mass(0.0);
            geom.set_density(0.0);
        }
    }
    for name in &missing {
        if let Some(mesh) = spec.mesh_mut(name) {
            // SAFETY: the mesh belongs to this spec and no geom refers to it
            // any more; nothing holds a reference to it past this call.
            #[allow(unsafe_code)]
            unsafe { mesh.delete() }.map_err(|e| MujocoError::Unsupported(format!("mesh \"{name}\": {e}")))?;
        }
    }
    Ok(missing.len())
}

/// Whether a mesh file MuJoCo is given resolves as MuJoCo resolves it:
/// absolute, or relative to the model's folder and its mesh folder.
fn resolves(base: &Path, meshdir: &Path, file: &str) -> bool {
    if file.contains("://") {
        return false;
    }
    let file = Path::new(file);
    file.is_absolute() && file.is_file() || base.join(meshdir).join(file).is_file()
}
