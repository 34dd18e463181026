//! A scene of objects and hands that touch the skin (sections 5 and 6).
//!
//! Objects of given shape, weight, stiffness and reflectance stand on a
//! support between the robot's arms (Figure 16); a person's hands can be put
//! anywhere. Given the world pose of every skin cell, the scene computes
//! what the cell feels: the force on each of its three force cells (a
//! series of springs: the foam under the skin and the object's surface) and
//! the infrared intensity its proximity sensor sees.
//!
//! Objects move quasi-statically: when the horizontal sum of the contact
//! forces exceeds the support's friction, the object slides in that
//! direction (viscously, never past the point where the forces balance
//! friction again), so arms can push and pull it; when their moment about
//! the vertical through its centre exceeds the support's friction moment,
//! it turns the same way. It does not tip.
//! The robot's surface without skin, when given as points, pushes objects
//! too but feels nothing; the skin does not see the robot's own body.

pub mod experiment;
pub mod force;
pub mod generated;
pub mod hand;
pub mod held;
pub mod object;
pub mod object_error;
pub mod object_file;
pub mod operator;
pub mod person;
pub mod placement;
pub mod proximity;
pub mod shape;
mod shared;
pub mod stage;

pub use shared::SharedScene;

use nalgebra::{Isometry3, Point3, Vector3};
use rand::Rng;

use force::{Foam, ForceCells};
use hand::Hand;
use object::Object;
use proximity::Vcnl4010;
use shape::Shape;

/// Standard gravity, m/s^2.
const G: f64 = 9.81;

/// How far past its test the broad phase's bound must be for a skip, m:
/// far above the rounding of a distance, so no skip changes a reading.
const BROAD_PHASE_MARGIN_M: f64 = 1e-9;

/// The sensing layers of a skin cell.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinModel {
    /// The foam between robot and cell.
    pub foam: Foam,
    /// The three force cells.
    pub force: ForceCells,
    /// The proximity sensor.
    pub proximity: Vcnl4010,
    /// Height of the outer skin surface above the cell's mounting point
    /// (foam, cell and cover), m.
    pub surface_offset_m: f64,
    /// Coulomb friction of the elastomer cover on objects.
    pub friction: f64,
}

impl SkinModel {
    /// Raw counts (proximity, three forces) of a sense, with sensor noise.
    pub fn counts(&self, sense: &CellSense, rng: &mut impl Rng) -> (u16, [u16; 3]) {
        let p = self.proximity.counts(sense.proximity, rng);
        let f = sense.force_n.map(|f| self.force.counts(f, rng));
        (p, f)
    }
}

impl Default for SkinModel {
    fn default() -> SkinModel {
        SkinModel {
            foam: Foam::default(),
            force: ForceCells::default(),
            proximity: Vcnl4010::default(),
            surface_offset_m: 0.008,
            friction: 1.0,
        }
    }
}

/// What one cell senses, in physical units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellSense {
    /// Normal force on each force cell, N.
    pub force_n: [f64; 3],
    /// Normalized proximity intensity, 0..1.
    pub proximity: f64,
}

/// An object standing in the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Placed {
    /// What it is.
    pub object: Object,
    /// Where it is (world frame).
    pub pose: Isometry3<f64>,
}

/// A contact of the robot with an object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The skin cell there, or the one whose body carries the bare surface there.
    pub cell: usize,
    /// Where, world frame.
    pub point: Point3<f64>,
    /// How hard, N.
    pub force_n: f64,
    /// Felt by the skin (else bare robot surface).
    pub felt: bool,
}

/// Something that can be touched: an object or a hand.
struct Touchable<'a> {
    shape: &'a Shape,
    pose: Isometry3<f64>,
    stiffness_n_per_m: f64,
    reflectance: f64,
}

/// Robot surface without skin: it pushes objects but feels nothing.
#[derive(Clone, Debug)]
struct Bare {
    /// The cell whose frame carries the points (a cell on the same body).
    cell: usize,
    /// Surface points in that cell's frame, m.
    points: Vec<Point3<f64>>,
    /// A sphere holding every point (centre in the cell's frame, radius in
    /// m), for the broad phase.
    bound: (Point3<f64>, f64),
}

