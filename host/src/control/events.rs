//! Tactile events (section 5.2): Table 3 levels with hysteresis, emitted
//! only on a change of level, located by touch area.
//!
//! The host quantizes the samples of cells that do not quantize themselves;
//! a cell that sends its own [`TactileEvent`]s (the processing in the cell,
//! event traffic) is taken at its word from its first event on, and its
//! samples are no longer quantized here. Per area and modality the number
//! of cells at each level is kept up to date, so a question like "is every
//! contact area at medium force?" costs O(areas), not O(cells).

use serde::Serialize;
use skin_protocol::event::{Quantizer, FORCE_LEVELS, HYSTERESIS, PROXIMITY_LEVELS};
use skin_protocol::message::{Channel, TactileEvent};
use skin_protocol::{Address, Sample};

use super::areas::{AreaId, AreaKind, Areas};
use super::ControlError;

/// A sensing modality with tactile levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Modality {
    /// The three normal-force cells (a cell's level is their highest).
    Force,
    /// The proximity (pre-contact) sensor.
    Proximity,
}

impl Modality {
    fn of(channel: Channel) -> Modality {
        match channel {
            Channel::Proximity => Modality::Proximity,
            _ => Modality::Force,
        }
    }
}

/// Table 3 levels: lower bounds of levels 1..=4.
pub mod level {
    /// Force level at which pain begins.
    pub const PAIN: u8 = 4;
    /// The force level below pain (Table 3's high force).
    pub const HIGH: u8 = 3;
    /// Proximity level of a close contact.
    pub const CLOSE_CONTACT: u8 = 4;
}

/// Level bounds (normalized readings) and hysteresis of the quantizers.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Levels {
    /// Lower bounds of low, medium, high and pain force.
    pub force: [f32; 4],
    /// Lower bounds of high, medium and low proximity and close contact.
    pub proximity: [f32; 4],
    /// A level is left only this far below its bound.
    pub hysteresis: f32,
}

impl Default for Levels {
    /// Table 3.
    fn default() -> Levels {
        Levels { force: FORCE_LEVELS, proximity: PROXIMITY_LEVELS, hysteresis: HYSTERESIS }
    }
}

impl Levels {
    /// Checks bounds are ascending within `[0, 1]` and the hysteresis small.
    pub fn check(&self) -> Result<(), ControlError> {
        for bounds in [self.force, self.proximity] {
            let ok = bounds.iter().all(|b| (0.0..=1.0).contains(b)) && bounds.windows(2).all(|w| w[0] < w[1]);
            if !ok {
                return Err(ControlError::Levels("level bounds must ascend strictly within [0, 1]"));
            }
        }
        if !(0.0..=0.1).contains(&self.hysteresis) {
            return Err(ControlError::Levels("the hysteresis must lie in [0, 0.1]"));
        }
        Ok(())
    }
}

/// A change of level on one channel of one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct TouchEvent {
    /// The cell.
    pub cell: Address,
    /// Its map row.
    #[serde(skip)]
    pub row: usize,
    /// Its touch area.
    #[serde(skip)]
    pub area: AreaId,
    /// The modality that changed.
    pub modality: Modality,
    /// The sensor that changed (`0` proximity, `1..=3` force cells).
    pub sensor: u8,
    /// The new level, 0..=4.
    pub level: u8,
}

const CHANNELS: [Channel; 4] = [Channel::Proximity, Channel::Force0, Channel::Force1, Channel::Force2];

/// Level state of every cell and per-area level counts.
#[derive(Clone, Debug)]
pub struct Events {
    quantizers: Vec<[Quantizer; 4]>,
    channel_levels: Vec<[u8; 4]>,
    self_quantizing: Vec<bool>,
    area_of: Vec<AreaId>,
    kinds: Vec<AreaKind>,
    /// Per area, per modality (force, proximity): cells at each level.
    counts: Vec<[[u32; 5]; 2]>,
}

