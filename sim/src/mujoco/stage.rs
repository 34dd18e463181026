//! The grasping experiment's lab in MuJoCo: the person's hands, the object
//! and what it stands on, as bodies MuJoCo moves and the skin feels only
//! through MuJoCo's sensors.
//!
//! The scene hook of the MuJoCo world ([`super::Model::world_on_stage`])
//! adds to the robot's model, through mjSpec: a floor 1 m below the root,
//! two spheres for the person's palms, free bodies put where the person
//! holds them every tick (they touch the robot, not the object), and a
//! tray for the person's hands under the object (it touches the object
//! only), put under it every tick and giving way to the arms' pull. An
//! object put down is a free body with the object file's mass and
//! friction and a contact softness from its stiffness; putting one down
//! recompiles the model from the kept spec and carries the robot's state
//! over. Taking an object back, the person's
//! hands carry it where they took it, as forces on its free joint. The
//! person ([`crate::scene::operator`]) acts on it through [`SharedStage`],
//! as on the built-in scene.

use std::cell::RefCell;
use std::rc::Rc;

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::SpecObject;
use nalgebra::{Isometry3, Point3, Translation3, Vector3};

use crate::scene::hand::Hand;
use crate::scene::object::Object;
use crate::scene::shape::Shape;
use crate::scene::stage::{Look, Stage, TAKE_AWAY_M, TAKE_AWAY_M_PER_S};
use crate::scene::{Contact, Placed, SkinModel};

/// Height of the floor below the root (the chest), m: what a dropped object lands on.
const FLOOR_Z_M: f64 = -1.0;
/// The hands the person has.
const HANDS: usize = 2;
/// Where a body that is not in use waits: far below the floor, out of every ray.
const PARKED: [f64; 3] = [0.0, 0.0, -10.0];
/// Half thickness of the tray the object stands on, m.
const TRAY_HALF_M: f64 = 0.01;
/// The tray's half extent as a fraction of the object's, so the arms
/// closing around the object's sides do not meet the person's hands.
const TRAY_FRACTION: f64 = 0.7;
/// Mass of the tray, kg, and at least this many times the object's (the
/// person holds it up, weightless to MuJoCo): MuJoCo's contact stiffness
/// is an acceleration, so the object's contact with a tray as light as it
/// gives as much more as their reduced mass is less than the object's
/// (a 40 kg box on a 20 kg tray went through it to the floor).
const TRAY_MASS_KG: f64 = 20.0;
const TRAY_MASS_PER_OBJECT_MASS: f64 = 25.0;
/// How readily the person's hands go with an object the arms draw
/// towards the robot: the fraction of its pace towards the robot's root
/// the tray moves at (away or sideways, not at all). A tray standing
/// still (a mocap body) rubbed on the object as a fixed surface whose
/// friction outweighed the arms' drag: 18 of 45 failures of 400 grasps
/// were pulls that stalled hug after hug. Going with the object at its
/// full pace, the object shot ahead of the converging forearms to the
/// chest. At half, 371 of 400 were held (355 standing still); at three
/// quarters, with boxes rounded and hands raised back slowly, 382 and
/// none in pain (375 and 2 at half).
const TRAY_PACE: f64 = 0.75;
/// Contact stiffness of a hand on a cell's cover plate over one of its
/// force cells, N/m: the palm (3000 N/m) in series with the skin's foam
/// under that force cell (1500 N/m), which alone bears a load there.
const HAND_N_PER_M: f64 = 1000.0;
/// Mass of a palm, kg (its contact stiffness is referred to it: MuJoCo's
/// direct stiffness is an acceleration per metre).
const HAND_MASS_KG: f64 = 0.4;
/// How much an object's contact softness outweighs the robot's where they
/// meet (MuJoCo's solmix): the object file's stiffness decides.
const OBJECT_SOLMIX: f64 = 1000.0;
/// Contact bit of the robot's geoms (MJCF writer: contype 2, conaffinity 1).
const ROBOT_AFFINITY: i32 = 1;
const ROBOT_TYPE: i32 = 2;
/// Contact bit of what carries objects (floor, tray).
const SUPPORT_TYPE: i32 = 4;
/// MuJoCo contact priority of what has its own contact softness (the
/// object, the palms) and of the skin's cover; the robot's bare shell and
/// what carries objects keep 0. Where two priorities differ the higher
/// geom's contact parameters all apply, friction among them: an object
/// rubs with its own (the object file's) on the robot's bare shell and on
/// the tray, hard surfaces. Where they are equal MuJoCo mixes them (the
/// softness by `solmix`, the larger friction): the cover grips an object
/// with its own 1.0, and the object's or palm's softness decides their
/// contact with it. At MuJoCo's default (1.0 for every geom) the bare
/// shell gripped as the cover does: round objects put far forward,
/// pinched by bare surfaces, did not slide along them, and a cell reached
/// the high level while pulling (5 of the 100 anywhere-objects). A cover
/// above the object imposed MuJoCo's default softness, far stiffer than
/// the foam: the plates' depth read a hundredth of the force, and a 40 kg
/// box was carried with 450 N on each forearm while its cells read 0.17.
const SOFT_PRIORITY: i32 = 1;
/// MuJoCo's impedance of an object's contacts, the same at any depth. A
/// contact holds still where `d k r = (1 - d) a0` (its depth `r`, the
/// push `a0` per unit mass): at MuJoCo's default (`d` 0.9 to 0.95) the
/// cover was 9 to 19 times stiffer than the foam it stands for, and the
/// arms' force reactions tapped the object (in contact every other control
/// period) instead of pressing it; at 0.5 the contact gives as the foam in
/// series with the object does.
const CONTACT_IMPEDANCE: f64 = 0.5;
/// How much stiffer friction is than the normal contact (MuJoCo's
/// `impratio`, with elliptic friction cones, MuJoCo's advice for
/// grasping): at 1 a hugged trash bin slid down the arms and chest at
/// about 2.5 cm/s under a grip that could carry it; at 10 it sank 1.9 cm
/// over a 3 s hold.
const FRICTION_IMPRATIO: f64 = 10.0;
/// Iterations of MuJoCo's noslip solver, which makes friction inside its
/// cone hold exactly. MuJoCo's friction is as soft as the contact's normal
/// (the foam's give, `CONTACT_IMPEDANCE`), and a soft friction constraint
/// lets a grip inside the cone creep: held objects slid 0.3-1 mm a second
/// (median 0.85 mm in the hold's last second over 91 held of 100 objects,
/// 11 above 2 mm), which cardboard on silicone foam does not. With it they
/// lie still (median 0.03 mm), and what slides is outside the cone.
const NOSLIP_ITERATIONS: i32 = 10;
/// How fast the person raises their hands back under an object they had
/// begun to lower, m/s ([`lowering`]).
const RAISE_M_PER_S: f64 = 0.05;
/// How briskly the person's hands hold a taken-back object where they
/// took it: the natural frequency of their grip, Hz (critically damped).
const HANDS_HZ: f64 = 5.0;
/// How briskly the person's hands under an object keep it from tipping
/// over on the tray, Hz (critically damped, about the object's stiffest
/// axis): an egg-shaped blob stood on end tipped off the tray within 3 s
/// of being put down, before the arms reached it.
const STEADY_HZ: f64 = 2.0;

