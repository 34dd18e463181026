//! The QEMU network test: a hexagonal patch of firmware cells organizes
//! itself, takes configuration from the host, delivers injected samples,
//! survives the death of a cell and takes it back with its old ID.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::io::Write;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use skin_firmware::board::QEMU_CONFIG;
use skin_firmware::stimulus;
use skin_protocol::event::Quantizer;
use skin_protocol::message::{Channel, Neighbour, Port, Setting, TrafficMode};
use skin_protocol::{Address, Sample};

use super::cells::{gateway_socket, plan, stimulus_socket, CellCommand, Cells, CpuUse, StackUse};
use super::flash::{provision, Programs};
use super::gateway::{Gateway, GatewayStats};
use super::hex::{End, Wiring};
use super::host::Host;
use super::{Context, QemuError};

/// How to run the test.
#[derive(Clone, Debug)]
pub struct NetOptions {
    /// Cells in the patch (2 to 40).
    pub cells: usize,
    /// The `cell-qemu` firmware (`boot-qemu`, its bootloader, beside it).
    pub elf: PathBuf,
    /// Keep the run directory (sockets, stores, logs) after a success.
    pub keep: bool,
}

/// What the test saw, with the wall time of each stage.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NetReport {
    /// Cells in the patch.
    pub cells: usize,
    /// Links between them.
    pub links: usize,
    /// The ID of each cell, in patch order.
    pub ids: Vec<u16>,
    /// The cell that was killed and restarted.
    pub killed: usize,
    /// From the start of QEMU to unique IDs and a neighbour table equal to the wiring.
    pub organize_s: f64,
    /// Until every cell acknowledged the configuration.
    pub configure_s: f64,
    /// From the first press until every cell's sample and event arrived exactly.
    pub samples_s: f64,
    /// From the kill until the others reported the new wiring with their old IDs.
    pub reattach_s: f64,
    /// From the restart until the killed cell was back with its ID, offsets and settings.
    pub rejoin_s: f64,
    /// Samples and events the host received.
    pub samples: usize,
    /// Tactile events the host received.
    pub events: usize,
    /// The interface port's counts.
    pub gateway: GatewayStats,
    /// The deepest stack of any cell over the run, and the reserve.
    pub stack: Option<StackUse>,
    /// Wall time of the run, from the start of the cells.
    pub wall_s: f64,
    /// Processor time the QEMU cells took over the run.
    pub cpu: CpuUse,
    /// The run directory, when kept.
    pub dir: Option<PathBuf>,
}

/// The baseline every cell sees at boot and calibrates its offsets on.
pub(crate) fn baseline() -> Sample {
    Sample::saturating(1_000, [300, 310, 320], [0, 0, 256], 800, 0)
}

/// A distinct stimulus for cell `k` in round `round`: baseline plus a press.
fn stimulus_for(k: usize, round: usize) -> Sample {
    let (k16, r16) = (k as u16, round as u16);
    let b = baseline();
    Sample::saturating(
        b.proximity() + 3_000 + 400 * k16 + 1_000 * r16,
        [b.force()[0] + 200 + 30 * k16 + 60 * r16, b.force()[1] + 20 * k16, b.force()[2] + 5],
        [k as i16 + round as i16, -(k as i16), 256 - k as i16],
        800 + 10 * k as i16 + round as i16,
        0,
    )
}

/// What the cell sends for a raw sample: offsets (the baseline of the
/// calibrated channels) removed; with the filter cut-off far above the
/// sampling rate the low-pass passes a step at once.
fn expected(raw: &Sample) -> (u16, [u16; 3], [i16; 3], i16) {
    let b = baseline();
    let f = raw.force();
    let bf = b.force();
    (raw.proximity() - b.proximity(), [f[0] - bf[0], f[1] - bf[1], f[2] - bf[2]], raw.accel(), raw.temperature())
}

fn fields(s: &Sample) -> (u16, [u16; 3], [i16; 3], i16) {
    (s.proximity(), s.force(), s.accel(), s.temperature())
}

