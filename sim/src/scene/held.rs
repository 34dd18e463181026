//! What the simulator's truth says of an object between the arms: the
//! verdict on a grasp rests on this, never on the controller's own word.
//!
//! Held means the object is between the arms (each arm presses on it from
//! its own side of the object's centre), against the chest, and both arms
//! press on it, with their skin or their bare surface: the truth counts
//! what holds the object, whether the skin feels it or not. Where objects
//! can be lifted and fall (MuJoCo), held also means that nothing but the
//! robot carries it, and there an object both arms press onto the chest
//! from its front is between the arms and the chest too: whether friction
//! carries it is the physics' to say.

use nalgebra::Vector3;

use super::experiment::gap_to_chest_m;
use super::{Contact, Placed};

/// Within this of the chest's skin the object is against the chest, m.
pub const AGAINST_CHEST_M: f64 = 0.01;
/// At least this much force of the object on an arm's skin is contact, N.
pub const ARM_CONTACT_N: f64 = 0.05;
/// A force of an object on one link's bare surface (where no force cell
/// feels it; its contacts there summed) above this is pain, N: ten times
/// the weight of the heaviest object file's object (0.8 kg), a squeeze
/// that crushes cardboard.
pub const BARE_PAIN_N: f64 = 80.0;

/// Which arm a skin cell is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arm {
    /// The robot's right arm (towards -y).
    Right,
    /// Its left arm (towards +y).
    Left,
}

impl Arm {
    /// The arm of a cell on link `link` of the built-in robot, if any.
    pub fn of_link(link: &str) -> Option<Arm> {
        if link.starts_with("RARM") {
            Some(Arm::Right)
        } else if link.starts_with("LARM") {
            Some(Arm::Left)
        } else {
            None
        }
    }
}

/// The truth about an object at one instant.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ObjectTruth {
    /// How far the object is from the chest's skin, m.
    pub gap_m: f64,
    /// Where its centre is (world frame), m.
    pub centre_m: [f64; 3],
    /// The object's force on the skin of each arm (right, left), N.
    pub arm_force_n: [f64; 2],
    /// Its force on the rest of the robot (the chest), N.
    pub body_force_n: f64,
    /// Each arm presses from its own side of the object's centre.
    pub between_arms: bool,
    /// Both arms press on it ahead of its centre (from its front).
    pub from_front: bool,
    /// Whether something other than the robot carries it (its support, the
    /// floor); none where objects never leave their table.
    pub resting: Option<bool>,
    /// The force with which its support (or the floor) bears it, N; none
    /// where objects never leave their table.
    pub support_n: Option<f64>,
    /// Whether it has fallen to the floor.
    pub fallen: bool,
    /// The person took it back into their hands: it came down resting on
    /// them as they lowered them, so the robot never carried it alone.
    pub taken_back: bool,
}

impl ObjectTruth {
    /// The truth about `placed` (reaching `back_m` behind its centre)
    /// touched at `contacts`, each on the arm of its cell by `arms`.
    pub fn observe(
        placed: &Placed,
        back_m: f64,
        skin_offset_m: f64,
        arms: &[Option<Arm>],
        contacts: &[Contact],
    ) -> ObjectTruth {
        let mut force = [0.0; 2];
        let mut body_force_n = 0.0;
        // Force-weighted sum of each arm's contact points.
        let mut weighted = [Vector3::zeros(); 2];
        for c in contacts {
            let Some(Some(arm)) = arms.get(c.cell) else {
                body_force_n += c.force_n;
                continue;
            };
            let k = *arm as usize;
            force[k] += c.force_n;
            weighted[k] += c.force_n * c.point.coords;
        }
        let centre = placed.pose.translation.vector;
        let touched = force.map(|f| f >= ARM_CONTACT_N) == [true, true];
        // Where each arm presses, on average.
        let [right, left] = [0, 1].map(|k| weighted[k] / force[k]);
        ObjectTruth {
            gap_m: gap_to_chest_m(placed, back_m, skin_offset_m),
            centre_m: centre.into(),
            arm_force_n: force,
            body_force_n,
            between_arms: touched && right.y < centre.y && left.y > centre.y,
            from_front: touched && right.x > centre.x && left.x > centre.x,
            resting: None,
            support_n: None,
            fallen: false,
            taken_back: false,
        }
    }

