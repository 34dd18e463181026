//! Multi-modal cellular reaction primitives, equation (14).
//!
//! Every cell has one controller with a threshold `t_m` and a gain `P_m`
//! per modality: a normalized reading `rho_m` above its threshold gives a
//! proportional reaction `(rho_m - t_m) * P_m`; a cell's reactions are
//! summed and mapped to joint velocities through its row of the
//! sensory-motor map tile nearest the current pose, and all cells are
//! superposed. A gain of 0 inhibits a modality, a gain above 1 promotes it,
//! a negative gain inverts it (the cell is attracted instead of evading).
//!
//! Cells share parameters through groups (a touch area is a group); a cell
//! can also get a group of its own. Only stimulated cells, those with a
//! reading above the noise floor, are visited in a step, so a quiet cell
//! costs nothing however large the skin.

use serde::{Deserialize, Serialize};
use skin_protocol::Sample;

use super::cells::SparseSet;
use super::{ControlError, MotorMap};

/// Largest reaction gain a parameter file may give.
const MAX_GAIN: f64 = 100.0;

/// Readings at or below this are noise: the cell is quiet. Every active
/// threshold must be at least this, so that a quiet cell never reacts.
pub const NOISE_FLOOR: f64 = 0.005;

/// Threshold and gain of one modality of one cell.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Primitive {
    /// Activation level `t_m`, normalized reading.
    #[serde(default = "Primitive::unreachable")]
    pub threshold: f64,
    /// Proportional gain `P_m`, rad/s per unit of normalized reading above
    /// the threshold (scaled by the map weight).
    #[serde(default)]
    pub gain: f64,
}

impl Primitive {
    /// No reaction (Table 4's "-").
    pub const OFF: Primitive = Primitive { threshold: 1.0, gain: 0.0 };

    fn unreachable() -> f64 {
        1.0
    }

    /// A primitive with the given threshold and gain.
    pub fn new(threshold: f64, gain: f64) -> Primitive {
        Primitive { threshold, gain }
    }

    /// `(rho > t) * (rho - t) * P`.
    #[inline]
    pub fn react(&self, rho: f64) -> f64 {
        if rho > self.threshold {
            (rho - self.threshold) * self.gain
        } else {
            0.0
        }
    }

    fn check(&self, what: &str) -> Result<(), ControlError> {
        // Table 4's gains are at most 1: a gain past 100 is a typo that
        // would drive the joints at their limit on any reading.
        if !(-MAX_GAIN..=MAX_GAIN).contains(&self.gain) {
            return Err(ControlError::Range {
                what: format!("{what} gain"),
                value: self.gain,
                expected: "a gain in [-100, 100]",
            });
        }
        if self.gain != 0.0 && !(NOISE_FLOOR..=1.0).contains(&self.threshold) {
            return Err(ControlError::Range {
                what: format!("{what} threshold"),
                value: self.threshold,
                expected: "between the noise floor 0.005 and 1",
            });
        }
        Ok(())
    }
}

/// The parameters of one cell's multi-modal controller.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellGains {
    /// Applied to each of the three normal-force cells.
    #[serde(default = "off")]
    pub force: Primitive,
    /// Applied to the proximity (pre-contact) sensor.
    #[serde(default = "off")]
    pub proximity: Primitive,
}

fn off() -> Primitive {
    Primitive::OFF
}

impl CellGains {
    /// No reaction at all.
    pub const OFF: CellGains = CellGains { force: Primitive::OFF, proximity: Primitive::OFF };

    /// The sum over modalities of equation (14) for one cell.
    #[inline]
    pub fn react(&self, s: &Stimulus) -> f64 {
        s.force.iter().map(|&f| self.force.react(f)).sum::<f64>() + self.proximity.react(s.proximity)
    }

    /// Checks gains are finite and active thresholds lie above the noise floor.
    pub fn check(&self) -> Result<(), ControlError> {
        self.force.check("force")?;
        self.proximity.check("proximity")
    }
}