/// The cells' covers in the lab: as thick as the skin stands off the
/// robot in the built-in world, touching what the robot's geoms touch.
pub(super) fn cover(skin: &SkinModel) -> super::cells::Cover {
    super::cells::Cover {
        height_m: skin.surface_offset_m,
        contype: ROBOT_TYPE,
        conaffinity: ROBOT_AFFINITY,
        friction: skin.friction,
        priority: SOFT_PRIORITY,
    }
}

/// What the person asks of MuJoCo's bodies and what MuJoCo shows them.
#[derive(Default)]
struct Props {
    skin: SkinModel,
    hands: Vec<Hand>,
    /// An object to put down (none: take it away) at the next tick.
    put: Option<Option<(Object, Isometry3<f64>)>>,
    /// The person holds the tray up under the object...
    supporting: bool,
    /// ...this far below where they put it down, m.
    lowered_m: f64,
    /// The person takes the object into their hands where it is now, and
    /// whether to carry it away.
    taking_back: Option<bool>,
    look: Look,
}

/// The lab shared between the person and the MuJoCo engine.
#[derive(Clone, Default)]
pub struct SharedStage(Rc<RefCell<Props>>);

impl SharedStage {
    /// An empty lab, the skin's sensing layers as `skin` models them.
    pub fn new(skin: SkinModel) -> SharedStage {
        SharedStage(Rc::new(RefCell::new(Props { skin, ..Props::default() })))
    }
}

impl Stage for SharedStage {
    fn skin(&self) -> SkinModel {
        self.0.borrow().skin.clone()
    }

    /// The hand presses the cell's cover plate over its first force cell,
    /// where the palm's contact stiffness is referred to.
    fn pat(&self, cell: &Isometry3<f64>, depth_m: f64) -> Hand {
        let props = self.0.borrow();
        let [x, y] = props.skin.force.positions()[0];
        Hand::facing(&(cell * Translation3::new(x, y, 0.0)), props.skin.surface_offset_m, -depth_m)
    }

    fn set_hands(&self, hands: Vec<Hand>) {
        self.0.borrow_mut().hands = hands;
    }

    fn put(&self, object: Option<(Object, Isometry3<f64>)>) {
        let mut props = self.0.borrow_mut();
        props.supporting = object.is_some();
        props.lowered_m = 0.0;
        props.look =
            Look { bare_force_max_n: Some(0.0), resting: object.is_some().then_some(false), ..Look::default() };
        props.put = Some(object);
    }

    fn lower_support(&self, down_m: f64) {
        self.0.borrow_mut().lowered_m = down_m;
    }

    fn let_go(&self) {
        self.0.borrow_mut().supporting = false;
    }

    fn take_back(&self) {
        self.0.borrow_mut().taking_back = Some(false);
    }

    fn carry_away(&self) {
        // Their hands hold the object now, not the tray under it.
        let mut props = self.0.borrow_mut();
        props.taking_back = Some(true);
        props.supporting = false;
    }

    fn look(&self) -> Look {
        self.0.borrow().look.clone()
    }
}

/// The object as a body in the compiled model.
struct Body {
    object: Object,
    geom: usize,
    qpos: usize,
    /// Height of the tray's centre under it; sideways the tray follows it.
    tray_z: f64,
    /// Where it is in the velocities (its free joint's first DoF).
    qvel: usize,
    /// How it was turned when put down, which the person's hands keep
    /// its tilt to while they hold the tray up.
    upright: nalgebra::UnitQuaternion<f64>,
    /// Its largest principal moment of inertia, kg m^2.
    inertia: f64,
    /// Where the person took it into their hands (none: not), and since
    /// when they carry it away, s.
    in_hands_at: Option<([f64; 3], Option<f64>)>,
    /// How far below `tray_z` the tray is, m, and when it was put there, s.
    lowered_m: f64,
    lowered_at_s: f64,
}

/// The lab's bodies in the compiled model, and the spec to recompile.
pub(super) struct Scenery {
    shared: SharedStage,
    spec: MjSpec,
    hand_geom: [usize; HANDS],
    /// Where each palm's free joint is in `qpos` and `qvel`.
    hand_q: [(usize, usize); HANDS],
    /// Where the tray's free joint is in `qpos` and `qvel`.
    tray_q: (usize, usize),
    tray_geom: usize,
    floor_geom: usize,
    object: Option<Body>,
    /// Positions and DoFs of the robot and the hands, which come before the object's.
    kept_nq: usize,
    kept_nv: usize,
    /// Per skin cell: its site.
    cells: Vec<usize>,
    /// Per geom: the cell whose plate it is.
    plate_of: Vec<Option<usize>>,
    /// The robot's root body (the cells' bodies' root).
    robot_root: i32,
    /// Where a cell's force cells are under its plate (cell frame, x y).
    forces: [[f64; 2]; 3],
    /// Per cell: its force cells' normal forces at the end of the last tick, N.
    felt: Vec<[f64; 3]>,
}

