//! The skin file: the cells of each link with their poses, TOML or JSON.
//!
//! ```toml
//! [[link]]
//! name = "forearm_link"
//! cell = [{ xyz = [0.0, 0.05, 0.2], rpy = [-1.5708, 0.0, 0.0] }, { xyz = [0.05, 0.0, 0.1], rpy = [0.0, 1.5708, 0.0], id = 9 }]
//! ```
//!
//! Poses are in the link frame, z of the cell along the outward normal;
//! `rpy` defaults to zero and cells without `id` get the smallest free ones.
//! The simulator reads it (`--skin`) and a calibration writes it
//! ([`skin_toml`]), so a calibrated skin can be fed back and compared.

use std::collections::BTreeSet;
use std::fmt::Write;
use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use skin_protocol::Address;

use super::{check_count, clearance, joint_axes, Cell, Skin, SkinError};
use crate::robot::Robot;

/// The largest skin file read: a thousand bytes per cell for 32,000 cells.
pub const MAX_FILE_BYTES: usize = 32 * crate::file::MIB;

impl Skin {
    /// Cells from a skin file, TOML or JSON by its extension.
    pub fn from_file(robot: &Robot, path: &Path) -> Result<Skin, SkinError> {
        let text = crate::file::read_text_capped(path, MAX_FILE_BYTES)
            .map_err(|e| SkinError::Read { path: path.display().to_string(), source: e })?;
        match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => Skin::from_toml_str(robot, &text),
            Some("json") => Skin::from_json_str(robot, &text),
            _ => Err(SkinError::Format(path.display().to_string())),
        }
    }

    /// Cells from a TOML skin description (see the module's example).
    pub fn from_toml_str(robot: &Robot, text: &str) -> Result<Skin, SkinError> {
        let file: SkinFile = toml::from_str(text).map_err(|e| SkinError::Parse(e.to_string()))?;
        file.build(robot)
    }

    /// Cells from a JSON skin description, the same fields as the TOML one:
    /// `{"link": [{"name": "forearm_link", "cell": [{"xyz": [0, 0.05, 0.2]}]}]}`.
    pub fn from_json_str(robot: &Robot, text: &str) -> Result<Skin, SkinError> {
        let file: SkinFile = serde_json::from_str(text).map_err(|e| SkinError::Parse(e.to_string()))?;
        file.build(robot)
    }
}

/// One cell as a skin file lists it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileCell<'a> {
    /// The cell's ID.
    pub id: Address,
    /// The link it is on.
    pub link: &'a str,
    /// Its pose in the link's frame, z along the cell's own z.
    pub in_link: Isometry3<f64>,
}