/// One cell's normalized readings, the units of Tables 3 and 4.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stimulus {
    /// The three normal-force cells, 0..1 of full scale.
    pub force: [f64; 3],
    /// Proximity intensity, 0..1 of full scale.
    pub proximity: f64,
}

impl Stimulus {
    /// Whether any reading is above the noise floor.
    pub fn is_stimulated(&self) -> bool {
        self.proximity > NOISE_FLOOR || self.force.iter().any(|f| *f > NOISE_FLOOR)
    }
}

impl From<&Sample> for Stimulus {
    fn from(s: &Sample) -> Stimulus {
        Stimulus { force: s.force_norm().map(f64::from), proximity: f64::from(s.proximity_norm()) }
    }
}

/// A group of cells sharing one set of gains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Group(pub u16);

/// The reaction controllers of all cells and their superposition.
#[derive(Clone, Debug)]
pub struct Reactions {
    dofs: usize,
    groups: Vec<CellGains>,
    group_of: Vec<Group>,
    stimulus: Vec<Stimulus>,
    stimulated: SparseSet,
    smoothing_s: f64,
    raw: Vec<f64>,
    output: Vec<f64>,
    reacting: usize,
}

impl Reactions {
    /// Controllers for `group_of.len()` cells (one entry per map row) and
    /// `dofs` DoFs; group `g` starts with gains `groups[g]`.
    pub fn new(dofs: usize, group_of: Vec<Group>, groups: Vec<CellGains>) -> Result<Reactions, ControlError> {
        for g in &groups {
            g.check()?;
        }
        if let Some(g) = group_of.iter().find(|g| usize::from(g.0) >= groups.len()) {
            return Err(ControlError::UnknownGroup(g.0));
        }
        let cells = group_of.len();
        Ok(Reactions {
            dofs,
            groups,
            group_of,
            stimulus: vec![Stimulus::default(); cells],
            stimulated: SparseSet::new(cells),
            smoothing_s: 0.0,
            raw: vec![0.0; dofs],
            output: vec![0.0; dofs],
            reacting: 0,
        })
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.group_of.len()
    }

    /// Sets the gains of a group; every cell of it reacts with them from
    /// the next step on. O(1): cells look their group up when stimulated.
    pub fn set_group(&mut self, group: Group, gains: CellGains) -> Result<(), ControlError> {
        gains.check()?;
        *self.groups.get_mut(usize::from(group.0)).ok_or(ControlError::UnknownGroup(group.0))? = gains;
        Ok(())
    }

    /// The gains of a group.
    pub fn group(&self, group: Group) -> Option<CellGains> {
        self.groups.get(usize::from(group.0)).copied()
    }

    /// Gives one cell gains of its own (a new group, returned).
    pub fn set_cell(&mut self, row: usize, gains: CellGains) -> Result<Group, ControlError> {
        gains.check()?;
        if row >= self.cells() {
            return Err(ControlError::UnknownRow(row));
        }
        let g = u16::try_from(self.groups.len()).map_err(|_| ControlError::TooManyGroups)?;
        self.groups.push(gains);
        self.group_of[row] = Group(g);
        Ok(Group(g))
    }

    /// Time constant of the first-order smoothing of the response, s (0:
    /// none, the reaction follows the stimulus at once).
    pub fn set_smoothing(&mut self, tau_s: f64) -> Result<(), ControlError> {
        if !(tau_s.is_finite() && tau_s >= 0.0) {
            return Err(ControlError::Range { what: "smoothing".into(), value: tau_s, expected: ">= 0 s" });
        }
        self.smoothing_s = tau_s;
        Ok(())
    }

    /// The latest readings of a cell. O(1).
    pub fn stimulate(&mut self, row: usize, s: Stimulus) {
        self.stimulus[row] = s;
        if s.is_stimulated() {
            self.stimulated.insert(row);
        } else {
            self.stimulated.remove(row);
        }
    }

    /// The latest readings of a cell.
    pub fn stimulus(&self, row: usize) -> Stimulus {
        self.stimulus[row]
    }