/// Logs contact `i` of the object (at trace level, target
/// `skin_sim::mujoco::stage`): why an object slides or stays is each
/// contact's friction against its cone, which no skin reading shows. On
/// the robot: its cell (a plate's, `felt`, or the nearest to bare
/// surface) and the force the truth counts; `cell` none: on the tray or
/// the floor.
fn trace_contact(
    data: &MjData<Box<MjModel>>,
    i: usize,
    object_first: bool,
    cell: Option<usize>,
    felt: bool,
    force_n: f64,
) {
    if !tracing::enabled!(tracing::Level::TRACE) {
        return;
    }
    let c = &data.contact()[i];
    let f = data.contact_force(i);
    // MuJoCo's normal points from the first geom to the second.
    let into = if object_first { -1.0 } else { 1.0 };
    tracing::trace!(
        time_s = data.time(),
        cell,
        felt,
        point = ?c.pos,
        normal_into_object = ?[0, 1, 2].map(|k| into * c.frame[k]),
        force_n,
        solver_normal_n = f[0],
        friction_n = f[1].hypot(f[2]),
        // On the object, world frame: which way each contact drags it.
        friction_on_object = ?[0, 1, 2].map(|k| into * (f[1] * c.frame[3 + k] + f[2] * c.frame[6 + k])),
        friction = c.friction[0],
        "object contact"
    );
}

/// Adds the floor, the hands and the tray to `spec` (before the first compile).
pub(super) fn furnish(spec: &mut MjSpec) {
    let option = spec.option_mut();
    option.cone = MjtCone::mjCONE_ELLIPTIC as i32;
    option.impratio = FRICTION_IMPRATIO;
    option.noslip_iterations = NOSLIP_ITERATIONS;
    let world = spec.world_body_mut();
    let floor = world.add_geom();
    let _ = floor.set_name("stage:floor");
    floor.set_type(MjtGeomBase::mjGEOM_PLANE);
    *floor.size_mut() = [3.0, 3.0, 0.1];
    *floor.pos_mut() = [0.0, 0.0, FLOOR_Z_M];
    floor.set_contype(SUPPORT_TYPE);
    floor.set_conaffinity(0);
    for k in 0..HANDS {
        // A palm the person puts where they want it every tick: a free
        // body (not a mocap, whose contact with a direction the robot
        // cannot give in would push without bound), whose contact
        // softness makes its force its depth times the hand's stiffness.
        let hand = world.add_body();
        let _ = hand.set_name(&format!("stage:hand{k}"));
        *hand.pos_mut() = PARKED;
        hand.set_gravcomp(1.0);
        hand.add_free_joint();
        let palm = hand.add_geom();
        let _ = palm.set_name(&format!("stage:hand{k}"));
        palm.set_type(MjtGeomBase::mjGEOM_SPHERE);
        *palm.size_mut() = [Hand::RADIUS_M, 0.0, 0.0];
        palm.set_mass(HAND_MASS_KG);
        palm.set_contype(ROBOT_AFFINITY);
        palm.set_conaffinity(0);
        let k_acc = HAND_N_PER_M / HAND_MASS_KG;
        *palm.solref_mut() = [-k_acc, -2.0 * k_acc.sqrt()];
        palm.set_solmix(OBJECT_SOLMIX);
        palm.set_priority(SOFT_PRIORITY);
    }
    // A free body too, put under the object every tick with the velocity
    // the person's hands move at, which MuJoCo's friction sees.
    let tray = world.add_body();
    let _ = tray.set_name("stage:tray");
    *tray.pos_mut() = PARKED;
    tray.set_gravcomp(1.0);
    tray.add_free_joint();
    let plate = tray.add_geom();
    let _ = plate.set_name("stage:tray");
    plate.set_type(MjtGeomBase::mjGEOM_BOX);
    *plate.size_mut() = [0.05, 0.05, TRAY_HALF_M];
    plate.set_contype(SUPPORT_TYPE);
    plate.set_conaffinity(0);
}

impl Scenery {
    /// The lab's bodies in `model`, compiled from `spec`.
    pub(super) fn bind(
        shared: SharedStage,
        spec: MjSpec,
        model: &MjModel,
        cells: Vec<(usize, usize)>,
        forces: [[f64; 2]; 3],
    ) -> Result<Scenery, String> {
        let id = |kind, name: &str| model.name_to_id(kind, name).ok_or_else(|| format!("the model lacks {name}"));
        let free = |name: &str| -> Result<(usize, usize), String> {
            let joint = model.body_jntadr()[id(MjtObjBase::mjOBJ_BODY, name)?] as usize;
            Ok((model.jnt_qposadr()[joint] as usize, model.jnt_dofadr()[joint] as usize))
        };
        Ok(Scenery {
            hand_q: [free("stage:hand0")?, free("stage:hand1")?],
            hand_geom: [id(MjtObjBase::mjOBJ_GEOM, "stage:hand0")?, id(MjtObjBase::mjOBJ_GEOM, "stage:hand1")?],
            tray_q: free("stage:tray")?,
            tray_geom: id(MjtObjBase::mjOBJ_GEOM, "stage:tray")?,
            floor_geom: id(MjtObjBase::mjOBJ_GEOM, "stage:floor")?,
            object: None,
            kept_nq: model.ffi().nq as usize,
            kept_nv: model.ffi().nv as usize,
            shared,
            spec,
            plate_of: plates_by_geom(model.ffi().ngeom as usize, &cells),
            robot_root: cells.first().map_or(-1, |&(site, _)| model.body_rootid()[model.site_bodyid()[site] as usize]),
            felt: vec![[0.0; 3]; cells.len()],
            cells: cells.iter().map(|&(site, _)| site).collect(),
            forces,
        })
    }

