//! Cost of one tactile control period: the samples that arrived (events),
//! equation (14) and the key-pose trajectory, with the grasp running.
//!
//! Skins of 74 cells x 14 DoF (the paper's HRP-2) and 10,000 cells x 60 DoF,
//! with 1 %, 10 % and 100 % of the cells touched. Cells send samples on
//! change (event traffic), so a quiet cell sends nothing; one case lets
//! every cell send every period (clock traffic) to show what the host pays
//! when cells do not filter. The budget is the 4 ms period of a 250 Hz
//! skin; the table printed first gives the mean step time against it and
//! the number of cells that reacted (the work done). Then criterion times
//! each case. `cargo bench -p skin-host --bench control`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_host::control::areas::{parse_specs, Areas};
use skin_host::control::cells::CellIndex;
use skin_host::control::controller::{Controller, Input};
use skin_host::control::dense::DenseMap;
use skin_host::control::grasp::State;
use skin_host::control::params::Params;
use skin_host::control::teach::KeyPoses;
use skin_protocol::{Address, Sample};

const PERIOD_S: f64 = 0.004;

/// Traffic of a case: who sends a sample each period.
#[derive(Clone, Copy, PartialEq)]
enum Traffic {
    /// Touched cells only.
    Event,
    /// Every cell.
    Clock,
}

struct Case {
    cells: usize,
    dofs: usize,
    touched_percent: usize,
    traffic: Traffic,
}

impl Case {
    fn name(&self) -> String {
        let t = if self.traffic == Traffic::Clock { ", clock traffic" } else { "" };
        format!("{} cells x {} DoF, {} % touched{t}", self.cells, self.dofs, self.touched_percent)
    }
}

const CASES: [Case; 5] = [
    Case { cells: 74, dofs: 14, touched_percent: 100, traffic: Traffic::Event },
    Case { cells: 10_000, dofs: 60, touched_percent: 1, traffic: Traffic::Event },
    Case { cells: 10_000, dofs: 60, touched_percent: 10, traffic: Traffic::Event },
    Case { cells: 10_000, dofs: 60, touched_percent: 100, traffic: Traffic::Event },
    Case { cells: 10_000, dofs: 60, touched_percent: 1, traffic: Traffic::Clock },
];

/// A controller opening the arms (trajectory and proximity reactions on
/// every area), and the samples of one period.
struct Rig {
    controller: Controller,
    map: DenseMap,
    pose: Vec<f64>,
    touched: Vec<(Address, Sample)>,
    quiet: Vec<(Address, Sample)>,
    traffic: Traffic,
    time_s: f64,
}

impl Rig {
    fn new(case: &Case) -> Rig {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let (n, d) = (case.cells, case.dofs);
        let cells: Vec<Address> = (1..=n as u16).map(Address).collect();
        let mut tiles = Vec::new();
        let mut poses = KeyPoses::new();
        for (k, name) in ["home", "open", "closed", "pulled"].into_iter().enumerate() {
            let pose: Vec<f64> = (0..d).map(|_| rng.random_range(-1.0..1.0)).collect();
            poses.record(name, &pose).unwrap();
            let weights = (0..n * d).map(|_| rng.random_range(-1.0f32..1.0)).collect();
            tiles.push((if k == 0 { vec![0.0; d] } else { pose }, weights));
        }
        let map = DenseMap::new(n, d, tiles);
        let q = n / 8;
        let specs = parse_specs(&format!(
            "[[area]]\nname='pat'\nkind='pat'\ncells=[1]\n\
             [[area]]\nname='left'\nkind='contact'\ncells={:?}\n\
             [[area]]\nname='right'\nkind='contact'\ncells={:?}\n\
             [[area]]\nname='chest'\nkind='chest'\ncells={:?}",
            (2..2 + q).collect::<Vec<_>>(),
            (2 + q..2 + 2 * q).collect::<Vec<_>>(),
            (2 + 2 * q..2 + 3 * q).collect::<Vec<_>>(),
        ))
        .unwrap();
        let index = CellIndex::new(&cells).unwrap();
        let areas = Areas::resolve(&specs, &index, |_| None).unwrap();
        // Progress is not judged in a benchmark: the pose stands still.
        let mut params = Params::default();
        params.timing.stall_window_s = 1e9;
        let mut controller = Controller::new(index, areas, d, params).unwrap();
        controller.start_grasp(poses).unwrap();
        let pose = vec![0.0; d];
        // A pat launches the grasp.
        let sample =
            |p: f64, f: f64| Sample::new((p * 65535.0) as u16, [(f * 4095.0) as u16, 0, 0], [0; 3], 0, 0).unwrap();
        controller.receive(Address(1), &Input::Sample(sample(0.0, 0.2)));
        controller.step(&map, &pose, 0.0).unwrap();
        controller.receive(Address(1), &Input::Sample(sample(0.0, 0.0)));
        controller.step(&map, &pose, PERIOD_S).unwrap();
        assert_eq!(controller.state(), Some(State::Open));
        // Touched cells see something at medium proximity (no events once
        // there), spread over the skin but not on the pat area.
        let stride = 100 / case.touched_percent;
        let touched = (2..=n as u16).step_by(stride).map(|c| (Address(c), sample(0.05, 0.0))).collect();
        let quiet = (2..=n as u16)
            .filter(|c| !((c - 2) as usize).is_multiple_of(stride))
            .map(|c| (Address(c), sample(0.0, 0.0)))
            .collect();
        Rig { controller, map, pose, touched, quiet, traffic: case.traffic, time_s: PERIOD_S }
    }

    /// One control period.
    fn step(&mut self) -> usize {
        self.time_s += PERIOD_S;
        for (cell, s) in &self.touched {
            self.controller.receive(*cell, &Input::Sample(*s));
        }
        if self.traffic == Traffic::Clock {
            for (cell, s) in &self.quiet {
                self.controller.receive(*cell, &Input::Sample(*s));
            }
        }
        black_box(self.controller.step(&self.map, &self.pose, self.time_s).unwrap());
        self.controller.reactions().reacting()
    }
}

fn control_step(c: &mut Criterion) {
    println!("{:<50} | {:>12} {:>14} | {:>9}", "case", "mean us/step", "% of 4 ms", "reacting");
    for case in &CASES {
        let mut rig = Rig::new(case);
        let steps = 2000;
        let start = Instant::now();
        let mut reacting = 0;
        for _ in 0..steps {
            reacting = rig.step();
        }
        let us = start.elapsed().as_secs_f64() * 1e6 / f64::from(steps);
        assert_eq!(rig.controller.state(), Some(State::Open));
        println!("{:<50} | {:>12.1} {:>13.2}% | {:>9}", case.name(), us, us / (PERIOD_S * 1e6) * 100.0, reacting);
    }
    let mut group = c.benchmark_group("control step");
    for case in &CASES {
        let mut rig = Rig::new(case);
        group.bench_function(case.name(), |b| b.iter(|| rig.step()));
    }
    group.finish();
}

criterion_group!(benches, control_step);
criterion_main!(benches);