impl Events {
    /// Everything at level 0.
    pub fn new(areas: &Areas, levels: &Levels) -> Result<Events, ControlError> {
        levels.check()?;
        let q = Quantizer::new(levels.proximity, levels.hysteresis);
        let f = Quantizer::new(levels.force, levels.hysteresis);
        let cells = areas.groups().len();
        let area_of: Vec<AreaId> = (0..cells).map(|r| areas.area_of(r)).collect();
        let mut counts = vec![[[0; 5]; 2]; areas.len()];
        for a in &area_of {
            for m in &mut counts[usize::from(a.0)] {
                m[0] += 1;
            }
        }
        Ok(Events {
            quantizers: vec![[q, f, f, f]; cells],
            channel_levels: vec![[0; 4]; cells],
            self_quantizing: vec![false; cells],
            area_of,
            kinds: areas.ids().map(|a| areas.kind(a)).collect(),
            counts,
        })
    }

    /// Quantizes a sample of the cell at `row` (unless the cell sends its
    /// own events) and appends the level changes to `out`.
    pub fn sample(&mut self, row: usize, cell: Address, s: &Sample, out: &mut Vec<TouchEvent>) {
        if self.self_quantizing[row] {
            return;
        }
        let f = s.force_norm();
        let values = [s.proximity_norm(), f[0], f[1], f[2]];
        for (i, v) in values.into_iter().enumerate() {
            if let Some(level) = self.quantizers[row][i].update(v) {
                self.set(row, cell, i, level, out);
            }
        }
    }

    /// Takes an event the cell sent itself; appends it to `out` when it
    /// changes the level known here.
    pub fn event(&mut self, row: usize, cell: Address, e: &TactileEvent, out: &mut Vec<TouchEvent>) {
        self.self_quantizing[row] = true;
        let i = CHANNELS.iter().position(|c| *c == e.channel).expect("every channel is listed");
        if e.level != self.channel_levels[row][i] {
            self.set(row, cell, i, e.level.min(4), out);
        }
    }

    fn set(&mut self, row: usize, cell: Address, channel: usize, level: u8, out: &mut Vec<TouchEvent>) {
        let modality = Modality::of(CHANNELS[channel]);
        let before = self.cell_level(row, modality);
        self.channel_levels[row][channel] = level;
        let after = self.cell_level(row, modality);
        let area = self.area_of[row];
        if before != after {
            let c = &mut self.counts[usize::from(area.0)][modality as usize];
            c[usize::from(before)] -= 1;
            c[usize::from(after)] += 1;
        }
        out.push(TouchEvent { cell, row, area, modality, sensor: channel as u8, level });
    }

    /// A cell's level: its proximity level, or the highest of its forces.
    pub fn cell_level(&self, row: usize, modality: Modality) -> u8 {
        let l = &self.channel_levels[row];
        match modality {
            Modality::Proximity => l[0],
            Modality::Force => l[1].max(l[2]).max(l[3]),
        }
    }

    /// The highest level of any cell in an area.
    pub fn level(&self, area: AreaId, modality: Modality) -> u8 {
        let c = &self.counts[usize::from(area.0)][modality as usize];
        (0..5).rev().find(|&l| c[l] > 0).unwrap_or(0) as u8
    }

    /// How many cells of an area are at `level` or above.
    pub fn cells_at_least(&self, area: AreaId, modality: Modality, level: u8) -> u32 {
        self.counts[usize::from(area.0)][modality as usize][usize::from(level.min(4))..].iter().sum()
    }

    /// Whether some area of the kind has a cell at `level` or above.
    pub fn any(&self, kind: AreaKind, modality: Modality, level: u8) -> bool {
        self.areas(kind).any(|a| self.level(a, modality) >= level)
    }

    /// How many areas of the kind have a cell at `level` or above.
    pub fn count(&self, kind: AreaKind, modality: Modality, level: u8) -> usize {
        self.areas(kind).filter(|a| self.level(*a, modality) >= level).count()
    }

    /// Whether every area of the kind (at least one) has a cell at `level`
    /// or above.
    pub fn every(&self, kind: AreaKind, modality: Modality, level: u8) -> bool {
        let mut areas = self.areas(kind).peekable();
        areas.peek().is_some() && areas.all(|a| self.level(a, modality) >= level)
    }

    /// The highest level anywhere on the skin.
    pub fn highest(&self, modality: Modality) -> u8 {
        (0..self.kinds.len() as u16).map(|a| self.level(AreaId(a), modality)).max().unwrap_or(0)
    }