    /// Before a tick: the object put down or taken away (a recompile), the
    /// hands and the tray where the person holds them.
    pub(super) fn before(&mut self, data: &mut MjData<Box<MjModel>>) {
        let put = self.shared.0.borrow_mut().put.take();
        if let Some(object) = put {
            if let Err(e) = self.rebuild(data, object) {
                tracing::error!("MuJoCo cannot take the object: {e}");
            }
        }
        let taking_back = std::mem::take(&mut self.shared.0.borrow_mut().taking_back);
        if let Some(body) = &mut self.object {
            if let Some(away) = taking_back {
                let at = object_pose(data, body.qpos).translation.vector.into();
                body.in_hands_at = Some((at, away.then(|| data.time())));
            }
            let supporting = self.shared.0.borrow().supporting;
            match body.in_hands_at {
                Some((at, away_since_s)) => {
                    let down_m = away_since_s.map_or(0.0, |s| (TAKE_AWAY_M_PER_S * (data.time() - s)).min(TAKE_AWAY_M));
                    hold_in_hands(data, body, [at[0], at[1], at[2] - down_m]);
                }
                None if supporting => steady(data, body),
                None => data.qfrc_applied_mut()[body.qvel..body.qvel + 6].fill(0.0),
            }
        }
        let props = self.shared.0.borrow();
        for (k, &(qpos, qvel)) in self.hand_q.iter().enumerate() {
            let at: [f64; 3] = props.hands.get(k).map_or(PARKED, |h| h.centre.coords.into());
            place(data, (qpos, qvel), at, [0.0; 2]);
        }
        // The person's hands stay under the object as the arms drag it
        // over them (as the built-in scene's support does): a tray left
        // where the object was put down let it tip off its back edge.
        let (tray, pace) = match &mut self.object {
            Some(body) if props.supporting => {
                let weight = body.object.mass_kg * -data.model().opt().gravity[2];
                let bearing = props.look.support_n.is_some_and(|n| n >= weight);
                let step_m = RAISE_M_PER_S * (data.time() - body.lowered_at_s);
                body.lowered_m = lowering(body.lowered_m, props.lowered_m, bearing, step_m);
                body.lowered_at_s = data.time();
                let at = &data.qpos()[body.qpos..body.qpos + 2];
                ([at[0], at[1], body.tray_z - body.lowered_m], yielding(data, body))
            }
            _ => (PARKED, [0.0; 2]),
        };
        place(data, self.tray_q, tray, pace);
    }

    /// Recompiles the model with `object` (or none) and carries the
    /// robot's state, its servos' targets and the mocap bodies over.
    fn rebuild(
        &mut self,
        data: &mut MjData<Box<MjModel>>,
        object: Option<(Object, Isometry3<f64>)>,
    ) -> Result<(), String> {
        if let Some(old) = self.spec.body_mut("stage:object") {
            // SAFETY: the body belongs to this spec, and nothing holds a
            // reference to it or its children past this call.
            #[allow(unsafe_code)]
            unsafe { old.delete() }.map_err(|e| e.to_string())?;
        }
        if let Some(old) = self.spec.mesh_mut("stage:object") {
            // SAFETY: as the body's, and its geom went with the body.
            #[allow(unsafe_code)]
            unsafe { old.delete() }.map_err(|e| e.to_string())?;
        }
        let tray_z = object.as_ref().map(|(o, pose)| add_object(&mut self.spec, o, pose));
        let model = self.spec.compile().map_err(|e| e.to_string())?;
        let mut next = MjData::new(Box::new(model));
        next.qpos_mut()[..self.kept_nq].copy_from_slice(&data.qpos()[..self.kept_nq]);
        next.qvel_mut()[..self.kept_nv].copy_from_slice(&data.qvel()[..self.kept_nv]);
        next.qacc_warmstart_mut()[..self.kept_nv].copy_from_slice(&data.qacc_warmstart()[..self.kept_nv]);
        next.ctrl_mut().copy_from_slice(data.ctrl());
        next.act_mut().copy_from_slice(data.act());
        next.mocap_pos_mut().copy_from_slice(data.mocap_pos());
        next.mocap_quat_mut().copy_from_slice(data.mocap_quat());
        next.set_time(data.time());
        self.object = match (object, tray_z) {
            (Some((object, pose)), Some(tray_z)) => {
                let model = next.model();
                let geom = model
                    .name_to_id(MjtObjBase::mjOBJ_GEOM, "stage:object")
                    .ok_or("the model lacks the object's geom")?;
                let joint = model
                    .name_to_id(MjtObjBase::mjOBJ_JOINT, "stage:object")
                    .ok_or("the model lacks the object's joint")?;
                let qpos = model.jnt_qposadr()[joint] as usize;
                let qvel = model.jnt_dofadr()[joint] as usize;
                let inertia = model.body_inertia()[model.geom_bodyid()[geom] as usize].into_iter().fold(0.0, f64::max);
                let q = pose.rotation.quaternion();
                let p = pose.translation.vector;
                next.qpos_mut()[qpos..qpos + 7].copy_from_slice(&[p.x, p.y, p.z, q.w, q.i, q.j, q.k]);
                Some(Body {
                    object,
                    geom,
                    qpos,
                    tray_z,
                    qvel,
                    upright: pose.rotation,
                    inertia,
                    in_hands_at: None,
                    lowered_m: 0.0,
                    lowered_at_s: data.time(),
                })
            }
            _ => None,
        };
        next.forward();
        *data = next;
        Ok(())
    }

    /// Cell `cell`'s force cells' normal forces at the end of the last
    /// tick, N: what its plate bears, shared as the plate rests on them.
    pub(super) fn felt(&self, cell: usize) -> [f64; 3] {
        self.felt[cell]
    }

