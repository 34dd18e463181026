//! A person's hand, for guidance, pats and tests.

use nalgebra::{Isometry3, Point3};

use super::shape::Shape;

/// A person's hand (the palm as a sphere): for guidance, pats and tests.
/// It is moved by whoever plays the person; contact does not move it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hand {
    /// Centre of the palm, world frame, m.
    pub centre: Point3<f64>,
    /// Palm radius, m.
    pub radius_m: f64,
    /// Contact stiffness under one force cell, N/m.
    pub stiffness_n_per_m: f64,
}

impl Hand {
    /// Default palm radius, m.
    pub const RADIUS_M: f64 = 0.04;

    /// A hand whose palm is `gap_m` in front of the outer skin surface of
    /// the cell at `cell` (world pose, z the outward normal), along the
    /// normal; a negative gap presses into the skin.
    pub fn facing(cell: &Isometry3<f64>, surface_offset_m: f64, gap_m: f64) -> Hand {
        let centre = cell * Point3::new(0.0, 0.0, surface_offset_m + gap_m + Hand::RADIUS_M);
        Hand { centre, radius_m: Hand::RADIUS_M, stiffness_n_per_m: 3000.0 }
    }

    /// The hand as an object: a skin-reflecting sphere.
    pub fn shape(&self) -> Shape {
        Shape::Sphere { radius: self.radius_m }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hand_facing_a_cell_is_on_its_normal() {
        let cell = Isometry3::translation(0.1, 0.0, 0.0)
            * Isometry3::rotation(nalgebra::Vector3::y() * std::f64::consts::FRAC_PI_2);
        let h = Hand::facing(&cell, 0.008, 0.05);
        // The cell's z axis is world x: the palm's surface is 5 cm beyond the skin.
        assert!((h.centre - Point3::new(0.1 + 0.008 + 0.05 + Hand::RADIUS_M, 0.0, 0.0)).norm() < 1e-12);
        assert_eq!(h.shape(), Shape::Sphere { radius: Hand::RADIUS_M });
    }
}