    /// Number of cells with a reading above the noise floor.
    pub fn stimulated(&self) -> usize {
        self.stimulated.len()
    }

    /// Number of cells that reacted in the last step.
    pub fn reacting(&self) -> usize {
        self.reacting
    }

    /// Equation (14) at `pose`, with `dt_s` since the last step for the
    /// smoothing: the tactile joint velocity, rad/s. Visits stimulated
    /// cells only; a map without tiles gives no reaction.
    pub fn step(&mut self, map: &impl MotorMap, pose: &[f64], dt_s: f64) -> &[f64] {
        self.raw.fill(0.0);
        self.reacting = 0;
        if let Some(tile) = map.nearest_tile(pose) {
            for row in self.stimulated.rows() {
                let gains = &self.groups[usize::from(self.group_of[row].0)];
                let s = gains.react(&self.stimulus[row]);
                if s != 0.0 {
                    self.reacting += 1;
                    for (o, w) in self.raw.iter_mut().zip(map.weights(tile, row)) {
                        *o += f64::from(*w) * s;
                    }
                }
            }
        }
        if self.smoothing_s > 0.0 {
            let a = 1.0 - (-dt_s.max(0.0) / self.smoothing_s).exp();
            for (o, r) in self.output.iter_mut().zip(&self.raw) {
                *o += a * (r - *o);
            }
        } else {
            self.output.copy_from_slice(&self.raw);
        }
        &self.output
    }