    /// How well geom `geom` reflects the proximity sensors' light, relative
    /// to skin (the curve's calibration): the object as its file says, the
    /// person's hands and tray as skin, the robot's own surface not at all.
    /// A real skin sees its own body; the host does not tell it from an
    /// object, and the forearm cells facing the chest in the pulled pose
    /// evaded it: the person could not teach that pose (the arms ended 41
    /// cm from it after a minute). The built-in world's skin does not see
    /// the robot either.
    pub(super) fn reflectance(&self, data: &MjData<Box<MjModel>>, geom: usize) -> f64 {
        let model = data.model();
        let root = |g: usize| model.body_rootid()[model.geom_bodyid()[g] as usize];
        match &self.object {
            Some(body) if body.geom == geom => body.object.reflectance,
            _ if root(geom) == self.robot_root => 0.0,
            _ => 1.0,
        }
    }

    /// The cell nearest `point` on robot body `body` (any cell, if it has none).
    fn nearest_cell(&self, data: &MjData<Box<MjModel>>, body: usize, point: &Point3<f64>) -> usize {
        let model = data.model();
        let sites = data.site_xpos();
        let distance = |&site: &usize| {
            let away = if model.site_bodyid()[site] as usize == body { 0.0 } else { 1e3 };
            (Vector3::from(sites[site]) - point.coords).norm() + away
        };
        (0..self.cells.len())
            .min_by(|&a, &b| distance(&self.cells[a]).total_cmp(&distance(&self.cells[b])))
            .unwrap_or(0)
    }

    /// After a tick: what the person sees, from MuJoCo's contacts.
    pub(super) fn after(&mut self, data: &MjData<Box<MjModel>>) {
        let mut props = self.shared.0.borrow_mut();
        let look = &mut props.look;
        look.contacts.clear();
        let model = data.model();
        look.object =
            self.object.as_ref().map(|body| Placed { object: body.object.clone(), pose: object_pose(data, body.qpos) });
        let object_geom = self.object.as_ref().map(|b| b.geom);
        // Per force cell (cell, force cell): the object's force and the hands'.
        let mut zones: Vec<[[f64; 3]; 2]> = vec![[[0.0; 3]; 2]; self.cells.len()];
        let (mut resting, mut fallen, mut support_n) = (false, false, 0.0);
        // Per robot body: the object's force on its bare surface.
        let mut bare_n: Vec<(usize, f64)> = Vec::new();
        let hand_geoms = self.hand_geom;
        for (i, c) in data.contact().iter().enumerate() {
            let (g1, g2) = (c.geom1 as usize, c.geom2 as usize);
            let (other, by_hand) = if object_geom.is_some_and(|g| g == g1 || g == g2) {
                (if object_geom == Some(g1) { g2 } else { g1 }, false)
            } else if hand_geoms.contains(&g1) || hand_geoms.contains(&g2) {
                (if hand_geoms.contains(&g1) { g2 } else { g1 }, true)
            } else {
                continue;
            };
            if other == self.floor_geom || other == self.tray_geom {
                // Only the object touches these (the palms collide with neither).
                trace_contact(data, i, object_geom == Some(g1), None, false, 0.0);
                resting = true;
                support_n += data.contact_force(i)[0].max(0.0);
                fallen |= other == self.floor_geom;
                continue;
            }
            let point = Point3::from(Vector3::from(c.pos));
            let plate = self.plate_of.get(other).copied().flatten();
            // MuJoCo's convex collider now and then reports, for one tick,
            // a robot geom flat on the object as deep in it (a chest plate
            // 9.6 cm into a box 13.4 cm thick, where every contact of an
            // object on the robot over 5 N in 100 grasps was at most
            // 7 mm deep on a plate, 12 mm on bare surface): read as the
            // foam's force, that was 84 N on a cell, pain. No surface
            // reaches past the object's middle: such a contact is no
            // touch, and a warning says so.
            if !by_hand && self.object.as_ref().is_some_and(|b| -c.dist > b.object.shape.thinnest_half()) {
                tracing::warn!(time_s = data.time(), depth_m = -c.dist, "a phantom contact of the object, not sensed");
                continue;
            }
            // A plate's force is what compresses the foam under it: the
            // force MuJoCo's soft contact settles to at its depth, as a
            // spring has it. The solver's constraint force also carries,
            // within the step, any push the arm's servo gives (MuJoCo
            // blends a soft contact's acceleration with the unconstrained
            // one): read as the foam's force, a servo's tick-to-tick change
            // came back as 0.5-6 N swings every other tick, and the force
            // reactions fed them. The depth times the object's stiffness
            // read about half of it (MuJoCo's contact rows weigh the depth
            // by the contact's own mass, not the object's): a 0.3 kg box
            // resting on a plate read 1.42 N of its 2.84 N. A palm's force
            // stays its depth times the hand's stiffness: the person puts
            // it where they hold it every tick, never at rest on the plate.
            let force_n = match plate {
                Some(_) if by_hand => HAND_N_PER_M * (-c.dist).max(0.0),
                Some(_) => spring_force(data, c.efc_address, -c.dist),
                None => data.contact_force(i)[0].max(0.0),
            };
            if let Some(u) = plate {
                let cell = super::engine::site_pose(data, self.cells[u]);
                let local = cell.inverse_transform_point(&point);
                // The force cells measure the part along the cell's normal.
                let normal = Vector3::new(c.frame[0], c.frame[1], c.frame[2]);
                let along = force_n * normal.dot(&(cell.rotation * Vector3::z())).abs();
                super::cells::bear(&mut zones[u][usize::from(by_hand)], &self.forces, [local.x, local.y], along);
            }
            if !by_hand {
                let body = model.geom_bodyid()[other] as usize;
                let cell = plate.unwrap_or_else(|| self.nearest_cell(data, body, &point));
                trace_contact(data, i, object_geom == Some(g1), Some(cell), plate.is_some(), force_n);
                look.contacts.push(Contact { cell, point, force_n, felt: plate.is_some() });
                if plate.is_none() {
                    match bare_n.iter_mut().find(|(b, _)| *b == body) {
                        Some((_, sum)) => *sum += force_n,
                        None => bare_n.push((body, force_n)),
                    }
                }
            }
        }
        if let Some(&(_, most)) = bare_n.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            let bare = look.bare_force_max_n.get_or_insert(0.0);
            *bare = bare.max(most);
        }
        for (felt, [object, hand]) in self.felt.iter_mut().zip(zones) {
            *felt = [0, 1, 2].map(|k| object[k] + hand[k]);
            for k in 0..3 {
                look.max_force_n = look.max_force_n.max(object[k] + hand[k]);
                look.grip_force_max_n = look.grip_force_max_n.max(object[k]);
                look.hand_force_max_n = look.hand_force_max_n.max(hand[k]);
            }
        }
        if look.object.is_some() {
            look.resting = Some(resting);
            look.support_n = Some(support_n);
            look.fallen = fallen;
        }
    }
}

