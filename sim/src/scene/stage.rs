//! What the person in the lab acts on and looks at: the built-in scene or,
//! in the MuJoCo world, MuJoCo's bodies.
//!
//! The person ([`super::operator::Operator`]) is the same in both worlds:
//! they picture key poses, guide with their hands, pat and put objects
//! down. Only how a hand, an object and the truth about them are made
//! differs, and that is behind [`Stage`].

use nalgebra::Isometry3;

use super::hand::Hand;
use super::object::Object;
use super::{Contact, Placed, SkinModel};

/// How far below where they took it the person carries an object they
/// took back, m: down past the arms by more than the tallest generated
/// object (0.34 m).
pub const TAKE_AWAY_M: f64 = 0.4;
/// How fast they carry it away, m/s: carefully.
pub const TAKE_AWAY_M_PER_S: f64 = 0.1;

/// A stage the person acts on, between control periods.
pub trait Stage {
    /// The skin's sensing layers (where a guiding hand is held for an
    /// intensity, how far the skin's surface is above a cell's mount).
    fn skin(&self) -> SkinModel;
    /// A hand patting the cell at `cell` (world pose, z outward), pressed
    /// `depth_m` into what the hand meets there.
    fn pat(&self, cell: &Isometry3<f64>, depth_m: f64) -> Hand;
    /// Puts the person's hands where given (none: taken away).
    fn set_hands(&self, hands: Vec<Hand>);
    /// Puts `object` down at the pose given, standing on its support, or
    /// takes the object away; forgets the largest forces.
    fn put(&self, object: Option<(Object, Isometry3<f64>)>);
    /// The person lowers the support the object stands on to `down_m`
    /// below where they put it (a table that stays does nothing).
    fn lower_support(&self, down_m: f64);
    /// The person lets go of the support the object stands on, once the
    /// robot holds it (a table that stays does nothing).
    fn let_go(&self);
    /// The person takes the object into their hands where it is now,
    /// before patting to release it, so that it does not drop as the arms
    /// open (an object on a table that stays needs nothing).
    fn take_back(&self);
    /// The person takes the object into their hands where it is now and
    /// carries it away, down out of the arms ([`TAKE_AWAY_M`] at
    /// [`TAKE_AWAY_M_PER_S`]), as one takes a box back from someone who
    /// cannot hold it (an object on a table that stays needs nothing).
    fn carry_away(&self);
    /// What the person sees now.
    fn look(&self) -> Look;
}

/// What the person sees of the stage after a period.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Look {
    /// The largest force on any one force cell since the object was put (or taken away), N.
    pub max_force_n: f64,
    /// The same of the object's contacts alone, N.
    pub grip_force_max_n: f64,
    /// The same of the person's hands alone, N.
    pub hand_force_max_n: f64,
    /// The largest force of the object on one link's bare surface (where
    /// no force cell is; its contacts there summed) since it was put, N;
    /// both worlds measure it, and MuJoCo's says none until an object is
    /// first put.
    pub bare_force_max_n: Option<f64>,
    /// The object as it is now.
    pub object: Option<Placed>,
    /// Where the robot touches the object now.
    pub contacts: Vec<Contact>,
    /// Whether the object rests on something other than the robot (its
    /// support, the floor); none where objects never leave their table.
    pub resting: Option<bool>,
    /// The force with which its support (or the floor) bears the object
    /// now, N; none where objects never leave their table.
    pub support_n: Option<f64>,
    /// Whether the object has fallen to the floor.
    pub fallen: bool,
}