/// Objects, hands and the physics between them and the skin.
#[derive(Clone, Debug)]
pub struct Scene {
    skin: SkinModel,
    objects: Vec<Placed>,
    bare: Vec<Bare>,
    hands: Vec<Hand>,
    damping_n_s_per_m: f64,
    last_time_s: Option<f64>,
    last_windows: Vec<Point3<f64>>,
    sensed: Vec<CellSense>,
    contacts: Vec<Contact>,
    max_force_n: f64,
    max_object_force_n: f64,
    max_hand_force_n: f64,
    max_bare_force_n: f64,
}

impl Scene {
    /// An empty scene.
    pub fn new(skin: SkinModel) -> Scene {
        Scene {
            skin,
            objects: Vec::new(),
            bare: Vec::new(),
            hands: Vec::new(),
            damping_n_s_per_m: 40.0,
            last_time_s: None,
            last_windows: Vec::new(),
            sensed: Vec::new(),
            contacts: Vec::new(),
            max_force_n: 0.0,
            max_object_force_n: 0.0,
            max_hand_force_n: 0.0,
            max_bare_force_n: 0.0,
        }
    }

    /// The skin's sensing layers.
    pub fn skin(&self) -> &SkinModel {
        &self.skin
    }

    /// Puts an object at `pose`; returns its index.
    pub fn place(&mut self, object: Object, pose: Isometry3<f64>) -> usize {
        self.objects.push(Placed { object, pose });
        self.objects.len() - 1
    }

    /// Takes every object away.
    pub fn clear_objects(&mut self) {
        self.objects.clear();
    }

    /// The objects.
    pub fn objects(&self) -> &[Placed] {
        &self.objects
    }

    /// Adds robot surface without skin, as points in the frame of cell
    /// `cell` (skin order), which sits on the same rigid body: objects are
    /// pushed by it (grounded on insensitive spots, as the paper puts it)
    /// but no cell feels that.
    pub fn add_bare_surface(&mut self, cell: usize, points: Vec<Point3<f64>>) {
        let centre = points.iter().fold(Vector3::zeros(), |sum, p| sum + p.coords) / points.len().max(1) as f64;
        let radius = points.iter().map(|p| (p.coords - centre).norm()).fold(0.0, f64::max);
        self.bare.push(Bare { cell, points, bound: (Point3::from(centre), radius) });
    }

    /// Puts a person's hands somewhere (none: taken away).
    pub fn set_hands(&mut self, hands: Vec<Hand>) {
        self.hands = hands;
    }

    /// The hands present.
    pub fn hands(&self) -> &[Hand] {
        &self.hands
    }

    /// The largest force on any force cell since the start (or the last
    /// reset), N.
    pub fn max_force_n(&self) -> f64 {
        self.max_force_n
    }

    /// The largest force of an object (not a hand) on any force cell
    /// since the start (or the last reset), N: the grip.
    pub fn max_object_force_n(&self) -> f64 {
        self.max_object_force_n
    }

    /// The largest force of a person's hand on any force cell since the
    /// start (or the last reset), N: pats and guidance.
    pub fn max_hand_force_n(&self) -> f64 {
        self.max_hand_force_n
    }

    /// The largest force of the objects on one bare surface (what one
    /// [`Scene::add_bare_surface`] added: in the experiments, a link's)
    /// since the start (or the last reset), N: a pinch no cell feels.
    pub fn max_bare_force_n(&self) -> f64 {
        self.max_bare_force_n
    }

    /// Forgets the largest forces.
    pub fn reset_max_force(&mut self) {
        self.max_force_n = 0.0;
        self.max_object_force_n = 0.0;
        self.max_hand_force_n = 0.0;
        self.max_bare_force_n = 0.0;
    }

