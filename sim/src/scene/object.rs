//! The objects of Figure 16.
//!
//! The paper grasped five objects of different weight, size, shape and
//! hardness with one parameter set. Their sizes here are scaled to the
//! simulated HRP-2-like arms (0.25 m upper arm and forearm, whose elbows
//! reach only 0.13 m past the chest), their weights to what those arms
//! can pull over a table with the force Table 4 allows (a few newtons);
//! stiffness and reflectance are estimates of the real things. Stiffness is
//! per force-cell contact (a 1.5 cm^2 patch): a packed computer box barely
//! gives, a sponge gives a lot.

use nalgebra::Vector3;

use super::shape::Shape;

/// A rigid or soft body that the skin can touch and see.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name, as given on the command line.
    pub name: &'static str,
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

impl Object {
    /// (A) A plastic trash bin: a light, fairly stiff cylinder.
    pub fn trash_bin() -> Object {
        Object {
            name: "trash_bin",
            shape: Shape::Cylinder { radius: 0.14, half_height: 0.17 },
            mass_kg: 0.5,
            stiffness_n_per_m: 4000.0,
            reflectance: 0.7,
            friction: 0.3,
        }
    }

    /// (B) A sponge rock: irregular, very soft and light.
    pub fn sponge_rock() -> Object {
        Object {
            name: "sponge_rock",
            shape: Shape::Blob { semi: Vector3::new(0.11, 0.15, 0.12), bump_m: 0.012, bump_rad_per_m: 25.0 },
            mass_kg: 0.2,
            stiffness_n_per_m: 350.0,
            reflectance: 0.5,
            friction: 0.5,
        }
    }

    /// (C) A large moving box: wide cardboard, light.
    pub fn moving_box() -> Object {
        Object {
            name: "moving_box",
            shape: Shape::Box { half: Vector3::new(0.09, 0.16, 0.16), round_m: 0.02 },
            mass_kg: 0.6,
            stiffness_n_per_m: 2500.0,
            reflectance: 0.8,
            friction: 0.3,
        }
    }

    /// (D) The lid of a paper box, standing on its long edge: thin and
    /// flexible (modelled by its outer hull).
    pub fn box_lid() -> Object {
        Object {
            name: "box_lid",
            shape: Shape::Box { half: Vector3::new(0.06, 0.19, 0.11), round_m: 0.015 },
            mass_kg: 0.15,
            stiffness_n_per_m: 900.0,
            reflectance: 0.9,
            friction: 0.3,
        }
    }

    /// (E) A computer delivery box: packed, hard and the heaviest.
    pub fn delivery_box() -> Object {
        Object {
            name: "delivery_box",
            shape: Shape::Box { half: Vector3::new(0.07, 0.15, 0.13), round_m: 0.01 },
            mass_kg: 0.8,
            stiffness_n_per_m: 20_000.0,
            reflectance: 0.9,
            friction: 0.3,
        }
    }

    /// The five objects of Figure 16, (A) to (E).
    pub fn figure_16() -> [Object; 5] {
        [Object::trash_bin(), Object::sponge_rock(), Object::moving_box(), Object::box_lid(), Object::delivery_box()]
    }

    /// An object of Figure 16 by name.
    pub fn by_name(name: &str) -> Option<Object> {
        Object::figure_16().into_iter().find(|o| o.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_distinct_objects_by_name() {
        let all = Object::figure_16();
        for o in &all {
            assert_eq!(Object::by_name(o.name).as_ref(), Some(o));
            assert!(o.mass_kg > 0.0 && o.stiffness_n_per_m > 0.0 && o.reflectance > 0.0);
        }
        assert!(Object::by_name("piano").is_none());
        let hardest = all.iter().max_by(|a, b| a.stiffness_n_per_m.total_cmp(&b.stiffness_n_per_m)).unwrap();
        assert_eq!(hardest.name, "delivery_box");
    }
}