/// The skin file (TOML) of `cells`: links in name order, each link's cells
/// in the order given, positions and angles to six decimals (a micrometre,
/// a microradian).
pub fn skin_toml(cells: &[FileCell<'_>]) -> String {
    let mut links: Vec<&str> = cells.iter().map(|c| c.link).collect();
    links.sort_unstable();
    links.dedup();
    let mut s = String::new();
    for link in links {
        let _ = writeln!(s, "\n[[link]]\nname = {}\ncell = [", toml::Value::String(link.to_owned()));
        for c in cells.iter().filter(|c| c.link == link) {
            let t = c.in_link.translation.vector;
            let (r, p, y) = c.in_link.rotation.euler_angles();
            let _ = writeln!(
                s,
                "  {{ id = {}, xyz = [{:.6}, {:.6}, {:.6}], rpy = [{:.6}, {:.6}, {:.6}] }},",
                c.id.0, t.x, t.y, t.z, r, p, y
            );
        }
        s.push_str("]\n");
    }
    s
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SkinFile {
    link: Vec<LinkCells>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LinkCells {
    name: String,
    #[serde(default)]
    cell: Vec<CellSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CellSpec {
    xyz: [f64; 3],
    #[serde(default)]
    rpy: [f64; 3],
    id: Option<u32>,
}

impl SkinFile {
    fn build(self, robot: &Robot) -> Result<Skin, SkinError> {
        let mut cells = Vec::new();
        let mut taken = BTreeSet::new();
        for l in &self.link {
            let link = robot.link(&l.name).ok_or_else(|| SkinError::UnknownLink(l.name.clone()))?;
            for c in &l.cell {
                if !c.xyz.iter().chain(&c.rpy).all(|v| v.is_finite()) {
                    return Err(SkinError::NotFinite(l.name.clone()));
                }
                let id = match c.id {
                    Some(id) => {
                        let a = u16::try_from(id).ok().and_then(Address::cell).ok_or(SkinError::BadId(id))?;
                        if !taken.insert(a.0) {
                            return Err(SkinError::DuplicateId(a.0));
                        }
                        a
                    }
                    None => Address::UNASSIGNED,
                };
                let [r, p, y] = c.rpy;
                let in_link = Isometry3::from_parts(
                    Translation3::from(Vector3::from(c.xyz)),
                    UnitQuaternion::from_euler_angles(r, p, y),
                );
                let pose = link.in_body * in_link;
                let axis_clearance_m = clearance(&joint_axes(robot, link.body), &Point3::from(pose.translation.vector));
                cells.push(Cell { id, link: link.name.clone(), body: link.body, pose, axis_clearance_m });
            }
        }
        check_count(cells.len())?;
        let mut free = (1..=Address::MAX_CELL).filter(|id| !taken.contains(id));
        for c in cells.iter_mut().filter(|c| c.id == Address::UNASSIGNED) {
            c.id = Address(free.next().expect("check_count leaves enough free IDs"));
        }
        Ok(Skin { cells, wires: Vec::new() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::hrp2;

    #[test]
    fn a_written_skin_file_reads_back_as_the_same_cells() {
        let robot = hrp2::robot();
        let laid = Skin::with_counts(&robot, &hrp2::SKIN, 5).unwrap();
        let cells: Vec<FileCell<'_>> = laid
            .cells()
            .iter()
            .map(|c| FileCell {
                id: c.id,
                link: &c.link,
                in_link: robot.link(&c.link).unwrap().in_body.inverse() * c.pose,
            })
            .collect();
        let read = Skin::from_toml_str(&robot, &skin_toml(&cells)).unwrap();
        assert_eq!(read.cells().len(), laid.cells().len());
        for c in read.cells() {
            let was = laid.cells().iter().find(|l| l.id == c.id).unwrap();
            assert_eq!((&c.link, c.body), (&was.link, was.body));
            // Six decimals: a micrometre and a microradian per value.
            assert!((c.pose.translation.vector - was.pose.translation.vector).norm() < 2e-6, "cell {}", c.id);
            assert!(c.pose.rotation.angle_to(&was.pose.rotation) < 4e-6, "cell {}", c.id);
        }
    }

    #[test]
    fn skin_files_name_what_is_wrong() {
        let robot = hrp2::robot();
        let toml = r#"
            [[link]]
            name = "RARM_LINK3"
            cell = [{ xyz = [0.0, 0.045, -0.1], rpy = [-1.5708, 0.0, 0.0], id = 5 }, { xyz = [0.045, 0.0, -0.1] }]
        "#;
        let skin = Skin::from_toml_str(&robot, toml).unwrap();
        assert_eq!(skin.cells().iter().map(|c| c.id.0).collect::<Vec<_>>(), [5, 1]);
        let json = r#"{"link": [{"name": "RARM_LINK3", "cell": [{"xyz": [0, 0.045, -0.1]}]}]}"#;
        assert_eq!(Skin::from_json_str(&robot, json).unwrap().cells().len(), 1);
        let unknown = Skin::from_toml_str(&robot, "[[link]]\nname = \"TAIL\"\ncell = [{ xyz = [0, 0, 0] }]");
        assert!(matches!(unknown, Err(SkinError::UnknownLink(l)) if l == "TAIL"));
        let typo = Skin::from_toml_str(&robot, "[[link]]\nname = \"CHEST\"\ncell = [{ xzy = [0, 0, 0] }]");
        assert!(matches!(typo, Err(SkinError::Parse(m)) if m.contains("xzy")));
        let twice = "[[link]]\nname = \"CHEST\"\ncell = [{ xyz = [0, 0, 0], id = 3 }, { xyz = [0, 0, 0], id = 3 }]";
        assert!(matches!(Skin::from_toml_str(&robot, twice), Err(SkinError::DuplicateId(3))));
        let big = "[[link]]\nname = \"CHEST\"\ncell = [{ xyz = [0, 0, 0], id = 70000 }]";
        assert!(matches!(Skin::from_toml_str(&robot, big), Err(SkinError::BadId(70000))));
        assert!(matches!(Skin::from_toml_str(&robot, "link = []"), Err(SkinError::NoCells)));
        assert!(matches!(Skin::per_link(&robot, 0, 1), Err(SkinError::NoCells)));
    }
}