/// The harness: cells, host, interface port and stimulus channels.
pub(crate) struct World {
    pub(crate) cells: Cells,
    pub(crate) host: Host,
    gateway: Gateway,
    listeners: Vec<UnixListener>,
    streams: Vec<Option<UnixStream>>,
    /// What each cell's sensors read; `None`: nothing yet, no samples.
    stimulus: Vec<Option<Sample>>,
    last_stimulus: Instant,
    /// The programs the cells run.
    pub(crate) programs: Programs,
    /// Each cell's flash file.
    pub(crate) flashes: Vec<PathBuf>,
}

impl World {
    /// A patch wired as `wiring` with its interface port at `interface`, in
    /// `dir`, not started: each cell's flash file holds version 1 of the
    /// `cell-qemu` program `elf` in slot A.
    pub(crate) fn new(elf: &Path, wiring: &Wiring, interface: End, dir: &Path) -> Result<World, QemuError> {
        let n = wiring.cells();
        let mut host = Host::bind()?;
        let listener = |p: PathBuf| {
            let l = UnixListener::bind(&p).context(|| format!("listening on {}", p.display()))?;
            l.set_nonblocking(true).context(|| "nonblocking listener".into())?;
            Ok::<_, QemuError>(l)
        };
        let gateway = Gateway::start(0, QEMU_CONFIG, listener(gateway_socket(dir))?, host.addr()?)?;
        host.set_gateway(gateway.udp_addr());
        let listeners = (0..n).map(|i| listener(stimulus_socket(dir, i))).collect::<Result<Vec<_>, _>>()?;
        let programs = Programs::load(elf)?;
        let factory = programs.genuine(1);
        let (mut commands, mut flashes) = (Vec::new(), Vec::new());
        for (i, uarts) in plan(wiring, interface, dir).into_iter().enumerate() {
            let flash = dir.join(format!("cell{i}.flash"));
            provision(&flash, &factory)?;
            commands.push(CellCommand::new(&programs.bootloader, &flash, uarts));
            flashes.push(flash);
        }
        Ok(World {
            cells: Cells::new(dir, commands),
            host,
            gateway,
            listeners,
            streams: (0..n).map(|_| None).collect(),
            stimulus: vec![None; n],
            last_stimulus: Instant::now(),
            programs,
            flashes,
        })
    }

    /// Serves the stimulus channels and the host for `wait`.
    pub(crate) fn pump(&mut self, wait: Duration) -> Result<(), QemuError> {
        self.cells.check_alive()?;
        let resend = self.last_stimulus.elapsed() > Duration::from_millis(100);
        for (i, listener) in self.listeners.iter().enumerate() {
            let mut fresh = false;
            if let Ok((stream, _)) = listener.accept() {
                self.streams[i] = Some(stream);
                fresh = true;
            }
            if let (Some(stream), Some(raw), true) = (&mut self.streams[i], self.stimulus[i], fresh || resend) {
                if stream.write_all(&stimulus::encode(&raw)).is_err() {
                    self.streams[i] = None;
                }
            }
        }
        if resend {
            self.last_stimulus = Instant::now();
        }
        self.host.pump(wait)
    }

    /// Writes `settings` (tag, setting) to every cell of `ids` until each
    /// acknowledged each; returns the time it took.
    pub(crate) fn configure(&mut self, ids: &[Option<Address>], settings: &[(u8, Setting)]) -> Result<f64, QemuError> {
        let mut last_write = Instant::now() - Duration::from_secs(1);
        let ((), configure_s) = self.wait("configuration", Duration::from_secs(15), |w| {
            let missing: Vec<_> = ids
                .iter()
                .flatten()
                .flat_map(|id| settings.iter().map(move |(tag, _)| (*id, *tag)))
                .filter(|key| w.host.acks.get(key) != Some(&true))
                .collect();
            if missing.is_empty() {
                return Ok(());
            }
            // Writes are idempotent; repeat them for cells that lost one.
            if last_write.elapsed() > Duration::from_secs(1) {
                last_write = Instant::now();
                for (tag, setting) in settings {
                    w.host.broadcast(*tag, *setting).map_err(|e| e.to_string())?;
                }
            }
            Err(format!("acknowledgements missing: {missing:?}"))
        })?;
        Ok(configure_s)
    }

