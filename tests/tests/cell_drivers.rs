//! The three drivers of a skin cell (the firmware's node, the simulator's
//! cell, the load generator's cell) run one script of host writes, raw
//! samples and reboots, and send the host the same frames, byte for byte:
//! they all run the protocol crate's cell application, and nothing of a
//! cell's behaviour may grow back into one of them alone.

use skin_firmware::node::Node;
use skin_firmware::store::{RamFlash, Store};
use skin_host::interface::loadgen::AppCell;
use skin_protocol::app::{Delivered, MemoryStore};
use skin_protocol::cell::Received;
use skin_protocol::message::{ConfigWrite, IdAssign, Port, Setting, TrafficMode};
use skin_protocol::organize::{Config, FromCell, Sink};
use skin_protocol::processing::CALIBRATION_SAMPLES;
use skin_protocol::{Address, Frame, Kind, Message, Sample};
use skin_sim::network::{Network, NetworkConfig, SimCell, Stamper};

const ID: Address = Address(1);

#[derive(Clone, Copy, Debug)]
enum Step {
    /// The host writes a setting to the cell, with a tag.
    Write(u8, Setting),
    /// The cell takes this raw sample this many times.
    Samples(u32, Sample),
    /// Power off and on.
    Reboot,
}

fn still() -> Sample {
    Sample::new(500, [100, 100, 100], [0, 0, 256], 800, 0).unwrap()
}

fn touched() -> Sample {
    Sample::new(60_000, [3_000, 2_500, 2_000], [10, -20, 250], 805, 0).unwrap()
}

fn script() -> Vec<Step> {
    use Step::*;
    vec![
        Samples(4, still()),
        Write(1, Setting::Traffic(TrafficMode::Event)),
        Samples(4, still()),
        Write(2, Setting::Delta { channel: 0, counts: 50 }),
        Samples(3, touched()),
        Samples(3, still()),
        Write(3, Setting::SampleRateHz(-1.0)),
        Reboot,
        Samples(3, touched()),
        Samples(3, still()),
        Write(4, Setting::Traffic(TrafficMode::Clock)),
        Write(5, Setting::Calibrate),
        Samples(CALIBRATION_SAMPLES + 3, still()),
        Reboot,
        Samples(3, still()),
    ]
}

/// The store every cell ships with: the network's settings, factory offsets.
fn factory() -> MemoryStore {
    let config = NetworkConfig { traffic: TrafficMode::Clock, ..NetworkConfig::default() };
    Network::factory_store(&config).unwrap()
}

/// A cell on port 0 of an interface port, on a virtual clock.
trait Wired {
    fn poll_at(&self) -> u64;
    fn poll(&mut self, now_us: u64);
    fn receive(&mut self, frame: &Frame, now_us: u64);
    fn transmit(&mut self) -> Option<Frame>;
    fn sample(&mut self, raw: &Sample);
    fn reboot(&mut self, now_us: u64);
}

impl Wired for Node<RamFlash<1024, 2>> {
    fn poll_at(&self) -> u64 {
        Node::poll_at(self)
    }
    fn poll(&mut self, now_us: u64) {
        Node::poll(self, now_us);
    }
    fn receive(&mut self, frame: &Frame, now_us: u64) {
        for b in frame.as_bytes() {
            Node::receive(self, Port::P0, *b, now_us);
        }
    }
    fn transmit(&mut self) -> Option<Frame> {
        Node::transmit(self, Port::P0)
    }
    fn sample(&mut self, raw: &Sample) {
        Node::sample(self, raw);
    }
    fn reboot(&mut self, now_us: u64) {
        let store = std::mem::replace(self, firmware_node(now_us)).into_store();
        *self = Node::new(Config::default(), store, now_us);
    }
}

fn firmware_node(now_us: u64) -> Node<RamFlash<1024, 2>> {
    let mut store = Store::<_>::open(RamFlash::default(), 0, 2048).unwrap();
    let factory = factory();
    store.set_offsets(factory.offsets.unwrap()).unwrap();
    for s in factory.settings.iter().flatten() {
        store.set_setting(*s).unwrap();
    }
    Node::new(Config::default(), store, now_us)
}

/// The simulator's cell, driven as the network drives it.
struct Simulated(SimCell, u64);

impl Wired for Simulated {
    fn poll_at(&self) -> u64 {
        self.0.app().unwrap().poll_at()
    }
    fn poll(&mut self, now_us: u64) {
        self.0.app_mut().unwrap().poll(now_us, &mut Stamper::new(now_us * 1000, 0));
    }
    fn receive(&mut self, frame: &Frame, now_us: u64) {
        let stamp = &mut Stamper::new(now_us * 1000, 0);
        let app = self.0.app_mut().unwrap();
        let rx = Received { port: Port::P0, bytes: frame.as_bytes(), meta: None };
        if let Some(Delivered::Config(write)) = app.receive(rx, now_us, stamp) {
            app.configure(&write, stamp, |_, _| {});
        }
    }
    fn transmit(&mut self) -> Option<Frame> {
        self.0.app_mut().unwrap().transmit(Port::P0)
    }
    fn sample(&mut self, raw: &Sample) {
        self.0.app_mut().unwrap().sample(raw, &mut Stamper::new(self.1, 0), |_, _| {});
    }
    fn reboot(&mut self, now_us: u64) {
        self.0.power_off();
        self.0.power_on(Config::default(), now_us);
    }
}

