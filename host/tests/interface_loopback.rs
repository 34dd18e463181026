//! The interface over real loopback sockets: a simulated skin's traffic is
//! taken in whole and counted, the registry learns the skin's shape,
//! configuration writes reach the cells and come back acknowledged, ID
//! requests are answered down the port they came from, and datagrams from
//! the wrong source are refused.

use std::net::{SocketAddr, UdpSocket};
use std::thread;
use std::time::{Duration, Instant};

use skin_host::config::{InterfaceConfig, PortConfig};
use skin_host::interface::loadgen::{LoadGen, LoadSpec, Pace};
use skin_host::interface::{DatagramReject, Event, EventKind, Interface};
use skin_protocol::interface::{encode, Datagram, DatagramHeader, MAX_DATAGRAM};
use skin_protocol::message::{IdRequest, Port, Setting, TrafficMode};
use skin_protocol::{Address, Frame, Message};

fn loopback() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 0))
}

fn interface(ports: Vec<PortConfig>) -> Interface {
    Interface::bind(&InterfaceConfig { listen: loopback(), ports, ..InterfaceConfig::default() }).unwrap()
}

/// Polls until `done` holds or `limit` passes; returns the events seen.
fn poll_until(
    interface: &mut Interface,
    limit: Duration,
    mut done: impl FnMut(&Interface, &[Event]) -> bool,
) -> Vec<Event> {
    let start = Instant::now();
    let mut all = Vec::new();
    while start.elapsed() < limit && !done(interface, &all) {
        interface.poll(Duration::from_millis(10), &mut all).unwrap();
    }
    all
}

#[test]
fn a_simulated_skin_is_heard_whole_and_obeys_configuration_writes() {
    let spec = LoadSpec { cells: 60, ports: 3, report_period_s: 0.2, ..LoadSpec::default() };
    let mut interface = interface((0..3).map(|number| PortConfig { number, address: None }).collect());
    let mut generator = LoadGen::new(spec, interface.local_addr()).unwrap();
    let sender = thread::spawn(move || generator.run(Duration::from_secs(3), Pace::RealTime, |_| {}));

    // Every cell heard and every neighbour table in: the skin's shape.
    poll_until(&mut interface, Duration::from_secs(10), |i, _| {
        i.registry().len() == 60 && i.registry().cells().all(|c| c.neighbours().is_some())
    });
    let topology = interface.registry().topology();
    assert_eq!(topology.patches.iter().map(Vec::len).collect::<Vec<_>>(), [20, 20, 20]);
    // Patches of 20 in 5 columns, each hanging off its port at its first cell.
    for (id, hops) in &topology.hops {
        let j = usize::from(id.0 - 1) % 20;
        assert_eq!(usize::from(*hops), j / 5 + j % 5 + 1, "{id}");
    }
    assert_eq!(topology.hops.len(), 60);

    // Clock-driven: samples flow.
    let before = interface.counters().frames.accepted;
    poll_until(&mut interface, Duration::from_millis(300), |_, _| false);
    let clock_frames = interface.counters().frames.accepted - before;

    // Event-driven from now on, and one cell gets its own write.
    let tags = interface.send_config(Address::BROADCAST, &[Setting::Traffic(TrafficMode::Event)]).unwrap();
    let own = interface.send_config(Address(7), &[Setting::Hysteresis(0.01)]).unwrap();
    let events = poll_until(&mut interface, Duration::from_secs(5), |_, events| {
        events.iter().filter(|e| matches!(e.kind, EventKind::ConfigAck(_))).count() == 61
    });
    let acks: Vec<(u16, u8, bool)> = events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::ConfigAck(a) => Some((e.cell.0, a.tag, a.accepted)),
            _ => None,
        })
        .collect();
    assert_eq!(acks.len(), 61, "every cell acknowledged the broadcast, cell 7 also its own write");
    assert!(acks.iter().all(|(_, _, accepted)| *accepted));
    assert_eq!(acks.iter().filter(|(_, tag, _)| *tag == tags[0]).count(), 60);
    assert_eq!(acks.iter().filter(|(_, tag, _)| *tag == own[0]).map(|a| a.0).collect::<Vec<_>>(), [7]);

    // A quiet skin sending on events only is (nearly) silent.
    let before = interface.counters().frames.accepted;
    poll_until(&mut interface, Duration::from_millis(300), |_, _| false);
    let event_frames = interface.counters().frames.accepted - before;
    assert!(clock_frames > 1000 && event_frames * 10 < clock_frames, "clock {clock_frames}, event {event_frames}");

    let sent = sender.join().unwrap();
    poll_until(&mut interface, Duration::from_secs(5), |i, _| i.counters().frames.accepted >= sent.frames);
    let c = interface.counters();
    assert!(c.balanced());
    assert_eq!(c.frames.accepted, sent.frames, "loopback at 15,000 frames/s loses nothing");
    assert_eq!((c.datagrams.received, c.datagrams.missing), (sent.datagrams, 0));
    assert_eq!(sent.writes_applied, 61);
    for p in interface.ports().iter() {
        assert!(p.address().is_some(), "port {} bound to its first source", p.number());
    }
}

