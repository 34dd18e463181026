//! Object shapes as signed distance functions.
//!
//! A shape answers one question, how far a point is from its surface
//! (negative inside), in its own frame; penetration depths, contact normals
//! and proximity distances all follow from it. The irregular blob's
//! distance is a bound, not exact (its bumps are scaled down so the bound
//! holds), which is all contact and ray marching need.

use nalgebra::{Point3, SVector, Vector2, Vector3};

/// A shape in its own frame, centred on the origin, z up (as object files
/// write it: `{ box = { half = [x, y, z], round_m = r } }`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A box with half edge lengths and rounded edges, m.
    Box {
        /// Half extents along x, y, z, m.
        half: Vector3<f64>,
        /// Radius of its edges and corners (the give of cardboard), m.
        #[serde(default)]
        round_m: f64,
    },
    /// An upright cylinder with rounded rims.
    Cylinder {
        /// Radius, m.
        radius: f64,
        /// Half height, m.
        half_height: f64,
        /// Radius of its rims (a can's or a bucket's is rolled), m.
        #[serde(default)]
        round_m: f64,
    },
    /// A sphere.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// An ellipsoid with bumps: an irregular, rock-like body.
    Blob {
        /// Semi-axes, m.
        semi: Vector3<f64>,
        /// Height of the bumps, m.
        #[serde(default)]
        bump_m: f64,
        /// Spatial frequency of the bumps, rad/m.
        #[serde(default)]
        bump_rad_per_m: f64,
    },
}

impl Shape {
    /// Signed distance from `p` (shape frame) to the surface, m.
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        match *self {
            Shape::Box { half, round_m } => rounded(p.coords.abs() - half.add_scalar(-round_m), round_m),
            Shape::Cylinder { radius, half_height, round_m } => {
                let q = Vector2::new(p.coords.xy().norm() - radius, p.z.abs() - half_height);
                rounded(q.add_scalar(round_m), round_m)
            }
            Shape::Sphere { radius } => p.coords.norm() - radius,
            Shape::Blob { semi, bump_m, bump_rad_per_m } => {
                let k0 = p.coords.component_div(&semi).norm();
                let k1 = p.coords.component_div(&semi.component_mul(&semi)).norm();
                let ellipsoid = if k1 > 0.0 { k0 * (k0 - 1.0) / k1 } else { -semi.min() };
                let w = bump_rad_per_m;
                let bumps = bump_m * (w * p.x).sin() * (1.3 * w * p.y + 0.7).sin() * (0.8 * w * p.z + 1.9).sin();
                // The bumps' slope is up to bump * 1.3 w: scale so the bound holds.
                (ellipsoid - bumps) / (1.0 + 1.3 * bump_m * w)
            }
        }
    }

    /// Outward unit normal of the surface nearest `p` (the distance's
    /// gradient, by central differences).
    pub fn normal(&self, p: &Point3<f64>) -> Vector3<f64> {
        const H: f64 = 1e-5;
        let g = Vector3::from_fn(|i, _| {
            let mut e = Vector3::zeros();
            e[i] = H;
            self.distance(&(p + e)) - self.distance(&(p - e))
        });
        g.try_normalize(1e-12).unwrap_or_else(Vector3::z)
    }

    /// How far the shape reaches from its centre along the unit vector
    /// `dir` (its support function), m: exact for the box, cylinder and
    /// sphere; for the blob, the farthest of its surface points along a fan
    /// of rays within 60 degrees of `dir`, found by the sign of the
    /// distance, which is exact even where its size is a bound.
    pub fn extent(&self, dir: &Vector3<f64>) -> f64 {
        match *self {
            Shape::Box { half, round_m } => (half.add_scalar(-round_m)).dot(&dir.abs()) + round_m,
            Shape::Cylinder { radius, half_height, round_m } => {
                (radius - round_m) * dir.xy().norm() + (half_height - round_m) * dir.z.abs() + round_m
            }
            Shape::Sphere { radius } => radius,
            Shape::Blob { .. } => {
                let side = if dir.z.abs() < 0.9 { Vector3::z() } else { Vector3::x() };
                let u = dir.cross(&side).normalize();
                let v = dir.cross(&u);
                let fan = 12;
                let mut far = 0.0f64;
                for i in -fan..=fan {
                    for j in -fan..=fan {
                        let (a, b) = (f64::from(i) / f64::from(fan), f64::from(j) / f64::from(fan));
                        let ray = (dir + u * a * 3f64.sqrt() + v * b * 3f64.sqrt()).normalize();
                        if ray.dot(dir) < 0.5 {
                            continue;
                        }
                        far = far.max(self.surface_along(&ray) * ray.dot(dir));
                    }
                }
                far
            }
        }
    }

    /// Distance from the centre to the surface along the unit vector
    /// `ray`, by bisection on the sign of the distance, m.
    fn surface_along(&self, ray: &Vector3<f64>) -> f64 {
        let (mut inside, mut outside) = (0.0, self.bounding_radius());
        for _ in 0..40 {
            let mid = 0.5 * (inside + outside);
            if self.distance(&Point3::from(ray * mid)) < 0.0 {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    }

    /// A lower bound of [`Shape::distance`] at every point `r_m` from the
    /// centre (or farther: it never falls as `r_m` grows), m: the scene's broad phase, which skips the distance of
    /// cells too far for any bound of it to reach them. The box, cylinder
    /// and sphere distances are exact, so the bounding sphere bounds them;
    /// the blob's is an estimate, bounded through its own formula (the
    /// ellipsoid term is at least `r min(semi) / max(semi) - max(semi)`).
    pub fn distance_at_least(&self, r_m: f64) -> f64 {
        match *self {
            Shape::Box { half, .. } => r_m - half.norm(),
            // Not `hypot`, which costs more than the distance it saves;
            // the rounding is far below the broad phase's margin.
            Shape::Cylinder { radius, half_height, .. } => r_m - (radius * radius + half_height * half_height).sqrt(),
            Shape::Sphere { radius } => r_m - radius,
            Shape::Blob { semi, bump_m, bump_rad_per_m } => {
                let scale = 1.0 + 1.3 * bump_m * bump_rad_per_m;
                let above = semi.min() / semi.max() * r_m - semi.max() - bump_m.abs();
                if semi.min() > 0.0 && scale > 0.0 && above > 0.0 {
                    above / scale
                } else {
                    f64::NEG_INFINITY
                }
            }
        }
    }

    /// Mean half size of the face it stands on, m: the lever of the
    /// support's friction against turning about the vertical.
    pub fn footprint_radius(&self) -> f64 {
        match *self {
            Shape::Box { half, .. } => 0.5 * (half.x + half.y),
            Shape::Cylinder { radius, .. } | Shape::Sphere { radius } => radius,
            Shape::Blob { semi, .. } => 0.5 * (semi.x + semi.y),
        }
    }

    /// Half its thinnest extent, m (the blob's without its bumps): no
    /// surface pressed into it can reach deeper without passing its middle.
    pub fn thinnest_half(&self) -> f64 {
        match *self {
            Shape::Box { half, .. } => half.min(),
            Shape::Cylinder { radius, half_height, .. } => radius.min(half_height),
            Shape::Sphere { radius } => radius,
            Shape::Blob { semi, .. } => semi.min(),
        }
    }

    /// Radius of a sphere around the origin that holds the whole shape, m.
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            Shape::Box { half, .. } => half.norm(),
            Shape::Cylinder { radius, half_height, .. } => radius.hypot(half_height),
            Shape::Sphere { radius } => radius,
            Shape::Blob { semi, bump_m, .. } => semi.max() + bump_m,
        }
    }
}