    /// Number of DoFs.
    pub fn dofs(&self) -> usize {
        self.dofs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::dense::DenseMap;

    fn one_cell(weights: Vec<f32>, gains: CellGains) -> (DenseMap, Reactions) {
        let d = weights.len();
        let map = DenseMap::new(1, d, vec![(vec![0.0; d], weights)]);
        (map, Reactions::new(d, vec![Group(0)], vec![gains]).unwrap())
    }

    /// Section 5.3: a force cell reading of 0.14 (1.0 N), threshold 0.05,
    /// gain 1.0 and a map weight of 1.0 on one DoF give 0.09 rad/s there.
    #[test]
    fn the_papers_force_guidance_example() {
        let gains = CellGains { force: Primitive::new(0.05, 1.0), proximity: Primitive::OFF };
        let (map, mut r) = one_cell(vec![0.0, 1.0, 0.0], gains);
        r.stimulate(0, Stimulus { force: [0.14, 0.0, 0.0], proximity: 0.0 });
        let w = r.step(&map, &[0.0; 3], 0.004);
        assert!((w[1] - 0.09).abs() < 1e-12, "{w:?}");
        assert_eq!((w[0], w[2]), (0.0, 0.0));
    }

    #[test]
    fn below_threshold_nothing_and_gains_inhibit_promote_invert() {
        let mut gains = CellGains { force: Primitive::new(0.05, 1.0), proximity: Primitive::new(0.01, 0.4) };
        let (map, mut r) = one_cell(vec![0.5], gains);
        r.stimulate(0, Stimulus { force: [0.04, 0.05, 0.0], proximity: 0.01 });
        assert_eq!(r.step(&map, &[0.0], 0.004), &[0.0]);
        r.stimulate(0, Stimulus { force: [0.15, 0.0, 0.0], proximity: 0.11 });
        let base = r.step(&map, &[0.0], 0.004)[0];
        assert!((base - 0.5 * (0.10 + 0.04)).abs() < 1e-12);
        for (p, expect) in [(0.0, 0.5 * 0.04), (2.0, 0.5 * (0.2 + 0.04)), (-1.0, 0.5 * (-0.1 + 0.04))] {
            gains.force.gain = p;
            r.set_group(Group(0), gains).unwrap();
            assert!((r.step(&map, &[0.0], 0.004)[0] - expect).abs() < 1e-12, "gain {p}");
        }
    }

    #[test]
    fn cells_superpose_through_the_nearest_tile() {
        // Two tiles: the one near pose 1.0 has the opposite weights.
        let map = DenseMap::new(
            2,
            2,
            vec![(vec![0.0, 0.0], vec![1.0, 0.0, 0.0, 1.0]), (vec![1.0, 1.0], vec![-1.0, 0.0, 0.0, -1.0])],
        );
        let g = CellGains { force: Primitive::new(0.05, 1.0), proximity: Primitive::OFF };
        let mut r = Reactions::new(2, vec![Group(0); 2], vec![g]).unwrap();
        r.stimulate(0, Stimulus { force: [0.15, 0.15, 0.0], proximity: 0.0 });
        r.stimulate(1, Stimulus { force: [0.0, 0.0, 0.25], proximity: 0.0 });
        let near_zero = r.step(&map, &[0.1, 0.2], 0.004).to_vec();
        assert!((near_zero[0] - 0.2).abs() < 1e-12 && (near_zero[1] - 0.2).abs() < 1e-12);
        let near_one = r.step(&map, &[0.9, 0.7], 0.004).to_vec();
        assert!((near_one[0] + 0.2).abs() < 1e-12 && (near_one[1] + 0.2).abs() < 1e-12);
        assert_eq!(r.reacting(), 2);
    }

    #[test]
    fn quiet_cells_leave_the_active_set_and_own_gains_override_the_group() {
        let g = CellGains { force: Primitive::new(0.05, 1.0), proximity: Primitive::OFF };
        let map = DenseMap::new(3, 1, vec![(vec![0.0], vec![1.0, 1.0, 1.0])]);
        let mut r = Reactions::new(1, vec![Group(0); 3], vec![g]).unwrap();
        r.stimulate(2, Stimulus { force: [0.2, 0.0, 0.0], proximity: 0.0 });
        assert_eq!(r.stimulated(), 1);
        r.stimulate(2, Stimulus::default());
        assert_eq!(r.stimulated(), 0);
        assert_eq!(r.step(&map, &[0.0], 0.004), &[0.0]);
        let own = r.set_cell(1, CellGains { force: Primitive::new(0.05, 3.0), ..g }).unwrap();
        assert_eq!(own, Group(1));
        r.stimulate(0, Stimulus { force: [0.15, 0.0, 0.0], proximity: 0.0 });
        r.stimulate(1, Stimulus { force: [0.15, 0.0, 0.0], proximity: 0.0 });
        assert!((r.step(&map, &[0.0], 0.004)[0] - 0.4).abs() < 1e-12);
    }

    #[test]
    fn smoothing_is_a_first_order_lag() {
        let g = CellGains { force: Primitive::new(0.05, 1.0), proximity: Primitive::OFF };
        let (map, mut r) = one_cell(vec![1.0], g);
        r.set_smoothing(0.1).unwrap();
        r.stimulate(0, Stimulus { force: [0.15, 0.0, 0.0], proximity: 0.0 });
        let first = r.step(&map, &[0.0], 0.1)[0];
        assert!((first - 0.1 * (1.0 - (-1.0f64).exp())).abs() < 1e-12);
        for _ in 0..100 {
            r.step(&map, &[0.0], 0.1);
        }
        assert!((r.step(&map, &[0.0], 0.1)[0] - 0.1).abs() < 1e-9);
        assert!(r.set_smoothing(f64::NAN).is_err());
    }

    #[test]
    fn bad_gains_are_refused() {
        let below_floor = CellGains { force: Primitive::new(0.001, 1.0), proximity: Primitive::OFF };
        assert!(Reactions::new(1, vec![Group(0)], vec![below_floor]).is_err());
        let infinite = CellGains { force: Primitive::new(0.05, f64::INFINITY), proximity: Primitive::OFF };
        assert!(infinite.check().is_err());
        assert!(matches!(Reactions::new(1, vec![Group(1)], vec![CellGains::OFF]), Err(ControlError::UnknownGroup(1))));
        // A threshold does not matter while the modality is inhibited.
        assert!(CellGains { force: Primitive::new(-3.0, 0.0), proximity: Primitive::OFF }.check().is_ok());
    }
}