    pub(crate) fn set_stimulus(&mut self, i: usize, raw: Sample) {
        self.stimulus[i] = Some(raw);
        if let Some(stream) = &mut self.streams[i] {
            if stream.write_all(&stimulus::encode(&raw)).is_err() {
                self.streams[i] = None;
            }
        }
    }

    /// Gives `cells` their stimulus one after the other, 20 ms apart, as a
    /// hand moves over the skin: all at once, their first samples would be
    /// a burst that the 16-frame queues near the interface port drop (the
    /// protocol repeats no samples).
    fn stimulate(&mut self, cells: &[usize], stimulus: impl Fn(usize) -> Sample) -> Result<(), QemuError> {
        for &i in cells {
            self.set_stimulus(i, stimulus(i));
            self.pump(Duration::from_millis(20))?;
        }
        Ok(())
    }

    /// Presses `cells` one after the other with their stimulus of `round`.
    fn press(&mut self, cells: &[usize], round: usize) -> Result<(), QemuError> {
        self.stimulate(cells, |i| stimulus_for(i, round))
    }

    /// Pumps until `done` gives a value or `limit` passes.
    pub(crate) fn wait<T>(
        &mut self,
        stage: &'static str,
        limit: Duration,
        mut done: impl FnMut(&mut World) -> Result<T, String>,
    ) -> Result<(T, f64), QemuError> {
        let start = Instant::now();
        loop {
            self.pump(Duration::from_millis(20))?;
            match done(self) {
                Ok(v) => return Ok((v, start.elapsed().as_secs_f64())),
                Err(detail) if start.elapsed() > limit => {
                    return Err(QemuError::Timeout { stage, seconds: limit.as_secs_f64(), detail });
                }
                Err(_) => {}
            }
        }
    }
}

/// The cell IDs implied by the neighbour reports, walking the wiring from
/// the interface port; an error says where reports and wiring disagree.
/// Checks uniqueness and that every reachable cell's whole table is right.
fn map_ids(
    wiring: &Wiring,
    interface: End,
    reports: &BTreeMap<Address, skin_protocol::message::NeighbourReport>,
) -> Result<Vec<Option<Address>>, String> {
    let iface = Neighbour { id: Address::interface(0).ok_or("no interface address")?, port: Port::P0 };
    let (g, gp) = interface;
    let mut at_interface = reports.iter().filter(|(_, r)| r.neighbours[gp.index()] == Some(iface));
    let first = at_interface.next().ok_or("no cell reports the interface port yet")?;
    let mut ids: Vec<Option<Address>> = vec![None; wiring.cells()];
    ids[g] = Some(*first.0);
    let mut used = BTreeSet::from([*first.0]);
    let mut queue = VecDeque::from([g]);
    while let Some(i) = queue.pop_front() {
        let id = ids[i].ok_or("unmapped cell in queue")?;
        if !id.is_cell() {
            return Err(format!("cell {i} has address {id}"));
        }
        let report = reports.get(&id).ok_or_else(|| format!("no report from cell {i} ({id})"))?;
        for p in Port::ALL {
            let got = report.neighbours[p.index()];
            let wired = wiring.peer((i, p));
            match (wired, got) {
                (None, None) => {}
                (None, Some(n)) if (i, p) == interface && n == iface => {}
                (Some((j, q)), Some(n)) if n.port == q => match ids[j] {
                    Some(known) if known == n.id => {}
                    Some(known) => return Err(format!("cell {j} is {known} but {id} sees {} on port {p:?}", n.id)),
                    None => {
                        if !used.insert(n.id) {
                            return Err(format!("ID {} seen on two cells", n.id));
                        }
                        ids[j] = Some(n.id);
                        queue.push_back(j);
                    }
                },
                (w, g) => return Err(format!("cell {i} ({id}) port {p:?}: wired to {w:?}, reports {g:?}")),
            }
        }
    }
    Ok(ids)
}

/// Every cell of `cells` mapped, to the IDs in `expect` where given.
pub(crate) fn organized(
    w: &World,
    wiring: &Wiring,
    interface: End,
    cells: &[usize],
    expect: Option<&[Option<Address>]>,
) -> Result<Vec<Option<Address>>, String> {
    let ids = map_ids(wiring, interface, &w.host.reports)?;
    for &i in cells {
        match (ids[i], expect.map(|e| e[i])) {
            (None, _) => return Err(format!("cell {i} not reached")),
            (Some(a), Some(Some(b))) if a != b => return Err(format!("cell {i} changed ID from {b} to {a}")),
            _ => {}
        }
    }
    Ok(ids)
}