/// Runs a wired cell against a sink for `until_us`, sampling nothing;
/// returns the frames for the host.
fn exchange(cell: &mut impl Wired, sink: &mut Sink, t: &mut u64, until_us: u64) -> Vec<Frame> {
    let mut up = Vec::new();
    while *t < until_us {
        if cell.poll_at() <= *t {
            cell.poll(*t);
        }
        sink.poll(*t);
        while let Some(frame) = cell.transmit() {
            if let Ok(FromCell::Host(f)) = sink.receive(frame.as_bytes(), *t) {
                up.push(f);
            }
        }
        while let Some(f) = sink.transmit() {
            cell.receive(&f, *t);
        }
        *t += 100;
    }
    up
}

/// The application's frames among those for the host.
fn app_frames(frames: Vec<Frame>) -> Vec<Frame> {
    frames.into_iter().filter(|f| matches!(f.kind(), Kind::Sample | Kind::Event | Kind::ConfigAck)).collect()
}

/// Organizes the cell (ID 1), then runs the script: what reached the host.
fn run_wired(mut cell: impl Wired) -> Vec<Frame> {
    let (mut sink, mut t) = (Sink::new(0, Config::default(), 0).unwrap(), 0);
    let up = exchange(&mut cell, &mut sink, &mut t, 100_000);
    let request = up.iter().find_map(|f| match f.message() {
        Ok(Message::IdRequest(r)) => Some(r),
        _ => None,
    });
    let r = request.expect("the cell asks for an ID");
    sink.send(Frame::new(Address::HOST, r.parent, &Message::IdAssign(IdAssign { port: r.port, id: ID }))).unwrap();
    exchange(&mut cell, &mut sink, &mut t, 200_000);
    let mut out = Vec::new();
    for step in script() {
        match step {
            Step::Write(tag, setting) => {
                let write = Message::ConfigWrite(ConfigWrite { tag, setting });
                sink.send(Frame::new(Address::HOST, ID, &write)).unwrap();
            }
            Step::Samples(n, raw) => {
                for _ in 0..n {
                    cell.sample(&raw);
                    let until = t + 4_000;
                    out.extend(app_frames(exchange(&mut cell, &mut sink, &mut t, until)));
                }
            }
            Step::Reboot => cell.reboot(t),
        }
        // Writes delivered, a rebooted cell attached again.
        let until = t + 100_000;
        out.extend(app_frames(exchange(&mut cell, &mut sink, &mut t, until)));
    }
    out
}

/// The load generator's cell: no network, straight to the host.
fn run_load_generator() -> Vec<Frame> {
    let mut cell = AppCell::new(ID, factory());
    let mut out = Vec::new();
    for step in script() {
        match step {
            Step::Write(tag, setting) => cell.configure(&ConfigWrite { tag, setting }, &mut out),
            Step::Samples(n, raw) => (0..n).for_each(|_| cell.sample(&raw, &mut out)),
            Step::Reboot => cell.reboot(),
        }
    }
    out
}

#[test]
fn firmware_simulator_and_load_generator_cells_send_the_same_bytes() {
    let firmware = run_wired(firmware_node(0));
    let mut sim = SimCell::new(factory(), None);
    sim.power_on(Config::default(), 0);
    let simulated = run_wired(Simulated(sim, 0));
    let load = run_load_generator();
    let bytes = |frames: &[Frame]| frames.iter().map(|f| f.as_bytes().to_vec()).collect::<Vec<_>>();
    assert_eq!(bytes(&firmware), bytes(&simulated), "firmware vs simulator");
    assert_eq!(bytes(&firmware), bytes(&load), "firmware vs load generator");
    // The script exercised what it is for: rejected and accepted writes,
    // settings kept across a reboot (event traffic after the first one,
    // clock traffic after the second), tactile events.
    let messages: Vec<Message> = firmware.iter().map(|f| f.message().unwrap()).collect();
    let acks: Vec<(u8, bool)> = messages
        .iter()
        .filter_map(|m| match m {
            Message::ConfigAck(a) => Some((a.tag, a.accepted)),
            _ => None,
        })
        .collect();
    assert_eq!(acks, [(1, true), (2, true), (3, false), (4, true), (5, true)]);
    assert!(messages.iter().any(|m| matches!(m, Message::Event(_))));
    let samples_between = |a: u8, b: u8| {
        let at = |tag| messages.iter().position(|m| matches!(m, Message::ConfigAck(k) if k.tag == tag)).unwrap();
        messages[at(a)..at(b)].iter().filter(|m| matches!(m, Message::Sample(_))).count()
    };
    assert!(samples_between(3, 4) < 6, "event traffic kept across the reboot");
    assert!(messages.iter().rev().take(3).all(|m| matches!(m, Message::Sample(_))), "clock traffic kept");
}