    fn areas(&self, kind: AreaKind) -> impl Iterator<Item = AreaId> + '_ {
        self.kinds.iter().enumerate().filter(move |(_, k)| **k == kind).map(|(a, _)| AreaId(a as u16))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::areas::{parse_specs, Areas};
    use crate::control::cells::CellIndex;
    use proptest::prelude::*;

    fn setup() -> (CellIndex, Events) {
        let ix = CellIndex::new(&[1, 2, 3, 4].map(Address)).unwrap();
        let specs = parse_specs(
            "[[area]]\nname='l'\nkind='contact'\ncells=[1]\n[[area]]\nname='r'\nkind='contact'\ncells=[2]\n\
             [[area]]\nname='pat'\nkind='pat'\ncells=[3]",
        )
        .unwrap();
        let areas = Areas::resolve(&specs, &ix, |_| None).unwrap();
        (ix, Events::new(&areas, &Levels::default()).unwrap())
    }

    fn sample(proximity: f32, force: [f32; 3]) -> Sample {
        let p = (proximity * 65535.0).round() as u16;
        Sample::new(p, force.map(|f| (f * 4095.0).round() as u16), [0; 3], 0, 0).unwrap()
    }

    #[test]
    fn levels_change_once_and_are_located() {
        let (_, mut ev) = setup();
        let mut out = Vec::new();
        ev.sample(0, Address(1), &sample(0.0, [0.12, 0.0, 0.0]), &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!((out[0].modality, out[0].sensor, out[0].level, out[0].area), (Modality::Force, 1, 2, AreaId(1)));
        ev.sample(0, Address(1), &sample(0.0, [0.12, 0.0, 0.0]), &mut out);
        assert_eq!(out.len(), 1, "no event without a change of level");
        assert_eq!(ev.level(AreaId(1), Modality::Force), 2);
        assert!(ev.any(AreaKind::Contact, Modality::Force, 2));
        assert!(!ev.every(AreaKind::Contact, Modality::Force, 1));
        ev.sample(1, Address(2), &sample(0.85, [0.05, 0.0, 0.0]), &mut out);
        assert!(ev.every(AreaKind::Contact, Modality::Force, 1));
        assert!(!ev.every(AreaKind::Contact, Modality::Proximity, level::CLOSE_CONTACT));
        assert_eq!(ev.level(AreaId(2), Modality::Proximity), 4);
        assert!(!ev.every(AreaKind::Chest, Modality::Force, 0), "no chest area: never every");
        assert_eq!(ev.highest(Modality::Force), 2);
    }

    #[test]
    fn a_cell_that_sends_events_is_not_quantized_twice() {
        let (_, mut ev) = setup();
        let mut out = Vec::new();
        let e = TactileEvent { channel: Channel::Force2, level: 4, value: 2000 };
        ev.event(2, Address(3), &e, &mut out);
        ev.event(2, Address(3), &e, &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(ev.level(AreaId(3), Modality::Force), 4);
        ev.sample(2, Address(3), &sample(0.0, [0.0; 3]), &mut out);
        assert_eq!(out.len(), 1, "samples of a self-quantizing cell make no events");
    }

    #[test]
    fn bad_levels_are_refused() {
        let ix = CellIndex::new(&[Address(1)]).unwrap();
        let areas = Areas::resolve(&[], &ix, |_| None).unwrap();
        let bad = Levels { force: [0.1, 0.05, 0.3, 0.45], ..Levels::default() };
        assert!(Events::new(&areas, &bad).is_err());
    }

    proptest! {
        /// Area counts always equal a recount of the cells' levels.
        #[test]
        fn area_counts_match_cell_levels(steps in proptest::collection::vec((0usize..4, 0.0f32..1.0, 0.0f32..0.6), 1..200)) {
            let (ix, mut ev) = setup();
            let mut out = Vec::new();
            for (row, p, f) in steps {
                ev.sample(row, ix.address(row), &sample(p, [f, f / 2.0, 0.0]), &mut out);
                for m in [Modality::Force, Modality::Proximity] {
                    for a in 0..4u16 {
                        let max = (0..4).filter(|r| ev.area_of[*r] == AreaId(a)).map(|r| ev.cell_level(r, m)).max().unwrap_or(0);
                        prop_assert_eq!(ev.level(AreaId(a), m), max);
                    }
                }
            }
        }
    }
}