/// Every cell in `cells` has delivered its stimulus exactly, after `since`.
fn delivered(w: &World, ids: &[Option<Address>], cells: &[usize], since: Instant) -> Result<(), String> {
    for &i in cells {
        let id = ids[i].ok_or("unmapped")?;
        let want = expected(&w.stimulus[i].ok_or("no stimulus")?);
        let ok = w.host.samples.iter().any(|a| a.src == id && a.at >= since && fields(&a.value) == want);
        if !ok {
            let last = w.host.samples.iter().rev().find(|a| a.src == id).map(|a| fields(&a.value));
            return Err(format!("cell {i} ({id}): want {want:?}, last got {last:?}"));
        }
    }
    Ok(())
}

/// The non-interface cell with the most links whose death leaves the
/// others connected to the interface: the one whose loss moves most routes.
fn victim(wiring: &Wiring, interface: End) -> Option<usize> {
    let degree = |i: usize| Port::ALL.iter().filter(|p| wiring.peer((i, **p)).is_some()).count();
    (0..wiring.cells())
        .filter(|&v| v != interface.0 && wiring.without(v).reachable(interface.0).len() == wiring.cells() - 1)
        .max_by_key(|&v| (degree(v), std::cmp::Reverse(v)))
}

/// Runs the whole test; `progress` hears each stage as it starts.
pub fn run(opts: &NetOptions, progress: &mut dyn FnMut(&str)) -> Result<NetReport, QemuError> {
    let n = opts.cells;
    if !(2..=40).contains(&n) {
        return Err(QemuError::BadSize(n));
    }
    if !opts.elf.is_file() {
        return Err(QemuError::MissingElf(opts.elf.clone()));
    }
    let dir = run_dir()?;
    let result = run_in(opts, &dir, progress);
    match &result {
        Ok(_) if !opts.keep => {
            let _ = std::fs::remove_dir_all(&dir);
        }
        Ok(_) => {}
        Err(_) => {
            tracing::error!(dir = %dir.display(), "run failed; sockets, stores and cell logs are kept in the run directory")
        }
    }
    result.map(|mut r| {
        r.dir = opts.keep.then_some(dir);
        r
    })
}

/// A fresh run directory for sockets, flash files and logs.
pub(crate) fn run_dir() -> Result<PathBuf, QemuError> {
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!("skin-qemu-net-{}-{stamp}", std::process::id()));
    std::fs::create_dir_all(&dir).context(|| format!("creating {}", dir.display()))?;
    Ok(dir)
}