    /// Where the robot touched an object at the last [`Scene::sense`]:
    /// felt by the skin or not.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// What the cells at `poses` (world frame, z the outward normal) sense
    /// at `time_s`; then the objects move under the cells' forces until the
    /// next call.
    pub fn sense(&mut self, time_s: f64, poses: &[Isometry3<f64>]) -> &[CellSense] {
        let dt = self.last_time_s.map_or(0.0, |t| (time_s - t).max(0.0));
        self.last_time_s = Some(time_s);
        self.sensed.clear();
        self.sensed.resize(poses.len(), CellSense::default());
        self.contacts.clear();
        let mut loads = vec![Load::default(); self.objects.len()];
        let windows: Vec<Point3<f64>> =
            poses.iter().map(|p| p * Point3::new(0.0, 0.0, self.skin.surface_offset_m)).collect();
        let moved = dt > 0.0 && self.last_windows.len() == windows.len();
        for (u, (cell, sense)) in poses.iter().zip(self.sensed.iter_mut()).enumerate() {
            let velocity = if moved { (windows[u] - self.last_windows[u]) / dt } else { Vector3::zeros() };
            for (placed, load) in self.objects.iter().zip(loads.iter_mut()) {
                let body = Touchable {
                    shape: &placed.object.shape,
                    pose: placed.pose,
                    stiffness_n_per_m: placed.object.stiffness_n_per_m,
                    reflectance: placed.object.reflectance,
                };
                touch(&self.skin, cell, &body, sense, Some((load, velocity)));
            }
            // Objects first: what the cell feels so far is theirs alone.
            let by_objects = sense.force_n;
            let felt: f64 = by_objects.iter().sum();
            if felt > 0.0 {
                self.contacts.push(Contact { cell: u, point: windows[u], force_n: felt, felt: true });
            }
            for h in &self.hands {
                // The proximity curve is calibrated on skin: reflectance 1.
                let shape = h.shape();
                let body = Touchable {
                    shape: &shape,
                    pose: Isometry3::translation(h.centre.x, h.centre.y, h.centre.z),
                    stiffness_n_per_m: h.stiffness_n_per_m,
                    reflectance: 1.0,
                };
                touch(&self.skin, cell, &body, sense, None);
            }
            sense.proximity = sense.proximity.min(1.0);
            for (all, object) in sense.force_n.iter().zip(by_objects) {
                self.max_force_n = self.max_force_n.max(*all);
                self.max_object_force_n = self.max_object_force_n.max(object);
                self.max_hand_force_n = self.max_hand_force_n.max(all - object);
            }
        }
        for bare in &self.bare {
            let Some(pose) = poses.get(bare.cell) else { continue };
            let mut on_surface_n = 0.0;
            let centre = pose * bare.bound.0;
            for (placed, load) in self.objects.iter().zip(loads.iter_mut()) {
                // The broad phase: no point of the surface can be inside.
                let nearest_m = (centre.coords - placed.pose.translation.vector).norm() - bare.bound.1;
                if placed.object.shape.distance_at_least(nearest_m) > BROAD_PHASE_MARGIN_M {
                    continue;
                }
                for p in &bare.points {
                    let at = pose * p;
                    let from_centre = (at.coords - placed.pose.translation.vector).norm();
                    if placed.object.shape.distance_at_least(from_centre) > BROAD_PHASE_MARGIN_M {
                        continue;
                    }
                    let local = placed.pose.inverse_transform_point(&at);
                    let depth = -placed.object.shape.distance(&local);
                    if depth > 0.0 {
                        // A rigid robot surface against the object's own compliance.
                        let into_body = -(placed.pose.rotation * placed.object.shape.normal(&local));
                        let force_n = depth * placed.object.stiffness_n_per_m;
                        self.contacts.push(Contact { cell: bare.cell, point: at, force_n, felt: false });
                        on_surface_n += force_n;
                        let centre = placed.pose.translation.vector;
                        load.press(&centre, &at, &into_body, force_n, placed.object.stiffness_n_per_m);
                    }
                }
            }
            self.max_bare_force_n = self.max_bare_force_n.max(on_surface_n);
        }
        for (placed, load) in self.objects.iter_mut().zip(loads) {
            slide(placed, &load, self.damping_n_s_per_m, dt);
        }
        self.last_windows = windows;
        &self.sensed
    }

    /// What every cell sensed at the last [`Scene::sense`].
    pub fn sensed(&self) -> &[CellSense] {
        &self.sensed
    }
}

/// What the skin does to one object in one tick.
#[derive(Clone, Copy, Debug, Default)]
struct Load {
    /// Horizontal sum of the contact forces, N.
    push: Vector3<f64>,
    /// Their stiffness against a displacement of the object, N/m.
    stiffness: f64,
    /// Largest friction force the gripping cells can exert, N.
    grip_n: f64,
    /// Sum of contact force times the cell's horizontal sliding velocity.
    drag: Vector3<f64>,
    /// Sum of the gripping cells' contact forces, N.
    gripping_n: f64,
    /// Moment of the contact forces about the vertical through the
    /// object's centre, N m.
    moment: f64,
    /// Their stiffness against a turn of the object, N m/rad.
    turn_stiffness: f64,
}