    /// Both arms press on it.
    pub fn gripped(&self) -> bool {
        self.arm_force_n.iter().all(|f| *f >= ARM_CONTACT_N)
    }

    /// Between the arms, against the chest, both arms pressing.
    pub fn hugged(&self) -> bool {
        self.enclosed() && self.gripped() && self.gap_m <= AGAINST_CHEST_M
    }

    /// Between the arms: pressed from either side, or (where the world
    /// tells whether the robot carries it) from its front onto the chest.
    /// The built-in world cannot drop an object friction fails to carry, so
    /// there only the arms on either side count.
    pub fn enclosed(&self) -> bool {
        self.between_arms || (self.from_front && self.resting.is_some())
    }

    /// Held: hugged, and carried by the robot alone where it could rest
    /// on something else.
    pub fn held(&self) -> bool {
        self.not_held().is_none()
    }

    /// Why the object is not held, the first of: on the floor, in the
    /// person's hands, on its support, an arm off it, not between the
    /// arms, away from the chest; none when it is held.
    pub fn not_held(&self) -> Option<NotHeld> {
        if self.fallen {
            Some(NotHeld::Fallen)
        } else if self.taken_back {
            Some(NotHeld::TakenBack)
        } else if self.resting == Some(true) {
            Some(NotHeld::Resting)
        } else if self.arm_force_n[0] < ARM_CONTACT_N {
            Some(NotHeld::RightArmOff)
        } else if self.arm_force_n[1] < ARM_CONTACT_N {
            Some(NotHeld::LeftArmOff)
        } else if !self.enclosed() {
            Some(NotHeld::NotBetweenArms)
        } else if self.gap_m > AGAINST_CHEST_M {
            Some(NotHeld::OffChest)
        } else {
            None
        }
    }
}

/// Why the truth does not call an object held.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NotHeld {
    /// It lies on the floor.
    Fallen,
    /// The person took it back into their hands.
    TakenBack,
    /// Something other than the robot carries it (its support).
    Resting,
    /// The right arm does not press on it.
    RightArmOff,
    /// The left arm does not press on it.
    LeftArmOff,
    /// The arms do not press from either side of its centre (nor, where
    /// it could fall, both from its front).
    NotBetweenArms,
    /// It is more than [`AGAINST_CHEST_M`] from the chest's skin.
    OffChest,
}

