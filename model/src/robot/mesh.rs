//! A link's triangle mesh, as a physics engine compiled it (MuJoCo's
//! `mesh_vert` and `mesh_face`): the skin lies on its faces, not on a box
//! around them.

use nalgebra::{Point3, Vector3};

/// Triangles in a shape's frame, wound counterclockwise seen from outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    vertices: Vec<Point3<f64>>,
    faces: Vec<[u32; 3]>,
    /// Each face's area, m^2, in face order.
    areas: Vec<f64>,
}

impl Mesh {
    /// The mesh of `vertices` and `faces` (indices into `vertices`); faces
    /// naming a vertex that does not exist, or of no area, are left out.
    pub fn new(vertices: Vec<Point3<f64>>, faces: impl IntoIterator<Item = [u32; 3]>) -> Mesh {
        let n = vertices.len();
        let mut kept = Vec::new();
        let mut areas = Vec::new();
        for face in faces {
            if face.iter().any(|&i| i as usize >= n) {
                continue;
            }
            let area = cross(&vertices, face).norm() / 2.0;
            if area > 0.0 && area.is_finite() {
                kept.push(face);
                areas.push(area);
            }
        }
        Mesh { vertices, faces: kept, areas }
    }

    /// The vertices, shape frame.
    pub fn vertices(&self) -> &[Point3<f64>] {
        &self.vertices
    }

    /// The faces kept, as indices into [`Mesh::vertices`].
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }

    /// Each face's area, m^2, in face order.
    pub fn face_areas(&self) -> &[f64] {
        &self.areas
    }

    /// The surface area, m^2.
    pub fn area(&self) -> f64 {
        self.areas.iter().sum()
    }

    /// The point at barycentric weights `(u, v)` (`u + v <= 1`) of face `f`
    /// and the face's outward unit normal.
    pub fn point_on(&self, f: usize, u: f64, v: f64) -> (Point3<f64>, Vector3<f64>) {
        let [a, b, c] = self.faces[f].map(|i| self.vertices[i as usize]);
        let p = a + (b - a) * u + (c - a) * v;
        (p, cross(&self.vertices, self.faces[f]).normalize())
    }

    /// The enclosed volume, m^3 (of a closed mesh), and its centroid.
    pub fn volume(&self) -> (f64, Point3<f64>) {
        let (mut volume, mut moment) = (0.0, Vector3::zeros());
        for face in &self.faces {
            let [a, b, c] = face.map(|i| self.vertices[i as usize].coords);
            let v = a.dot(&b.cross(&c)) / 6.0;
            volume += v;
            moment += (a + b + c) * (v / 4.0);
        }
        let centre = if volume.abs() > 0.0 { Point3::from(moment / volume) } else { Point3::origin() };
        (volume.abs(), centre)
    }
}

/// `(b - a) x (c - a)` of a face: twice its area along its normal.
fn cross(vertices: &[Point3<f64>], [a, b, c]: [u32; 3]) -> Vector3<f64> {
    let [a, b, c] = [a, b, c].map(|i| vertices[i as usize]);
    (b - a).cross(&(c - a))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's twelve outward triangles.
    fn cube() -> Mesh {
        let vertices =
            (0..8).map(|k| Point3::new(f64::from(k & 1), f64::from((k >> 1) & 1), f64::from(k >> 2))).collect();
        let faces = [
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        Mesh::new(vertices, faces)
    }

    #[test]
    fn a_cubes_area_volume_centre_and_normals_come_out_of_its_faces() {
        let m = cube();
        assert!((m.area() - 6.0).abs() < 1e-12);
        let (volume, centre) = m.volume();
        assert!((volume - 1.0).abs() < 1e-12 && (centre - Point3::new(0.5, 0.5, 0.5)).norm() < 1e-12);
        for f in 0..m.faces().len() {
            let (p, n) = m.point_on(f, 0.25, 0.25);
            // Outward: away from the centre, and the point on the cube's surface.
            assert!(n.dot(&(p - centre)) > 0.0, "face {f}");
            assert!(p.coords.iter().any(|&x| x == 0.0 || x == 1.0), "face {f}: {p}");
        }
    }

    #[test]
    fn faces_naming_missing_vertices_or_of_no_area_are_left_out() {
        let vertices = vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)];
        let m = Mesh::new(vertices, [[0, 1, 2], [0, 1, 7], [0, 0, 1]]);
        assert_eq!(m.faces(), &[[0, 1, 2]]);
        assert_eq!(m.face_areas(), &[0.5]);
    }
}
