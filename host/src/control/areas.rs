//! Touch areas (section 6.3): parts of the skin with reactions and event
//! monitors of their own.
//!
//! The grasp uses a "pat" area (launch, release and emergency button),
//! contact areas (CA) that hold the object, and the chest, the third
//! contact point. Every cell not assigned is in the non-contact area (NCA),
//! whose contacts are avoided. Areas are given in TOML by cell ID or by
//! body part (a part found by the structural exploration):
//!
//! ```toml
//! [[area]]
//! name = "left arm"
//! kind = "contact"
//! cells = [12, 14, 31]
//! parts = [4]
//! ```

use std::path::Path;

use serde::Deserialize;
use skin_protocol::Address;

use super::cells::CellIndex;
use super::reaction::Group;
use super::ControlError;
use skin_model::file::read_text_capped;

/// What an area is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AreaKind {
    /// Launch, release and emergency button.
    Pat,
    /// Surface to touch and hold the object with (CA).
    Contact,
    /// The chest: a close contact here completes the pull.
    Chest,
    /// Everything else: contacts are avoided (NCA).
    NonContact,
}

impl AreaKind {
    /// All kinds.
    pub const ALL: [AreaKind; 4] = [AreaKind::Pat, AreaKind::Contact, AreaKind::Chest, AreaKind::NonContact];
}

/// One area as the user writes it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaSpec {
    /// A name for logs and events.
    pub name: String,
    /// What the area is for.
    pub kind: AreaKind,
    /// Cell IDs in the area.
    #[serde(default)]
    pub cells: Vec<u16>,
    /// Body parts (from the structural exploration) whose cells are in the area.
    #[serde(default)]
    pub parts: Vec<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AreasFile {
    #[serde(default)]
    area: Vec<AreaSpec>,
}

/// Parses the `[[area]]` tables of a TOML document.
pub fn parse_specs(text: &str) -> Result<Vec<AreaSpec>, ControlError> {
    toml::from_str::<AreasFile>(text).map(|f| f.area).map_err(ControlError::Toml)
}

/// Reads the `[[area]]` tables of a TOML file.
pub fn read_specs(path: &Path) -> Result<Vec<AreaSpec>, ControlError> {
    let text = read_text_capped(path, super::MAX_FILE_BYTES)
        .map_err(|source| ControlError::Read { path: path.display().to_string(), source })?;
    parse_specs(&text)
}

/// An area's index; also the reaction [`Group`] of its cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AreaId(pub u16);

impl AreaId {
    /// The non-contact area: every cell not assigned elsewhere.
    pub const NON_CONTACT: AreaId = AreaId(0);
}

/// Every map cell's area.
#[derive(Clone, Debug)]
pub struct Areas {
    names: Vec<String>,
    kinds: Vec<AreaKind>,
    area_of: Vec<AreaId>,
}

impl Areas {
    /// Resolves specs against the map's cells; `part_of` gives a cell's body
    /// part. A cell in two areas, an unknown cell or part, or an area that
    /// gets no cell is a user mistake.
    pub fn resolve(
        specs: &[AreaSpec],
        index: &CellIndex,
        part_of: impl Fn(Address) -> Option<usize>,
    ) -> Result<Areas, ControlError> {
        let mut names = vec!["non-contact".to_owned()];
        let mut kinds = vec![AreaKind::NonContact];
        let mut area_of = vec![AreaId::NON_CONTACT; index.len()];
        let mut assigned = vec![false; index.len()];
        if specs.len() >= usize::from(u16::MAX) {
            return Err(ControlError::TooManyGroups);
        }
        for spec in specs {
            if names.contains(&spec.name) {
                return Err(ControlError::DuplicateArea(spec.name.clone()));
            }
            let id = AreaId(names.len() as u16);
            let mut rows = Vec::new();
            for &c in &spec.cells {
                let row = index
                    .row(Address(c))
                    .ok_or_else(|| ControlError::UnknownAreaCell { area: spec.name.clone(), cell: c })?;
                rows.push(row);
            }
            for &p in &spec.parts {
                let before = rows.len();
                rows.extend((0..index.len()).filter(|&r| part_of(index.address(r)) == Some(p)));
                if rows.len() == before {
                    return Err(ControlError::UnknownPart { area: spec.name.clone(), part: p });
                }
            }
            if rows.is_empty() {
                return Err(ControlError::EmptyArea(spec.name.clone()));
            }
            for row in rows {
                if assigned[row] && area_of[row] != id {
                    let other = names[usize::from(area_of[row].0)].clone();
                    return Err(ControlError::CellInTwoAreas {
                        cell: index.address(row).0,
                        first: other,
                        second: spec.name.clone(),
                    });
                }
                assigned[row] = true;
                area_of[row] = id;
            }
            names.push(spec.name.clone());
            kinds.push(spec.kind);
        }
        Ok(Areas { names, kinds, area_of })
    }

