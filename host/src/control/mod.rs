//! Whole-body tactile control (sections 5 and 6).
//!
//! Touch is turned into motion only through the self-explored
//! sensory-motor map: no robot model, no cell placement. Per control
//! period, the [`controller::Controller`] takes the samples (and cell
//! events) that arrived, turns level changes into [`events`] located by
//! touch [`areas`], lets the [`grasp`] state machine react to them, and
//! sums the cellular [`reaction`]s of equation (14) with the key-pose
//! [`trajectory`]. [`teach`] drives the robot by touch to record key poses;
//! [`params`] holds Table 4 as an editable TOML file. Work per period
//! grows with the number of touched cells, not with the size of the skin.

pub mod areas;
pub mod cells;
pub mod controller;
pub mod events;
pub mod grasp;
pub mod params;
pub mod reaction;
pub mod teach;
pub mod trajectory;

use skin_protocol::Address;

/// The largest parameter, area or key-pose file read: a few KiB is usual.
pub const MAX_FILE_BYTES: usize = skin_model::file::MIB;

/// The sensory-motor map as control uses it (section 4.3.3).
///
/// Sign convention of equation (11): a weight of +1 means a positive
/// velocity of the DoF moves the cell into its surface, away from what
/// touches it, so `omega = w * reaction` evades.
pub trait MotorMap {
    /// Number of DoFs, the length of every weight row.
    fn dofs(&self) -> usize;
    /// The cells with a weight row, in row order.
    fn cells(&self) -> &[Address];
    /// The tile explored nearest to `pose` (quadratic distance); `None`
    /// when the map has no tile.
    fn nearest_tile(&self, pose: &[f64]) -> Option<usize>;
    /// The weight row (one value per DoF) of map row `row` in tile `tile`.
    fn weights(&self, tile: usize, row: usize) -> &[f32];
}

/// Why tactile control cannot do what it was asked.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A TOML document is malformed or has an unknown key.
    #[error("{0} (compare with host/config/grasp.toml)")]
    Toml(#[from] toml::de::Error),
    /// A state gives some of the keys that go together, not all.
    #[error("{0}")]
    Incomplete(String),
    /// An error in a named file.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// What is wrong in it.
        source: Box<ControlError>,
    },
    /// A number outside its range.
    #[error("{what} = {value:?} is out of range: expected {expected}")]
    Range {
        /// The parameter.
        what: String,
        /// Its value.
        value: f64,
        /// What it should be.
        expected: &'static str,
    },
    /// Tactile level bounds that are not usable.
    #[error("tactile levels: {0}")]
    Levels(&'static str),
    /// An address that is not a cell ID.
    #[error("address {0} is not a cell ID (1..=65279)")]
    NotACell(u16),
    /// A cell listed twice in the map.
    #[error("cell {0} appears twice in the sensory-motor map")]
    DuplicateCell(u16),
    /// A map row that does not exist.
    #[error("there is no map row {0}")]
    UnknownRow(usize),
    /// A reaction group that does not exist.
    #[error("there is no reaction group {0}")]
    UnknownGroup(u16),
    /// More reaction groups than fit in 16 bits.
    #[error("too many reaction groups (at most 65535 areas and cells with gains of their own)")]
    TooManyGroups,
    /// Two areas of one name.
    #[error("two touch areas are named \"{0}\": give each a name of its own")]
    DuplicateArea(String),
    /// An area lists a cell the map does not know.
    #[error("touch area \"{area}\" lists cell {cell}, which the sensory-motor map does not know")]
    UnknownAreaCell {
        /// The area.
        area: String,
        /// The cell ID.
        cell: u16,
    },
    /// An area lists a body part without cells.
    #[error("touch area \"{area}\" lists body part {part}, which has no cells")]
    UnknownPart {
        /// The area.
        area: String,
        /// The body part.
        part: usize,
    },
    /// An area without cells.
    #[error("touch area \"{0}\" has no cells: list `cells` or `parts`")]
    EmptyArea(String),
    /// A cell in two areas.
    #[error("cell {cell} is in touch areas \"{first}\" and \"{second}\": give each cell one area")]
    CellInTwoAreas {
        /// The cell ID.
        cell: u16,
        /// The first area.
        first: String,
        /// The second area.
        second: String,
    },
    /// A pose or command of the wrong length.
    #[error("{got} values for a robot with {expected} DoFs")]
    Dimension {
        /// DoFs.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A key pose with a NaN or infinite angle.
    #[error("key pose \"{0}\" has an angle that is not finite")]
    BadPose(String),
    /// A key pose that has not been taught.
    #[error("key pose \"{0}\" has not been taught (teach home, open, closed and pulled first)")]
    MissingPose(String),
}

impl MotorMap for crate::explore::SensoryMotorMap {
    fn dofs(&self) -> usize {
        self.tiles().first().map_or(0, |t| t.pose().len())
    }

    fn cells(&self) -> &[Address] {
        crate::explore::SensoryMotorMap::cells(self)
    }

    fn nearest_tile(&self, pose: &[f64]) -> Option<usize> {
        let distance = |p: &[f64]| p.iter().zip(pose).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        let tiles = self.tiles();
        (0..tiles.len()).min_by(|a, b| distance(tiles[*a].pose()).total_cmp(&distance(tiles[*b].pose())))
    }

    fn weights(&self, tile: usize, row: usize) -> &[f32] {
        self.tiles()[tile].weights(row)
    }
}

pub mod dense {
    //! A map given by its tiles: synthetic skins for benchmarks and tests.

    use super::MotorMap;
    use skin_protocol::Address;

    /// Tiles of `(pose, row-major weights)`, cells `1..=n`.
    pub struct DenseMap {
        cells: Vec<Address>,
        dofs: usize,
        tiles: Vec<(Vec<f64>, Vec<f32>)>,
    }

    impl DenseMap {
        /// A map of `cells` cells (addresses `1..=cells`) and `dofs` DoFs.
        ///
        /// # Panics
        /// When a tile's pose or weights do not have those sizes.
        pub fn new(cells: usize, dofs: usize, tiles: Vec<(Vec<f64>, Vec<f32>)>) -> DenseMap {
            assert!(tiles.iter().all(|(p, w)| p.len() == dofs && w.len() == cells * dofs));
            DenseMap { cells: (1..=cells as u16).map(Address).collect(), dofs, tiles }
        }
    }

    impl MotorMap for DenseMap {
        fn dofs(&self) -> usize {
            self.dofs
        }
        fn cells(&self) -> &[Address] {
            &self.cells
        }
        fn nearest_tile(&self, pose: &[f64]) -> Option<usize> {
            let d = |p: &[f64]| p.iter().zip(pose).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            (0..self.tiles.len()).min_by(|a, b| d(&self.tiles[*a].0).total_cmp(&d(&self.tiles[*b].0)))
        }
        fn weights(&self, tile: usize, row: usize) -> &[f32] {
            &self.tiles[tile].1[row * self.dofs..(row + 1) * self.dofs]
        }
    }
}