/// Signed distance of a point `q` past the inner box of a shape whose
/// edges are rounded by `round_m` (per axis, how far beyond the inner box's
/// half size it lies): the box's in three axes, the cylinder's in two
/// (out from its axis, up from its middle).
fn rounded<const D: usize>(q: SVector<f64, D>, round_m: f64) -> f64 {
    q.sup(&SVector::zeros()).norm() + q.max().min(0.0) - round_m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_of_the_primitives() {
        let b = Shape::Box { half: Vector3::new(0.1, 0.2, 0.3), round_m: 0.0 };
        assert!((b.distance(&Point3::new(0.15, 0.0, 0.0)) - 0.05).abs() < 1e-12);
        assert!((b.distance(&Point3::origin()) + 0.1).abs() < 1e-12);
        assert!((b.distance(&Point3::new(0.13, 0.24, 0.0)) - 0.05).abs() < 1e-12, "outside a corner");
        let rounded = Shape::Box { half: Vector3::new(0.1, 0.2, 0.3), round_m: 0.02 };
        assert!((rounded.distance(&Point3::new(0.15, 0.0, 0.0)) - 0.05).abs() < 1e-12, "faces stay");
        let corner = Point3::new(0.1, 0.2, 0.0);
        assert!((rounded.distance(&corner) - 0.02 * (2f64.sqrt() - 1.0)).abs() < 1e-12, "edges are round");
        let c = Shape::Cylinder { radius: 0.1, half_height: 0.2, round_m: 0.0 };
        assert!((c.distance(&Point3::new(0.0, 0.3, 0.0)) - 0.2).abs() < 1e-12);
        assert!((c.distance(&Point3::new(0.0, 0.0, 0.25)) - 0.05).abs() < 1e-12);
        assert!((c.normal(&Point3::new(0.0, 0.3, 0.0)) - Vector3::y()).norm() < 1e-6);
        let rim = Point3::new(0.0, 0.1, 0.2);
        assert!(c.distance(&rim).abs() < 1e-12, "a sharp rim");
        let rolled = Shape::Cylinder { radius: 0.1, half_height: 0.2, round_m: 0.01 };
        assert!((rolled.distance(&Point3::new(0.0, 0.3, 0.0)) - 0.2).abs() < 1e-12, "the side stays");
        assert!((rolled.distance(&rim) - 0.01 * (2f64.sqrt() - 1.0)).abs() < 1e-12, "rims are round");
        let s = Shape::Sphere { radius: 0.04 };
        assert!((s.distance(&Point3::new(0.0, 0.0, 0.05)) - 0.01).abs() < 1e-12);
    }

    #[test]
    fn the_blob_is_a_bumpy_bounded_ellipsoid() {
        let blob = Shape::Blob { semi: Vector3::new(0.15, 0.12, 0.1), bump_m: 0.01, bump_rad_per_m: 30.0 };
        assert!(blob.distance(&Point3::origin()) < 0.0);
        // Along each axis the surface lies within a bump of the semi-axis.
        for axis in 0..3 {
            let mut p = Point3::origin();
            let mut t = 0.0;
            while blob.distance(&p) < 0.0 {
                t += 1e-4;
                p[axis] = t;
            }
            let semi = [0.15, 0.12, 0.1][axis];
            assert!((t - semi).abs() <= 0.0101, "axis {axis}: surface at {t}");
        }
        // The distance never overestimates: marching by it never jumps in.
        let dir = Vector3::new(-1.0, -0.4, -0.2).normalize();
        let mut p = Point3::new(0.5, 0.2, 0.1);
        for _ in 0..200 {
            let d = blob.distance(&p);
            assert!(d > -1e-9);
            if d < 1e-6 {
                break;
            }
            p += dir * d;
        }
        assert!(blob.bounding_radius() >= 0.16);
        // Its extent is that of a surface point: at least the march along
        // the axis, within the bumps of the semi-axis.
        let back = blob.extent(&-Vector3::x());
        let mut t = 0.0;
        while blob.distance(&Point3::new(-t, 0.0, 0.0)) < 0.0 {
            t += 1e-4;
        }
        assert!(back >= t - 1e-4 && back <= 0.15 + 0.0101, "{back} vs {t}");
    }

    proptest::proptest! {
        /// The broad phase's bound never exceeds the distance.
        #[test]
        fn the_distance_bound_holds(
            shape in 0..4usize,
            size in proptest::array::uniform3(0.01..0.3f64),
            bumps in (0.0..0.02f64, 0.0..60.0f64),
            point in proptest::array::uniform3(-1.0..1.0f64),
        ) {
            let [x, y, z] = size;
            let shape = [
                Shape::Box { half: Vector3::new(x, y, z), round_m: x.min(y).min(z) / 2.0 },
                Shape::Cylinder { radius: x, half_height: y, round_m: x.min(y) * z / 0.6 },
                Shape::Sphere { radius: x },
                Shape::Blob { semi: Vector3::new(x, y, z), bump_m: bumps.0, bump_rad_per_m: bumps.1 },
            ][shape];
            let p = Point3::from(Vector3::from(point));
            let (d, bound) = (shape.distance(&p), shape.distance_at_least(p.coords.norm()));
            proptest::prop_assert!(bound <= d + 1e-12, "{shape:?} at {p}: {d} < {bound}");
        }
    }

    #[test]
    fn extents_are_the_support_functions() {
        let b = Shape::Box { half: Vector3::new(0.1, 0.2, 0.3), round_m: 0.0 };
        assert!((b.extent(&Vector3::x()) - 0.1).abs() < 1e-12);
        let diagonal = Vector3::new(1.0, 1.0, 0.0).normalize();
        assert!((b.extent(&diagonal) - 0.3 / 2f64.sqrt()).abs() < 1e-12, "a corner reaches furthest");
        let rounded = Shape::Box { half: Vector3::new(0.1, 0.2, 0.3), round_m: 0.02 };
        assert!((rounded.extent(&-Vector3::y()) - 0.2).abs() < 1e-12);
        let c = Shape::Cylinder { radius: 0.1, half_height: 0.2, round_m: 0.0 };
        assert!((c.extent(&diagonal) - 0.1).abs() < 1e-12 && (c.extent(&Vector3::z()) - 0.2).abs() < 1e-12);
        let rolled = Shape::Cylinder { radius: 0.1, half_height: 0.2, round_m: 0.02 };
        let up = Vector3::new(1.0, 0.0, 1.0).normalize();
        assert!((rolled.extent(&up) - (0.08 + 0.18) / 2f64.sqrt() - 0.02).abs() < 1e-12, "a rim reaches less far");
        assert_eq!(Shape::Sphere { radius: 0.04 }.extent(&diagonal), 0.04);
    }

    #[test]
    fn the_thinnest_half_is_how_deep_the_middle_lies() {
        for shape in [
            Shape::Box { half: Vector3::new(0.2, 0.07, 0.3), round_m: 0.01 },
            Shape::Cylinder { radius: 0.11, half_height: 0.09, round_m: 0.0 },
            Shape::Cylinder { radius: 0.05, half_height: 0.2, round_m: 0.01 },
            Shape::Sphere { radius: 0.13 },
        ] {
            let middle = -shape.distance(&Point3::origin());
            assert!((shape.thinnest_half() - middle).abs() < 1e-12, "{shape:?}: {middle}");
        }
        let blob = Shape::Blob { semi: Vector3::new(0.1, 0.15, 0.08), bump_m: 0.0, bump_rad_per_m: 0.0 };
        assert_eq!(blob.thinnest_half(), 0.08);
    }
}