fn run_in(opts: &NetOptions, dir: &Path, progress: &mut dyn FnMut(&str)) -> Result<NetReport, QemuError> {
    let n = opts.cells;
    let wiring = Wiring::patch(n);
    let interface = *wiring.free_ports().first().ok_or(QemuError::BadSize(n))?;
    let killed = victim(&wiring, interface).ok_or(QemuError::BadSize(n))?;
    let everyone: Vec<usize> = (0..n).collect();
    let survivors: Vec<usize> = everyone.iter().copied().filter(|i| *i != killed).collect();

    let mut w = World::new(&opts.elf, &wiring, interface, dir)?;

    progress(&format!("starting {n} QEMU cells, interface on cell {} port {:?}", interface.0, interface.1));
    let started = Instant::now();
    for i in 0..n {
        w.cells.start(i)?;
    }
    let limit = Duration::from_secs(20 + n as u64);
    let (ids, organize_s) =
        w.wait("self-organization", limit, |w| organized(w, &wiring, interface, &everyone, None))?;

    progress("configuring: event traffic, filter cut-off 1 kHz");
    let settings = [(1u8, Setting::Traffic(TrafficMode::Event)), (2, Setting::FilterCutoffHz(1_000.0))];
    let configure_s = w.configure(&ids, &settings)?;

    // Sensors come alive only now, so the organization above ran on a quiet
    // network; each cell calibrates its offsets on the baseline, then sends
    // its first sample: all calibrated channels zero.
    progress("baseline stimulus: cells calibrate their offsets");
    let since = Instant::now();
    w.stimulate(&everyone, |_| baseline())?;
    let ((), _) = w.wait("calibration", Duration::from_secs(15), |w| delivered(w, &ids, &everyone, since))?;

    progress("injecting a distinct press on every cell");
    let since = Instant::now();
    w.press(&everyone, 1)?;
    w.wait("sample and event delivery", Duration::from_secs(15), |w| {
        delivered(w, &ids, &everyone, since)?;
        events(w, &ids)
    })?;
    let samples_s = since.elapsed().as_secs_f64();

    progress(&format!("killing cell {killed}"));
    w.cells.kill(killed);
    let without = wiring.without(killed);
    let ((), reattach_s) = w.wait("re-attachment", Duration::from_secs(20), |w| {
        organized(w, &without, interface, &survivors, Some(&ids)).map(drop)
    })?;
    // Samples sent toward the dead cell before its links timed out are lost
    // (event traffic repeats none), so the survivors are pressed after.
    let since = Instant::now();
    w.press(&survivors, 2)?;
    w.wait("delivery after re-attachment", Duration::from_secs(15), |w| delivered(w, &ids, &survivors, since))?;

    progress(&format!("restarting cell {killed} with its store"));
    // Its last report from before the kill must not count: it has to report anew.
    if let Some(id) = ids[killed] {
        w.host.reports.remove(&id);
    }
    let restart = Instant::now();
    w.set_stimulus(killed, stimulus_for(killed, 3));
    w.cells.start(killed)?;
    let ((), _) = w.wait("rejoin", Duration::from_secs(20), |w| {
        organized(w, &wiring, interface, &everyone, Some(&ids))?;
        delivered(w, &ids, &[killed], restart)
    })?;
    let rejoin_s = restart.elapsed().as_secs_f64();
    // Still in event traffic after the restart: a still cell stays quiet.
    let quiet_from = Instant::now();
    w.wait("quiet check", Duration::from_secs(2), |_| {
        (quiet_from.elapsed() > Duration::from_secs(1)).then_some(()).ok_or_else(String::new)
    })?;
    let id = ids[killed].ok_or(QemuError::BadSize(n))?;
    let chatter = w.host.samples.iter().filter(|a| a.src == id && a.at >= quiet_from).count();
    if chatter > 2 {
        return Err(QemuError::Timeout {
            stage: "settings after restart",
            seconds: 1.0,
            detail: format!(
                "the restarted cell sent {chatter} samples of a still stimulus: its event-traffic setting was lost"
            ),
        });
    }

    let World { cells, host, gateway, .. } = w;
    let stack = (0..n).filter_map(|i| cells.stack_use(i)).max_by_key(|s| s.peak_bytes);
    let cpu = cells.stop();
    Ok(NetReport {
        cells: n,
        links: wiring.links().len(),
        ids: ids.iter().map(|a| a.map_or(0, |a| a.0)).collect(),
        killed,
        organize_s,
        configure_s,
        samples_s,
        reattach_s,
        rejoin_s,
        samples: host.samples.len(),
        events: host.events.len(),
        gateway: gateway.stop(),
        stack,
        wall_s: started.elapsed().as_secs_f64(),
        cpu,
        dir: None,
    })
}

/// The last force-0 event of every cell is the Table 3 level of its press.
fn events(w: &World, ids: &[Option<Address>]) -> Result<(), String> {
    for (i, id) in ids.iter().enumerate() {
        let id = id.ok_or("unmapped")?;
        let raw = w.stimulus[i].ok_or("no stimulus")?;
        let press = Sample::saturating(0, expected(&raw).1, [0; 3], 0, 0);
        let mut q = Quantizer::force();
        q.update(press.force_norm()[0]);
        let last = w.host.events.iter().rev().find(|a| a.src == id && a.value.channel == Channel::Force0);
        if last.map(|a| a.value.level) != Some(q.level()) {
            return Err(format!("cell {i} ({id}): want force level {}, last event {last:?}", q.level()));
        }
    }
    Ok(())
}