impl Load {
    /// Adds a contact force `force_n` along the horizontal of `into_body`
    /// at `point`, of stiffness `k` along it, on a body centred at `centre`.
    fn press(&mut self, centre: &Vector3<f64>, point: &Point3<f64>, into_body: &Vector3<f64>, force_n: f64, k: f64) {
        let along = horizontal(into_body);
        self.push += force_n * along;
        self.stiffness += k;
        // A turn by a small angle moves the point by (z x r) * angle; the
        // part of that along the force is the lever.
        let r = horizontal(&(point.coords - centre));
        let lever = r.x * along.y - r.y * along.x;
        self.moment += force_n * lever;
        self.turn_stiffness += k * lever * lever;
    }
}

fn horizontal(v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(v.x, v.y, 0.0)
}

/// Adds what `body` does to the cell at `cell`; when the body is an object,
/// accumulates the cell's push, stiffness and grip on it (`velocity`: the
/// cell window's velocity).
fn touch(
    skin: &SkinModel,
    cell: &Isometry3<f64>,
    body: &Touchable<'_>,
    sense: &mut CellSense,
    load: Option<(&mut Load, Vector3<f64>)>,
) {
    let window = cell * Point3::new(0.0, 0.0, skin.surface_offset_m);
    let reach = skin.proximity.range_m + skin.force.radius_m;
    // The broad phase: a cell beyond the body's bounding distance (with a
    // margin for rounding) is left as the distance test below would leave it.
    let from_centre = (window.coords - body.pose.translation.vector).norm();
    if body.shape.distance_at_least(from_centre) > reach + BROAD_PHASE_MARGIN_M {
        return;
    }
    let axis = cell.rotation * Vector3::z();
    let local = body.pose.inverse_transform_point(&window);
    let distance = body.shape.distance(&local);
    if distance > reach {
        return;
    }
    let towards = -(body.pose.rotation * body.shape.normal(&local));
    sense.proximity += skin.proximity.intensity(distance, towards.dot(&axis), body.reflectance);
    if distance > skin.force.radius_m {
        return;
    }
    let mut load = load;
    for (i, [x, y]) in skin.force.positions().into_iter().enumerate() {
        let at = cell * Point3::new(x, y, skin.surface_offset_m);
        let p = body.pose.inverse_transform_point(&at);
        let depth = -body.shape.distance(&p);
        if depth <= 0.0 {
            continue;
        }
        let into_body = -(body.pose.rotation * body.shape.normal(&p));
        let f = skin.foam.contact_force(depth, body.stiffness_n_per_m);
        // The force cell measures the part along its normal.
        sense.force_n[i] += f * into_body.dot(&axis).max(0.0);
        if let Some((load, velocity)) = load.as_mut() {
            let k = (skin.foam.contact_force(depth + 1e-6, body.stiffness_n_per_m) - f) / 1e-6;
            load.press(&body.pose.translation.vector, &at, &into_body, f, k);
            // The cover grips: its motion along the surface drags the object.
            let sliding = *velocity - into_body * velocity.dot(&into_body);
            load.grip_n += skin.friction * f;
            load.drag += f * horizontal(&sliding);
            load.gripping_n += f;
        }
    }
}

/// Quasi-static motion on the support. The gripping skin carries the
/// object along with its own sliding velocity when its grip, with the
/// push, beats the support's friction; beyond that friction the push makes
/// it slide, viscously, but never further than where the contact forces
/// would fall back to the limit. It turns the same way under the moment.
fn slide(placed: &mut Placed, load: &Load, damping: f64, dt: f64) {
    if dt <= 0.0 {
        return;
    }
    turn(placed, load, damping, dt);
    let mut limit = placed.object.friction * placed.object.mass_kg * G;
    if load.gripping_n > 0.0 {
        let carried = load.drag / load.gripping_n;
        let along = carried.try_normalize(1e-9).map_or(0.0, |d| load.grip_n + load.push.dot(&d));
        if along > limit {
            placed.pose.translation.vector += carried * dt;
            // Already moving: the support holds no longer.
            limit = 0.0;
        }
    }
    let magnitude = load.push.norm();
    if magnitude <= limit {
        return;
    }
    let excess = magnitude - limit;
    let mut step = excess / damping * dt;
    if load.stiffness > 0.0 {
        step = step.min(excess / load.stiffness);
    }
    placed.pose.translation.vector += load.push / magnitude * step;
}

