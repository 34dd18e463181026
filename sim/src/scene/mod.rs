//! A scene of objects and a hand that touch the skin (sections 5 and 6).
//!
//! Objects of given shape, weight, stiffness and reflectance stand on a
//! support between the robot's arms (Figure 16); a person's hand can be put
//! anywhere. Given the world pose of every skin cell, the scene computes
//! what the cell feels: the force on each of its three force cells (a
//! series of springs: the foam under the skin and the object's surface) and
//! the infrared intensity its proximity sensor sees.
//!
//! Objects move quasi-statically: when the horizontal sum of the contact
//! forces exceeds the support's friction, the object slides in that
//! direction (viscously, never past the point where the forces balance
//! friction again), so arms can push and pull it. It does not tip or turn.
//! The scene knows only the skin's cells: insensitive parts of the robot
//! neither push objects nor are seen by the skin, and the skin does not see
//! the robot's own body.

pub mod force;
pub mod hand;
pub mod object;
pub mod proximity;
pub mod shape;

use nalgebra::{Isometry3, Point3, Vector3};
use rand::Rng;

use force::{Foam, ForceCells};
use hand::Hand;
use object::Object;
use proximity::Vcnl4010;
use shape::Shape;

/// Standard gravity, m/s^2.
const G: f64 = 9.81;

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
}