/// The force a soft contact settles to at `depth_m` (its constraint rows
/// starting at `efc`, the normal first): MuJoCo's reference acceleration
/// for that depth, stiffness times impedance times depth, over the row's
/// regulariser (times the constraint mass `efc_D`).
fn spring_force(data: &MjData<Box<MjModel>>, efc: i32, depth_m: f64) -> f64 {
    let Ok(row) = usize::try_from(efc) else { return 0.0 };
    // SAFETY: `after` runs after a step, whose pipeline filled the
    // constraint arrays for this tick's contacts; `row` is a contact's own.
    #[allow(unsafe_code)]
    let (kbip, mass) = unsafe { (data.efc_kbip(), data.efc_d()) };
    match (kbip.get(row), mass.get(row)) {
        (Some(&[k, _, imp, _]), Some(&d)) => (k * imp * depth_m.max(0.0) * d).max(0.0),
        _ => 0.0,
    }
}

/// Per geom of a model with `ngeom` geoms: the cell whose plate it is, of
/// `cells` (site, plate geom).
fn plates_by_geom(ngeom: usize, cells: &[(usize, usize)]) -> Vec<Option<usize>> {
    let mut plate_of = vec![None; ngeom];
    for (u, &(_, plate)) in cells.iter().enumerate() {
        plate_of[plate] = Some(u);
    }
    plate_of
}

/// The stiffness of `object` pressed on a cell's cover plate, N/m: its
/// own give in series with the foam under the plate, as stiff as on
/// average over the plate's face.
fn plate_contact_stiffness(object: &Object) -> f64 {
    let skin = crate::scene::SkinModel::default();
    let foam = skin.foam.stiffness_n_per_m * super::cells::plate_stiffness_factor(&skin.force.positions());
    1.0 / (1.0 / foam + 1.0 / object.stiffness_n_per_m)
}

/// Adds `object` at `pose` as a free body; returns the height of the
/// tray's centre under it.
fn add_object(spec: &mut MjSpec, object: &Object, pose: &Isometry3<f64>) -> f64 {
    let rounded = rounded_mesh(&object.shape);
    if let Some(vertices) = &rounded {
        let mesh = spec.add_mesh();
        let _ = mesh.set_name("stage:object");
        mesh.set_uservert(vertices);
    }
    let body = spec.world_body_mut().add_body();
    let _ = body.set_name("stage:object");
    let joint = body.add_free_joint();
    let _ = joint.set_name("stage:object");
    let geom = body.add_geom();
    let _ = geom.set_name("stage:object");
    let (kind, size) = match object.shape {
        _ if rounded.is_some() => {
            geom.set_meshname("stage:object");
            (MjtGeomBase::mjGEOM_MESH, [0.0; 3])
        }
        Shape::Box { half, .. } => (MjtGeomBase::mjGEOM_BOX, [half.x, half.y, half.z]),
        Shape::Cylinder { radius, half_height, .. } => (MjtGeomBase::mjGEOM_CYLINDER, [radius, half_height, 0.0]),
        Shape::Sphere { radius } => (MjtGeomBase::mjGEOM_SPHERE, [radius, 0.0, 0.0]),
        // Its bumps left out: MuJoCo collides with convex shapes.
        Shape::Blob { semi, .. } => (MjtGeomBase::mjGEOM_ELLIPSOID, [semi.x, semi.y, semi.z]),
    };
    geom.set_type(kind);
    *geom.size_mut() = size;
    geom.set_mass(object.mass_kg);
    geom.set_contype(ROBOT_AFFINITY);
    geom.set_conaffinity(ROBOT_TYPE | SUPPORT_TYPE);
    *geom.friction_mut() = [object.friction, 0.005, 0.0001];
    // The object's give in series with the skin's foam under one force
    // cell (as the built-in world presses each), the foam under a cover
    // plate as stiff as on average over its face, as a direct stiffness
    // per unit of the object's mass, critically damped.
    let k = plate_contact_stiffness(object);
    let d = CONTACT_IMPEDANCE;
    let k_acc = k / object.mass_kg.max(1e-3) * (1.0 - d) / d;
    *geom.solref_mut() = [-k_acc, -2.0 * k_acc.sqrt()];
    *geom.solimp_mut() = [d, d, 0.001, 0.5, 2.0];
    geom.set_solmix(OBJECT_SOLMIX);
    geom.set_priority(SOFT_PRIORITY);
    // The free joint's pose is set in the data; the tray goes under the
    // object, as large as most of its footprint.
    let half = |axis: Vector3<f64>| TRAY_FRACTION * object.shape.extent(&(pose.rotation.inverse() * axis));
    let tray_half = [half(Vector3::x()), half(Vector3::y())];
    if let Some(plate) = spec.geom_mut("stage:tray") {
        *plate.size_mut() = [tray_half[0], tray_half[1], TRAY_HALF_M];
        plate.set_mass(TRAY_MASS_KG.max(TRAY_MASS_PER_OBJECT_MASS * object.mass_kg));
    }
    tray_z_under(object, pose)
}