/// The farthest a point of a turning object moves in one step, m: a tenth
/// of the foam under the skin.
const MAX_TURN_STEP_M: f64 = 0.0005;

/// Quasi-static turn about the vertical through the object's centre: the
/// support's friction, spread evenly over the face it stands on, resists
/// with at most two thirds of its force times that face's radius; beyond
/// that the moment turns it, viscously (the same drag per unit area as a
/// slide), never past where the moment falls back to the limit, and its
/// farthest point moves at most [`MAX_TURN_STEP_M`] per step: the
/// stiffness counts only the contacts it has, and a corner turning
/// freely must not jump into a cell between two samples.
fn turn(placed: &mut Placed, load: &Load, damping: f64, dt: f64) {
    let radius = placed.object.shape.footprint_radius();
    let limit = 2.0 / 3.0 * placed.object.friction * placed.object.mass_kg * G * radius;
    let excess = load.moment.abs() - limit;
    if excess <= 0.0 {
        return;
    }
    let mut angle = excess / (damping * radius * radius / 2.0) * dt;
    if load.turn_stiffness > 0.0 {
        angle = angle.min(excess / load.turn_stiffness);
    }
    angle = angle.min(MAX_TURN_STEP_M / placed.object.shape.bounding_radius());
    let about = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle.copysign(load.moment));
    placed.pose.rotation = about * placed.pose.rotation;
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A cell at `x` on the world x axis facing +x (z along +x).
    fn cell_at(x: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            nalgebra::Translation3::new(x, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2),
        )
    }

    #[test]
    fn proximity_guidance_reacts_about_5_cm_before_contact() {
        let mut scene = Scene::new(SkinModel::default());
        let cell = cell_at(0.0);
        let offset = scene.skin().surface_offset_m;
        let mut first_seen = None;
        // The hand approaches from 10 cm in 0.5 mm steps.
        for k in 0..=200 {
            let gap = 0.1 - 0.0005 * f64::from(k);
            scene.set_hands(vec![Hand::facing(&cell, offset, gap)]);
            let p = scene.sense(f64::from(k) * 0.004, &[cell])[0].proximity;
            if p > 0.01 && first_seen.is_none() {
                first_seen = Some(gap);
            }
        }
        let gap = first_seen.expect("the hand is seen");
        assert!((gap - 0.05).abs() < 0.002, "threshold 0.01 crossed {gap} m before contact");
        let touching = scene.sense(1.0, &[cell])[0];
        assert!(touching.proximity > 0.8, "close contact at the surface");
        assert_eq!(touching.force_n, [0.0; 3]);
    }

    #[test]
    fn a_pressing_hand_loads_the_force_cells_through_the_foam() {
        let mut scene = Scene::new(SkinModel::default());
        let cell = cell_at(0.0);
        let offset = scene.skin().surface_offset_m;
        scene.set_hands(vec![Hand::facing(&cell, offset, -0.001)]);
        let s = scene.sense(0.0, &[cell])[0];
        // The palm is 1 mm into the skin on the axis; at the force cells, 7 mm
        // off the axis, the round palm is less deep. Foam (1500 N/m) and hand
        // (3000 N/m) are in series; the cell measures the normal part.
        let (r, c) = (Hand::RADIUS_M, Hand::RADIUS_M - 0.001);
        let from_centre = 0.007f64.hypot(c);
        let expected = (r - from_centre) * 1000.0 * c / from_centre;
        for f in s.force_n {
            assert!((f - expected).abs() < 1e-6, "{:?}, expected {expected}", s.force_n);
        }
        assert!((scene.max_force_n() - s.force_n.iter().fold(0.0, |m: f64, f| m.max(*f))).abs() < 1e-12);
        assert_eq!((scene.max_hand_force_n(), scene.max_object_force_n()), (scene.max_force_n(), 0.0), "a hand's");
        let far = scene.sense(0.004, &[cell_at(-0.5)])[0];
        assert_eq!(far, CellSense::default());
    }

    #[test]
    fn bare_surface_pushes_unfelt() {
        let mut scene = Scene::new(SkinModel::default());
        scene.place(Object::by_name("box_lid").unwrap(), Isometry3::translation(0.1, 0.0, 0.0));
        // A bare patch of points 1 cm into the lid's -x face (at x = 0.065),
        // carried by a cell far away.
        let points = (-2..=2).map(|k| Point3::new(0.075, f64::from(k) * 0.01, 0.0)).collect();
        scene.add_bare_surface(0, points);
        let far = Isometry3::identity();
        let start = scene.objects()[0].pose.translation.x;
        for k in 0..50 {
            let s = scene.sense(f64::from(k) * 0.004, &[far]);
            assert_eq!(s[0].force_n, [0.0; 3], "nothing is felt");
        }
        let unfelt = scene.contacts();
        assert!(unfelt.iter().all(|c| !c.felt && c.cell == 0 && c.force_n > 0.0) && !unfelt.is_empty());
        assert!(scene.objects()[0].pose.translation.x > start + 0.005, "the lid was pushed away");
    }

    #[test]
    fn a_bare_surface_s_force_is_its_points_summed_the_largest_surface_kept_until_reset() {
        let mut scene = Scene::new(SkinModel::default());
        scene.place(Object::by_name("box_lid").unwrap(), Isometry3::translation(0.1, 0.0, 0.0));
        let lid = scene.objects()[0].object.clone();
        let face_x = 0.1 + lid.shape.distance(&Point3::new(-1.0, 0.0, 0.0)) - 1.0;
        // Five points 1 mm into the lid's -x face on one surface, one on another.
        let depth = 0.001;
        scene.add_bare_surface(0, (-2..=2).map(|k| Point3::new(face_x + depth, f64::from(k) * 0.01, 0.0)).collect());
        scene.add_bare_surface(0, vec![Point3::new(face_x + depth, 0.03, 0.0)]);
        scene.sense(0.0, &[Isometry3::identity()]);
        let expected = 5.0 * depth * lid.stiffness_n_per_m;
        assert!((scene.max_bare_force_n() - expected).abs() < 1e-6 * expected, "{} N", scene.max_bare_force_n());
        scene.clear_objects();
        scene.sense(0.004, &[Isometry3::identity()]);
        assert!((scene.max_bare_force_n() - expected).abs() < 1e-6 * expected, "the largest is kept");
        scene.reset_max_force();
        assert_eq!(scene.max_bare_force_n(), 0.0);
    }

    #[test]
    fn a_push_beside_the_centre_turns_an_object_one_through_it_does_not() {
        let yaw = |scene: &Scene| scene.objects()[0].pose.rotation.euler_angles().2;
        let pushed = |ys: [f64; 5]| {
            let mut scene = Scene::new(SkinModel::default());
            scene.place(Object::by_name("box_lid").unwrap(), Isometry3::translation(0.1, 0.0, 0.0));
            // Bare points 1 cm into the lid's -x face (at x = 0.04).
            scene.add_bare_surface(0, ys.iter().map(|y| Point3::new(0.05, *y, 0.0)).collect());
            let mut turns = Vec::new();
            for k in 0..50 {
                let before = yaw(&scene);
                scene.sense(f64::from(k) * 0.004, &[Isometry3::identity()]);
                turns.push((yaw(&scene) - before).abs());
            }
            (scene, turns)
        };
        let (scene, _) = pushed([-0.02, -0.01, 0.0, 0.01, 0.02]);
        assert_eq!(yaw(&scene), 0.0, "pushed square on its centre, it only slides");
        let (scene, turns) = pushed([0.10, 0.11, 0.12, 0.13, 0.14]);
        assert!(yaw(&scene) < -0.005, "pushed at its left end, it turns clockwise: {} rad", yaw(&scene));
        let bound = MAX_TURN_STEP_M / scene.objects()[0].object.shape.bounding_radius();
        assert!(turns.iter().all(|t| *t <= bound + 1e-12), "no corner jumps: {turns:?}");
    }

    proptest::proptest! {
        /// Any pinch of bare points, on any of the five objects turned any
        /// way: the pose stays finite, the object stays upright, and no step
        /// turns it faster than the bound.
        #[test]
        fn turning_stays_upright_finite_and_bounded(
            which in 0usize..5,
            yaw in -3.1f64..3.1,
            points in proptest::collection::vec((-0.25f64..0.25, -0.25f64..0.25, -0.1f64..0.1), 1..8),
        ) {
            let object = Object::figure_16().swap_remove(which);
            let bound = MAX_TURN_STEP_M / object.shape.bounding_radius();
            let mut scene = Scene::new(SkinModel::default());
            let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
            scene.place(object, Isometry3::from_parts(nalgebra::Translation3::identity(), turned));
            scene.add_bare_surface(0, points.iter().map(|&(x, y, z)| Point3::new(x, y, z)).collect());
            for k in 0..30 {
                let before = scene.objects()[0].pose.rotation;
                scene.sense(f64::from(k) * 0.004, &[Isometry3::identity()]);
                let pose = scene.objects()[0].pose;
                proptest::prop_assert!(pose.translation.vector.iter().all(|v| v.is_finite()));
                proptest::prop_assert!((pose.rotation * Vector3::z() - Vector3::z()).norm() < 1e-9, "tipped");
                proptest::prop_assert!(pose.rotation.angle_to(&before) <= bound + 1e-12);
            }
        }
    }

    #[test]
    fn gripping_skin_carries_an_object_along() {
        let mut scene = Scene::new(SkinModel::default());
        let lid = Object::by_name("box_lid").unwrap();
        let Shape::Box { half, .. } = lid.shape else { panic!("the lid is a box") };
        scene.place(lid, Isometry3::identity());
        // Two cells squeeze the lid's long faces 2 mm deep, one from each side...
        let offset = scene.skin().surface_offset_m;
        let squeeze = |x: f64| {
            let facing = |y: f64, normal: Vector3<f64>| {
                let rot = UnitQuaternion::rotation_between(&Vector3::z(), &normal).unwrap();
                Isometry3::from_parts(nalgebra::Translation3::new(x, y, 0.0), rot)
            };
            [facing(-half.y - offset + 0.002, Vector3::y()), facing(half.y + offset - 0.002, -Vector3::y())]
        };
        let start = scene.objects()[0].pose.translation;
        // ...and slide along it at 5 cm/s for 0.4 s: the lid goes with them.
        for k in 0..=100 {
            scene.sense(f64::from(k) * 0.004, &squeeze(-0.0002 * f64::from(k)));
        }
        let moved = scene.objects()[0].pose.translation.vector - start.vector;
        assert!((moved.x + 0.02).abs() < 0.001 && moved.y.abs() < 1e-9, "carried {moved:?}");
    }

    #[test]
    fn objects_slide_when_pushed_harder_than_friction() {
        let mut scene = Scene::new(SkinModel::default());
        let object = Object::by_name("delivery_box").unwrap();
        let Shape::Box { half, .. } = object.shape else { panic!("the delivery box is a box") };
        let half_x = half.x;
        scene.place(object.clone(), Isometry3::translation(0.1 + half_x + 0.008, 0.0, 0.0));
        // Four cells facing +x press 2 mm into the box's -x face.
        let cells: Vec<_> =
            [-0.04, -0.02, 0.02, 0.04].iter().map(|y| Isometry3::translation(0.102, *y, 0.0) * cell_at(0.0)).collect();
        let start = scene.objects()[0].pose.translation.x;
        let s = scene.sense(0.0, &cells).to_vec();
        let total: f64 = s.iter().flat_map(|c| c.force_n).sum();
        let felt: Vec<(usize, f64)> = scene.contacts().iter().map(|c| (c.cell, c.force_n)).collect();
        let expected: Vec<(usize, f64)> = s.iter().map(|c| c.force_n.iter().sum()).enumerate().collect();
        assert_eq!(felt, expected, "all of it the box's");
        assert_eq!((scene.max_object_force_n(), scene.max_hand_force_n()), (scene.max_force_n(), 0.0));
        assert!(total > object.friction * object.mass_kg * G, "pushing harder than friction: {total} N");
        for k in 1..200 {
            scene.sense(f64::from(k) * 0.004, &cells);
        }
        let moved = scene.objects()[0].pose.translation.x - start;
        assert!(moved > 0.0005 && moved < 0.002, "slid {moved} m, until the push fell to friction");
        let after: f64 = scene.sense(0.8, &cells).iter().flat_map(|c| c.force_n).sum();
        assert!((after - object.friction * object.mass_kg * G).abs() < 0.2, "left at the friction limit: {after} N");
    }
}