fn datagram(interface: u8, seq: u32, frames: &[Frame]) -> Vec<u8> {
    let mut buf = [0u8; MAX_DATAGRAM];
    let n = encode(DatagramHeader { interface, seq, timestamp_us: 0 }, frames, &mut buf).unwrap();
    buf[..n].to_vec()
}

#[test]
fn id_requests_are_answered_down_their_port_and_strangers_are_refused() {
    let port0 = UdpSocket::bind(loopback()).unwrap();
    let stranger = UdpSocket::bind(loopback()).unwrap();
    port0.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut interface = interface(vec![
        PortConfig { number: 0, address: Some(port0.local_addr().unwrap()) },
        PortConfig { number: 1, address: None },
    ]);
    let host = interface.local_addr();

    // A cell on port P2 of the cell attached to interface port 0 asks for an ID.
    let request = IdRequest { parent: Address::interface(0).unwrap(), port: Port::P2 };
    let frame = Frame::new(Address::UNASSIGNED, Address::HOST, &Message::IdRequest(request));
    port0.send_to(&datagram(0, 0, &[frame]), host).unwrap();
    // A stranger claims port 0 (bound elsewhere) and port 9 (not configured).
    stranger.send_to(&datagram(0, 1, &[frame]), host).unwrap();
    stranger.send_to(&datagram(9, 0, &[frame]), host).unwrap();
    poll_until(&mut interface, Duration::from_secs(5), |i, _| i.counters().datagrams.received == 3);

    let mut buf = [0u8; 2048];
    let (n, from) = port0.recv_from(&mut buf).unwrap();
    assert_eq!(from, host);
    let reply = Datagram::parse(&buf[..n]).unwrap();
    assert_eq!((reply.header().interface, reply.header().seq), (0, 0));
    let frame = reply.frames().next().unwrap().unwrap();
    assert_eq!(frame.dst(), Address::interface(0).unwrap());
    match frame.message().unwrap() {
        Message::IdAssign(a) => assert_eq!((a.port, a.id), (Port::P2, Address(1))),
        m => panic!("{m:?}"),
    }
    let c = interface.counters();
    assert_eq!(c.datagrams.rejected(DatagramReject::Spoofed), 1);
    assert_eq!(c.datagrams.rejected(DatagramReject::UnknownPort), 1);
    assert_eq!((c.id_replies, c.sent_datagrams), (1, 1));
    assert!(c.balanced());
    // Port 1 has not been heard, so a broadcast reaches port 0 only; a cell
    // never heard cannot be written to.
    interface.send_config(Address::BROADCAST, &[Setting::Traffic(TrafficMode::Clock)]).unwrap();
    assert_eq!(interface.counters().sent_datagrams, 2);
    assert!(interface.send_config(Address(99), &[Setting::Hysteresis(0.01)]).is_err());
    assert!(interface.send_config(Address::BROADCAST, &[Setting::SampleRateHz(-1.0)]).is_err());
}
