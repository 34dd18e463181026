//! A firmware update of a simulated skin through the real protocol code:
//! the host's [`Distributor`] sends through the interface ports as
//! datagrams, every cell runs its [`skin_protocol::update::Updater`] in its
//! network stack, and the sensor traffic goes on at its rate meanwhile, so
//! update time and sensor latency during an update can be measured.

use skin_protocol::address::Address;
use skin_protocol::frame::Frame;
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{Message, UpdateState};
use skin_protocol::update::{Distributor, Outcome, Outgoing};

use super::host::Host;
use super::ledger::Quantiles;
use super::simulator::Network;
use super::NetworkError;

/// The host sends what it has every this often.
const TICK_NS: u64 = 1_000_000;

/// The sensor traffic of one phase of an update.
#[derive(Clone, Copy, Debug, Default)]
pub struct Phase {
    /// Virtual time the phase took, s.
    pub time_s: f64,
    /// Sensor frames, made to host, us.
    pub latency_us: Quantiles,
    /// Sensor frames dropped.
    pub sensor_dropped: u64,
}

/// What an update of a simulated skin did.
#[derive(Clone, Debug)]
pub struct UpdateRun {
    /// Every cell's outcome, by address.
    pub outcomes: Vec<(Address, Outcome)>,
    /// The transfer: from the first frame sent until every cell holds a
    /// verified image (or refused it), sensor traffic going on.
    pub transfer: Phase,
    /// Boot and confirm: the cells restart into the new image (a restart
    /// is an outage of the cell and a re-attachment of its subtree).
    pub boot: Phase,
    /// Frames the host sent into the busiest interface port.
    pub frames_per_port: u64,
    /// Chunks in the image.
    pub chunks: usize,
}

/// The sensor traffic since the last `measure_from`, over `time_ns`.
fn phase(net: &Network, time_ns: u64) -> Phase {
    let m = net.measurements();
    Phase {
        time_s: time_ns as f64 * 1e-9,
        latency_us: m.latency.quantiles(),
        sensor_dropped: m.ledger.sensor_dropped - m.sensor_dropped_before,
    }
}

/// Organizes the skin with the built-in `host` (IDs for every cell), or
/// fails after `timeout_ns` of virtual time.
pub fn organize(net: &mut Network, host: &mut Host, timeout_ns: u64) -> Result<(), NetworkError> {
    while net.now_ns() < timeout_ns {
        pump(net, host, net.now_ns() + TICK_NS, &mut |_, _, _| {})?;
        if (0..net.cells()).all(|i| net.cell(i).is_some_and(|c| c.id().is_cell())) {
            return Ok(());
        }
    }
    Err(NetworkError::Flag(format!("the skin did not organize within {} s", timeout_ns as f64 / 1e9)))
}

/// Runs the network to `until_ns`, the built-in host answering ID requests
/// and `heard` taking every frame from a cell with the interface port it
/// came up.
fn pump(
    net: &mut Network,
    host: &mut Host,
    until_ns: u64,
    heard: &mut dyn FnMut(Address, u8, Message),
) -> Result<(), NetworkError> {
    while let Some(d) = net.step(until_ns) {
        if let Ok(datagram) = Datagram::parse(&d.bytes) {
            let port = datagram.header().interface;
            for (frame, message) in
                datagram.frames().filter_map(|f| f.ok()).filter_map(|f| Some((f, f.message().ok()?)))
            {
                heard(frame.src(), port, message);
            }
        }
        for reply in host.receive(&d.bytes) {
            net.inject(&reply)?;
        }
        net.recycle(d);
    }
    Ok(())
}

/// Updates every organized cell of `net` to `image`, sending at most
/// `per_ms` frames into each interface port per millisecond, for at most
/// `limit_ns` of virtual time. Sensor latency is measured from the start.
pub fn update(
    net: &mut Network,
    host: &mut Host,
    image: &[u8],
    per_ms: usize,
    limit_ns: u64,
) -> Result<UpdateRun, NetworkError> {
    let cells: Vec<Address> = (0..net.cells()).filter_map(|i| net.cell(i).map(|c| c.id())).collect();
    let mut distributor =
        Distributor::new(image, cells).map_err(|e| NetworkError::Flag(format!("the image cannot be sent: {e}")))?;
    net.measure_from();
    let start_ns = net.now_ns();
    let mut transfer = None;
    let mut seq = vec![0u32; net.interfaces()];
    let mut sent = vec![0u64; net.interfaces()];
    while net.now_ns() - start_ns < limit_ns && !distributor.finished() {
        let received = distributor
            .outcomes()
            .all(|(_, o)| o.is_final() || matches!(o, Outcome::Unfinished(UpdateState::Ready | UpdateState::Trial)));
        if received && transfer.is_none() {
            transfer = Some(phase(net, net.now_ns() - start_ns));
            net.measure_from();
        }
        let now_us = net.now_ns() / 1000;
        let outgoing: Vec<Outgoing> = std::iter::from_fn(|| distributor.next(now_us)).take(per_ms).collect();
        for (k, (seq, sent)) in seq.iter_mut().zip(&mut sent).enumerate() {
            let frames: Vec<Frame> = outgoing
                .iter()
                .filter(|o| o.via.includes(k as u8))
                .map(|o| Frame::new(Address::HOST, o.to, &o.message))
                .collect();
            *sent += frames.len() as u64;
            for batch in frames.chunks(MAX_FRAMES) {
                let header = DatagramHeader { interface: k as u8, seq: *seq, timestamp_us: now_us };
                *seq = seq.wrapping_add(1);
                let mut buf = [0u8; MAX_DATAGRAM];
                let len = interface::encode(header, batch, &mut buf).expect("1..=72 frames fit a datagram");
                net.inject(&buf[..len])?;
            }
        }
        pump(net, host, net.now_ns() + TICK_NS, &mut |src, port, message| {
            if let Message::UpdateReport(r) = message {
                distributor.handle(src, port, r);
            }
        })?;
    }
    let total_ns = net.now_ns() - start_ns;
    let (transfer, boot) = match transfer {
        Some(t) => (t, phase(net, total_ns - (t.time_s * 1e9) as u64)),
        None => (phase(net, total_ns), Phase::default()),
    };
    Ok(UpdateRun {
        outcomes: distributor.outcomes().collect(),
        transfer,
        boot,
        frames_per_port: sent.into_iter().max().unwrap_or(0),
        chunks: distributor.chunk_count(),
    })
}