impl NotHeld {
    /// What a person would say of it.
    pub fn describe(self) -> &'static str {
        match self {
            NotHeld::Fallen => "on the floor",
            NotHeld::TakenBack => "taken back into the person's hands",
            NotHeld::Resting => "standing on its support",
            NotHeld::RightArmOff => "the right arm off it",
            NotHeld::LeftArmOff => "the left arm off it",
            NotHeld::NotBetweenArms => "not between the arms",
            NotHeld::OffChest => "away from the chest",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::object::Object;
    use nalgebra::{Isometry3, Point3};

    fn placed(y: f64) -> Placed {
        Placed { object: Object::by_name("box_lid").unwrap(), pose: Isometry3::translation(0.2, y, 0.15) }
    }

    #[test]
    fn held_needs_both_arms_from_both_sides_and_the_chest() {
        let arms = [Some(Arm::Right), Some(Arm::Left), None];
        let at = |cell: usize, y: f64, force_n: f64, felt: bool| Contact {
            cell,
            point: Point3::new(0.2, y, 0.15),
            force_n,
            felt,
        };
        // The right arm's skin, the left arm's skin and bare surface, the chest.
        let press = [at(0, -0.2, 0.1, true), at(1, 0.2, 0.05, true), at(1, 0.2, 0.05, false), at(2, 0.0, 3.0, true)];
        // The lid reaches 0.06 m back: its back at 0.14, the chest's skin at 0.138.
        let truth = ObjectTruth::observe(&placed(0.0), 0.06, 0.008, &arms, &press);
        assert!((truth.gap_m - 0.002).abs() < 1e-12);
        assert_eq!(truth.arm_force_n, [0.1, 0.1], "the chest's force is no arm's; bare surface counts");
        assert_eq!((truth.body_force_n, truth.centre_m), (3.0, [0.2, 0.0, 0.15]));
        assert!(truth.between_arms && truth.held());
        let far = ObjectTruth::observe(&placed(0.0), 0.03, 0.008, &arms, &press);
        assert!(far.gripped() && !far.held(), "3.2 cm from the chest");
        let one_arm = ObjectTruth::observe(&placed(0.0), 0.06, 0.008, &arms, &press[..1]);
        assert!(!one_arm.gripped() && !one_arm.between_arms && !one_arm.held());
        // Both arms on the object's left: pinned, not held between.
        let aside = ObjectTruth::observe(&placed(-0.25), 0.06, 0.008, &arms, &press);
        assert!(aside.gripped() && !aside.between_arms && !aside.held());
        assert_eq!(aside.not_held(), Some(NotHeld::NotBetweenArms));
        assert_eq!(far.not_held(), Some(NotHeld::OffChest));
        assert_eq!(one_arm.not_held(), Some(NotHeld::LeftArmOff));
        assert_eq!(truth.not_held(), None);
        let hovering = ObjectTruth::observe(&placed(0.0), 0.06, 0.008, &arms, &press[..3]);
        assert!(hovering.hugged() && hovering.body_force_n == 0.0, "2 mm from the chest, not on it: hugged");
        let lifted = ObjectTruth { resting: Some(false), ..truth };
        assert!(lifted.held(), "carried by the robot alone");
        assert_eq!(ObjectTruth { resting: Some(true), ..truth }.not_held(), Some(NotHeld::Resting));
        assert_eq!(ObjectTruth { fallen: true, resting: Some(true), ..truth }.not_held(), Some(NotHeld::Fallen));
        let kept = ObjectTruth { taken_back: true, resting: Some(false), ..truth };
        assert_eq!(kept.not_held(), Some(NotHeld::TakenBack), "the arms on it, the person's hands carrying it");
    }

    #[test]
    fn pressed_from_the_front_is_between_only_where_it_could_fall() {
        let arms = [Some(Arm::Right), Some(Arm::Left), None];
        let at =
            |cell: usize, x: f64, y: f64| Contact { cell, point: Point3::new(x, y, 0.15), force_n: 1.0, felt: true };
        // Both arms on the lid's front (ahead of its centre at x = 0.2),
        // both right of its centre: not from either side.
        let front = [at(0, 0.26, -0.08), at(1, 0.26, -0.01), at(2, 0.14, 0.0)];
        let truth = ObjectTruth::observe(&placed(0.0), 0.06, 0.008, &arms, &front);
        assert!(truth.gripped() && truth.from_front && !truth.between_arms);
        assert_eq!(truth.not_held(), Some(NotHeld::NotBetweenArms), "the built-in world cannot drop it");
        assert!(!truth.hugged());
        let lifted = ObjectTruth { resting: Some(false), ..truth };
        assert!(lifted.hugged() && lifted.held(), "where it could fall, friction carried it");
        // One arm behind the centre: not from the front.
        let behind = [at(0, 0.26, -0.08), at(1, 0.17, -0.01), at(2, 0.14, 0.0)];
        let truth = ObjectTruth::observe(&placed(0.0), 0.06, 0.008, &arms, &behind);
        assert!(!truth.from_front && !ObjectTruth { resting: Some(false), ..truth }.held());
    }

    #[test]
    fn arms_by_link() {
        assert_eq!(Arm::of_link("RARM_LINK3"), Some(Arm::Right));
        assert_eq!(Arm::of_link("LARM_LINK0"), Some(Arm::Left));
        assert_eq!(Arm::of_link("CHEST"), None);
    }
}