/// How far below where the person put the object down their hands are,
/// m, now at `now_m`, asked to `wanted_m`: lowered as asked (the person
/// lowers them slowly), raised back no more than `step_m` a tick and not
/// once they bear the object's weight (`bearing`), as hands put back
/// under an object the arms hold: put back in one tick, hands lowered
/// 3 cm struck a box the arms held with 38 N, and a chest cell it pressed
/// passed pain (`gen3_24`).
fn lowering(now_m: f64, wanted_m: f64, bearing: bool, step_m: f64) -> f64 {
    if wanted_m >= now_m {
        wanted_m
    } else if bearing {
        now_m
    } else {
        (now_m - step_m).max(wanted_m)
    }
}

/// Rounder than this, m, a box's edges or a cylinder's rims are built
/// rounded ([`rounded_mesh`]).
const MIN_ROUND_M: f64 = 1e-4;
/// Facets per quarter circle of a rounded edge or rim: 22.5 degrees apart.
const ROUNDING_STEPS: usize = 4;
/// Facets around a rounded cylinder: 7.5 degrees apart, its side within
/// 0.3 mm of the circle at the largest radius an object file draws.
const AROUND_STEPS: usize = 48;

/// The vertices of a convex mesh for `shape` if its edges or rims are
/// rounded, its rounding kept: a sharp box's edge or cylinder's rim on a
/// cover plate makes MuJoCo's collider flip the contact's normal between
/// the plate's face and the object's from one tick to the next, and the
/// depth gathered along the one comes back as a blow along the other
/// (a box's edge in `gen3_01`; a cylinder's bottom rim on the lowest
/// chest cell, 26 N, in `gen3_17`).
fn rounded_mesh(shape: &Shape) -> Option<Vec<f32>> {
    match *shape {
        Shape::Box { half, round_m } if round_m > MIN_ROUND_M => Some(rounded_box(half, round_m)),
        Shape::Cylinder { radius, half_height, round_m } if round_m > MIN_ROUND_M => {
            Some(rounded_cylinder(radius, half_height, round_m))
        }
        _ => None,
    }
}

/// The vertices (x y z, for MuJoCo's mesh) whose convex hull is a box of
/// half-extents `half` with edges and corners rounded to `round_m`: each
/// corner's eighth of a sphere of that radius, on a grid of
/// [`ROUNDING_STEPS`] steps per quarter circle.
fn rounded_box(half: Vector3<f64>, round_m: f64) -> Vec<f32> {
    let r = round_m.min(half.min());
    let inner = half.add_scalar(-r);
    let n = ROUNDING_STEPS;
    let mut vertices = Vec::new();
    for corner in 0..8 {
        let sign = Vector3::new(corner & 1, corner & 2, corner & 4).map(|bit| if bit == 0 { 1.0 } else { -1.0 });
        for a in 0..=n {
            for b in 0..=n - a {
                let u = Vector3::new(a as f64, b as f64, (n - a - b) as f64).normalize();
                let p = (inner + u * r).component_mul(&sign);
                vertices.extend(p.iter().map(|&x| x as f32));
            }
        }
    }
    vertices
}

/// The vertices (x y z) whose convex hull is an upright cylinder with
/// rims rounded to `round_m`: [`AROUND_STEPS`] quarter circles of
/// [`ROUNDING_STEPS`] steps about each rim.
fn rounded_cylinder(radius: f64, half_height: f64, round_m: f64) -> Vec<f32> {
    let r = round_m.min(radius).min(half_height);
    let mut vertices = Vec::new();
    for k in 0..AROUND_STEPS {
        let around = std::f64::consts::TAU * k as f64 / AROUND_STEPS as f64;
        for a in 0..=ROUNDING_STEPS {
            let up = std::f64::consts::FRAC_PI_2 * a as f64 / ROUNDING_STEPS as f64;
            let (out, z) = (radius - r + r * up.cos(), half_height - r + r * up.sin());
            for z in [z, -z] {
                vertices.extend([out * around.cos(), out * around.sin(), z].map(|x| x as f32));
            }
        }
    }
    vertices
}

/// The person's hands carry `body`'s weight and hold it near `at`, as
/// forces on its free joint (they are not bodies MuJoCo collides).
fn hold_in_hands(data: &mut MjData<Box<MjModel>>, body: &Body, at: [f64; 3]) {
    let m = body.object.mass_kg;
    let g = data.model().opt().gravity;
    let w = std::f64::consts::TAU * HANDS_HZ;
    let (q, v) = (&data.qpos()[body.qpos..body.qpos + 3], &data.qvel()[body.qvel..body.qvel + 6]);
    let mut f = [0.0; 6];
    for k in 0..3 {
        f[k] = m * (-g[k] + w * w * (at[k] - q[k]) - 2.0 * w * v[k]);
        // Turning is damped alone, as a hand's grip does.
        f[k + 3] = -m * 0.01 * 2.0 * w * v[k + 3];
    }
    data.qfrc_applied_mut()[body.qvel..body.qvel + 6].copy_from_slice(&f);
}

/// The person's hands under the tray keep `body` from tipping over: a
/// torque about the horizontal axes back to the tilt it was put down
/// with; turning it about the vertical and pushing it over the tray is
/// left to the arms.
fn steady(data: &mut MjData<Box<MjModel>>, body: &Body) {
    let turn = object_pose(data, body.qpos).rotation;
    let tilt = (turn * body.upright.inverse()).scaled_axis();
    // A free joint's angular velocity and torque are in the body's frame.
    let v = &data.qvel()[body.qvel + 3..body.qvel + 6];
    let spin = turn * Vector3::new(v[0], v[1], v[2]);
    let w = std::f64::consts::TAU * STEADY_HZ;
    let mut torque = -body.inertia * (w * w * tilt + 2.0 * w * spin);
    torque.z = 0.0;
    let local = turn.inverse() * torque;
    let f = &mut data.qfrc_applied_mut()[body.qvel..body.qvel + 6];
    f[..3].fill(0.0);
    f[3..].copy_from_slice(local.as_slice());
}