impl Default for SkinModel {
    fn default() -> SkinModel {
        SkinModel {
            foam: Foam::default(),
            force: ForceCells::default(),
            proximity: Vcnl4010::default(),
            surface_offset_m: 0.008,
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

/// Something that can be touched: an object or the hand.
struct Touchable<'a> {
    shape: &'a Shape,
    pose: Isometry3<f64>,
    stiffness_n_per_m: f64,
    reflectance: f64,
}

/// Objects, a hand and the physics between them and the skin.
#[derive(Clone, Debug)]
pub struct Scene {
    skin: SkinModel,
    objects: Vec<Placed>,
    hand: Option<Hand>,
    damping_n_s_per_m: f64,
    last_time_s: Option<f64>,
    sensed: Vec<CellSense>,
    max_force_n: f64,
}

impl Scene {
    /// An empty scene.
    pub fn new(skin: SkinModel) -> Scene {
        Scene {
            skin,
            objects: Vec::new(),
            hand: None,
            damping_n_s_per_m: 40.0,
            last_time_s: None,
            sensed: Vec::new(),
            max_force_n: 0.0,
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

    /// The objects.
    pub fn objects(&self) -> &[Placed] {
        &self.objects
    }

    /// Puts the hand somewhere, or takes it away.
    pub fn set_hand(&mut self, hand: Option<Hand>) {
        self.hand = hand;
    }

    /// The hand, if present.
    pub fn hand(&self) -> Option<&Hand> {
        self.hand.as_ref()
    }

    /// The largest force on any force cell since the start (or the last
    /// reset), N.
    pub fn max_force_n(&self) -> f64 {
        self.max_force_n
    }

    /// Forgets the largest force.
    pub fn reset_max_force(&mut self) {
        self.max_force_n = 0.0;
    }

    /// What the cells at `poses` (world frame, z the outward normal) sense
    /// at `time_s`; then the objects move under the cells' forces until the
    /// next call.
    pub fn sense(&mut self, time_s: f64, poses: &[Isometry3<f64>]) -> &[CellSense] {
        let dt = self.last_time_s.map_or(0.0, |t| (time_s - t).max(0.0));
        self.last_time_s = Some(time_s);
        self.sensed.clear();
        self.sensed.resize(poses.len(), CellSense::default());
        // Horizontal push and its stiffness, per object.
        let mut push = vec![(Vector3::zeros(), 0.0); self.objects.len()];
        let hand = self.hand;
        let hand_shape = hand.map(|h| h.shape());
        for (cell, sense) in poses.iter().zip(self.sensed.iter_mut()) {
            for (placed, push) in self.objects.iter().zip(push.iter_mut()) {
                let body = Touchable {
                    shape: &placed.object.shape,
                    pose: placed.pose,
                    stiffness_n_per_m: placed.object.stiffness_n_per_m,
                    reflectance: placed.object.reflectance,
                };
                touch(&self.skin, cell, &body, sense, Some(push));
            }
            if let (Some(h), Some(shape)) = (hand, hand_shape.as_ref()) {
                // The proximity curve is calibrated on skin: reflectance 1.
                let body = Touchable {
                    shape,
                    pose: Isometry3::translation(h.centre.x, h.centre.y, h.centre.z),
                    stiffness_n_per_m: h.stiffness_n_per_m,
                    reflectance: 1.0,
                };
                touch(&self.skin, cell, &body, sense, None);
            }
            sense.proximity = sense.proximity.min(1.0);
            self.max_force_n = sense.force_n.iter().fold(self.max_force_n, |m, f| m.max(*f));
        }
        for (placed, (force, stiffness)) in self.objects.iter_mut().zip(push) {
            slide(placed, force, stiffness, self.damping_n_s_per_m, dt);
        }
        &self.sensed
    }

    /// Raw counts (proximity, three forces) of a sense, with sensor noise.
    pub fn counts(&self, sense: &CellSense, rng: &mut impl Rng) -> (u16, [u16; 3]) {
        let p = self.skin.proximity.counts(sense.proximity, rng);
        let f = sense.force_n.map(|f| self.skin.force.counts(f, rng));
        (p, f)
    }
}

/// Adds what `body` does to the cell at `cell`; accumulates the horizontal
/// push on the body and its stiffness.
fn touch(
    skin: &SkinModel,
    cell: &Isometry3<f64>,
    body: &Touchable<'_>,
    sense: &mut CellSense,
    push: Option<&mut (Vector3<f64>, f64)>,
) {
    let axis = cell.rotation * Vector3::z();
    let window = cell * Point3::new(0.0, 0.0, skin.surface_offset_m);
    let local = body.pose.inverse_transform_point(&window);
    let distance = body.shape.distance(&local);
    if distance > skin.proximity.range_m + skin.force.radius_m {
        return;
    }
    let towards = -(body.pose.rotation * body.shape.normal(&local));
    sense.proximity += skin.proximity.intensity(distance, towards.dot(&axis), body.reflectance);
    if distance > skin.force.radius_m {
        return;
    }
    let mut push = push;
    for (i, [x, y]) in skin.force.positions().into_iter().enumerate() {
        let p = body.pose.inverse_transform_point(&(cell * Point3::new(x, y, skin.surface_offset_m)));
        let depth = -body.shape.distance(&p);
        if depth <= 0.0 {
            continue;
        }
        let into_body = -(body.pose.rotation * body.shape.normal(&p));
        let f = skin.foam.contact_force(depth, body.stiffness_n_per_m);
        // The force cell measures the part along its normal.
        sense.force_n[i] += f * into_body.dot(&axis).max(0.0);
        if let Some((force, stiffness)) = push.as_deref_mut() {
            *force += f * Vector3::new(into_body.x, into_body.y, 0.0);
            let k = skin.foam.contact_force(depth + 1e-6, body.stiffness_n_per_m) - f;
            *stiffness += k / 1e-6;
        }
    }
}

/// Quasi-static sliding on the support: beyond static friction the object
/// moves with the excess force over a viscous damping, but never further
/// than where the contact forces would fall back to the friction limit.
fn slide(placed: &mut Placed, force: Vector3<f64>, stiffness: f64, damping: f64, dt: f64) {
    let limit = placed.object.friction * placed.object.mass_kg * G;
    let magnitude = force.norm();
    if magnitude <= limit || dt <= 0.0 {
        return;
    }
    let excess = magnitude - limit;
    let mut step = excess / damping * dt;
    if stiffness > 0.0 {
        step = step.min(excess / stiffness);
    }
    placed.pose.translation.vector += force / magnitude * step;
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
            scene.set_hand(Some(Hand::facing(&cell, offset, gap)));
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
        scene.set_hand(Some(Hand::facing(&cell, offset, -0.001)));
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
        let far = scene.sense(0.004, &[cell_at(-0.5)])[0];
        assert_eq!(far, CellSense::default());
    }

    #[test]
    fn objects_slide_when_pushed_harder_than_friction() {
        let mut scene = Scene::new(SkinModel::default());
        let object = Object::delivery_box();
        let half_x = 0.09;
        scene.place(object.clone(), Isometry3::translation(0.1 + half_x + 0.008, 0.0, 0.0));
        // Four cells facing +x press 2 mm into the box's -x face.
        let cells: Vec<_> =
            [-0.04, -0.02, 0.02, 0.04].iter().map(|y| Isometry3::translation(0.102, *y, 0.0) * cell_at(0.0)).collect();
        let start = scene.objects()[0].pose.translation.x;
        let s = scene.sense(0.0, &cells).to_vec();
        let total: f64 = s.iter().flat_map(|c| c.force_n).sum();
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