    /// Number of areas, the implicit non-contact one included.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Never empty: the non-contact area always exists.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The area of a map row.
    pub fn area_of(&self, row: usize) -> AreaId {
        self.area_of[row]
    }

    /// An area's name.
    pub fn name(&self, area: AreaId) -> &str {
        &self.names[usize::from(area.0)]
    }

    /// An area's kind.
    pub fn kind(&self, area: AreaId) -> AreaKind {
        self.kinds[usize::from(area.0)]
    }

    /// All areas.
    pub fn ids(&self) -> impl Iterator<Item = AreaId> + '_ {
        (0..self.names.len() as u16).map(AreaId)
    }

    /// The areas of a kind.
    pub fn of_kind(&self, kind: AreaKind) -> impl Iterator<Item = AreaId> + '_ {
        self.ids().filter(move |a| self.kind(*a) == kind)
    }

    /// Every row's reaction group (its area).
    pub fn groups(&self) -> Vec<Group> {
        self.area_of.iter().map(|a| Group(a.0)).collect()
    }

    /// The rows of an area (a linear scan: for setup and reports).
    pub fn rows(&self, area: AreaId) -> impl Iterator<Item = usize> + '_ {
        self.area_of.iter().enumerate().filter(move |(_, a)| **a == area).map(|(r, _)| r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOML: &str = r#"
        [[area]]
        name = "pat"
        kind = "pat"
        cells = [5]

        [[area]]
        name = "left arm"
        kind = "contact"
        parts = [2]
        cells = [3]
    "#;

    fn index() -> CellIndex {
        CellIndex::new(&[1, 2, 3, 4, 5, 6].map(Address)).unwrap()
    }

    fn part(a: Address) -> Option<usize> {
        Some(if a.0 <= 2 { 1 } else { 2 })
    }

    #[test]
    fn by_cell_and_by_part_rest_is_non_contact() {
        let areas = Areas::resolve(&parse_specs(TOML).unwrap(), &index(), |a| match a.0 {
            3 | 4 => Some(2),
            _ => Some(1),
        })
        .unwrap();
        assert_eq!(areas.len(), 3);
        let kinds: Vec<_> = (0..6).map(|r| areas.kind(areas.area_of(r))).collect();
        use AreaKind::*;
        assert_eq!(kinds, [NonContact, NonContact, Contact, Contact, Pat, NonContact]);
        assert_eq!(areas.name(areas.area_of(4)), "pat");
        assert_eq!(areas.of_kind(Contact).collect::<Vec<_>>(), [AreaId(2)]);
        assert_eq!(areas.rows(AreaId(2)).collect::<Vec<_>>(), [2, 3]);
    }

    #[test]
    fn user_mistakes_are_named() {
        let spec = |name: &str, cells: Vec<u16>, parts: Vec<usize>| AreaSpec {
            name: name.into(),
            kind: AreaKind::Contact,
            cells,
            parts,
        };
        let ix = index();
        let err = |specs: &[AreaSpec]| Areas::resolve(specs, &ix, part).unwrap_err();
        assert!(matches!(err(&[spec("a", vec![9], vec![])]), ControlError::UnknownAreaCell { cell: 9, .. }));
        assert!(matches!(err(&[spec("a", vec![], vec![7])]), ControlError::UnknownPart { part: 7, .. }));
        assert!(matches!(err(&[spec("a", vec![], vec![])]), ControlError::EmptyArea(_)));
        assert!(matches!(
            err(&[spec("a", vec![1], vec![]), spec("b", vec![], vec![1])]),
            ControlError::CellInTwoAreas { cell: 1, .. }
        ));
        assert!(matches!(
            err(&[spec("a", vec![1], vec![]), spec("a", vec![3], vec![])]),
            ControlError::DuplicateArea(_)
        ));
        assert!(parse_specs("[[area]]\nname = 'x'\nkind = 'elbow'").is_err());
        assert!(parse_specs("[[area]]\nname = 'x'\nkind = 'pat'\ncell = [1]").is_err());
    }
}