/// Puts the free body whose free joint starts at `qpos` and `qvel`
/// upright at `at`, moving horizontally at `velocity`.
fn place(data: &mut MjData<Box<MjModel>>, (qpos, qvel): (usize, usize), at: [f64; 3], velocity: [f64; 2]) {
    data.qpos_mut()[qpos..qpos + 7].copy_from_slice(&[at[0], at[1], at[2], 1.0, 0.0, 0.0, 0.0]);
    data.qvel_mut()[qvel..qvel + 6].copy_from_slice(&[velocity[0], velocity[1], 0.0, 0.0, 0.0, 0.0]);
}

/// The horizontal velocity of the person's hands under `body`: with it
/// where the arms draw it towards the robot's root (the world's origin),
/// at [`TRAY_PACE`] of its pace, and still where it goes any other way.
fn yielding(data: &MjData<Box<MjModel>>, body: &Body) -> [f64; 2] {
    let (q, v) = (&data.qpos()[body.qpos..body.qpos + 2], &data.qvel()[body.qvel..body.qvel + 2]);
    let distance = q[0].hypot(q[1]);
    if distance < 1e-6 {
        return [0.0; 2];
    }
    let toward = [-q[0] / distance, -q[1] / distance];
    let pace = (v[0] * toward[0] + v[1] * toward[1]).max(0.0) * TRAY_PACE;
    [pace * toward[0], pace * toward[1]]
}

/// Height of the tray's centre that carries `object` standing at `pose`.
fn tray_z_under(object: &Object, pose: &Isometry3<f64>) -> f64 {
    let bottom = object.shape.extent(&(pose.rotation.inverse() * -Vector3::z()));
    pose.translation.z - bottom - TRAY_HALF_M
}

/// The pose of the free body whose position starts at `qpos`.
fn object_pose(data: &MjData<Box<MjModel>>, qpos: usize) -> Isometry3<f64> {
    let q = &data.qpos()[qpos..qpos + 7];
    Isometry3::from_parts(
        Translation3::new(q[0], q[1], q[2]),
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[3], q[4], q[5], q[6])),
    )
}

/// The grasping experiment's world in MuJoCo: `model` (an MJCF of the
/// built-in robot; none: the built-in robot written as one) wearing
/// `setup`'s skin, in the lab, noise drawn from `seed`; and the lab the
/// person acts on.
pub fn experiment_world(
    model: Option<&std::path::Path>,
    setup: &crate::scene::experiment::Setup,
    seed: u64,
) -> Result<(crate::world::World, SharedStage), super::MujocoError> {
    let loaded = super::Model::built_in(model, seed)?;
    let cfg = crate::world::WorldConfig { seed, ..crate::world::WorldConfig::default() };
    let stage = SharedStage::new(SkinModel::default());
    let world = loaded.world_on_stage(setup.skin.clone(), cfg, stage.clone())?;
    Ok((world, stage))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hands_lower_as_asked_and_rise_back_slowly_until_they_bear_the_weight() {
        assert_eq!(lowering(0.01, 0.02, false, 0.001), 0.02, "lowered as asked");
        assert_eq!(lowering(0.01, 0.02, true, 0.001), 0.02, "lowered as asked, bearing or not");
        assert!((lowering(0.03, 0.0, false, 0.001) - 0.029).abs() < 1e-12, "raised a step");
        assert_eq!(lowering(0.0005, 0.0, false, 0.001), 0.0, "no higher than asked");
        assert_eq!(lowering(0.03, 0.0, true, 0.001), 0.03, "no higher once bearing the weight");
    }

    #[test]
    fn a_rounded_cylinder_s_vertices_lie_on_its_surface_and_reach_its_side_and_ends() {
        let (radius, half_height, round_m) = (0.114, 0.141, 0.005);
        let shape = Shape::Cylinder { radius, half_height, round_m };
        let points = vertices(&rounded_cylinder(radius, half_height, round_m));
        assert_eq!(points.len(), AROUND_STEPS * (ROUNDING_STEPS + 1) * 2);
        for p in &points {
            assert!(shape.distance(p).abs() < 1e-7, "{p} is {} m off the surface", shape.distance(p));
        }
        let reach = |f: fn(&Point3<f64>) -> f64| points.iter().map(f).fold(f64::MIN, f64::max);
        assert!((reach(|p| p.x) - radius).abs() < 1e-7 && (reach(|p| -p.z) - half_height).abs() < 1e-7);
        // The rim is cut by the rounding: no vertex where the sharp rim is.
        let rim = Point3::new(radius, 0.0, half_height);
        let nearest = points.iter().map(|p| (p - rim).norm()).fold(f64::MAX, f64::min);
        assert!(nearest > round_m * (2f64.sqrt() - 1.0) - 1e-7, "{nearest} m from the rim");
    }

    /// A mesh's vertices as points.
    fn vertices(mesh: &[f32]) -> Vec<Point3<f64>> {
        mesh.chunks(3).map(|p| Point3::new(p[0].into(), p[1].into(), p[2].into())).collect()
    }

    #[test]
    fn a_rounded_box_s_vertices_lie_on_its_surface_and_reach_its_faces() {
        let (half, round_m) = (Vector3::new(0.05, 0.156, 0.138), 0.016);
        let shape = Shape::Box { half, round_m };
        let points = vertices(&rounded_box(half, round_m));
        assert_eq!(points.len(), 8 * (ROUNDING_STEPS + 1) * (ROUNDING_STEPS + 2) / 2);
        for p in &points {
            assert!(shape.distance(p).abs() < 1e-7, "{p} is {} m off the surface", shape.distance(p));
        }
        for axis in 0..3 {
            let reach = points.iter().map(|p| p[axis]).fold(f64::MIN, f64::max);
            assert!((reach - half[axis]).abs() < 1e-7, "axis {axis} reaches {reach}, not {}", half[axis]);
        }
        // A corner is cut by the rounding: no vertex where the sharp box's is.
        let corner = Point3::from(half);
        let nearest = points.iter().map(|p| (p - corner).norm()).fold(f64::MAX, f64::min);
        assert!(nearest > round_m * (3f64.sqrt() - 1.0) - 1e-7 && nearest < round_m, "{nearest} m from the corner");
    }
}
