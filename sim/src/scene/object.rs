//! Objects that the skin can touch and see, and the five of Figure 16.
//!
//! The paper grasped five objects of different weight, size, shape and
//! hardness with one parameter set. They ship as object files
//! (`sim/objects/*.toml`, compiled in so their names always work); their
//! sizes are scaled to the simulated HRP-2-like arms (0.25 m upper arm and
//! forearm, whose elbows reach only 0.13 m past the chest), their weights to
//! what those arms can pull over a table with the force Table 4 allows (a
//! few newtons); stiffness and reflectance are estimates of the real
//! things. Stiffness is per force-cell contact (a 1.5 cm^2 patch): a packed
//! computer box barely gives, a sponge gives a lot.

use super::shape::Shape;

/// A rigid or soft body that the skin can touch and see.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name, as given on the command line and in file names.
    pub name: String,
    /// Shape in the object frame (z up).
    pub shape: Shape,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Local contact stiffness under one force cell, N/m.
    pub stiffness_n_per_m: f64,
    /// Infrared reflectance relative to skin.
    pub reflectance: f64,
    /// Coulomb friction coefficient with its support.
    pub friction: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_distinct_objects_by_name() {
        let all = Object::figure_16();
        let names: Vec<&str> = all.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["trash_bin", "sponge_rock", "moving_box", "box_lid", "delivery_box"]);
        for o in &all {
            assert_eq!(Object::by_name(&o.name).as_ref(), Some(o));
        }
        assert!(Object::by_name("piano").is_none());
        let hardest = all.iter().max_by(|a, b| a.stiffness_n_per_m.total_cmp(&b.stiffness_n_per_m)).unwrap();
        assert_eq!(hardest.name, "delivery_box");
        assert_eq!(all[0].shape, Shape::Cylinder { radius: 0.14, half_height: 0.17, round_m: 0.0 });
    }
}
