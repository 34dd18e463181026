//! Throughput and loss of the host's UDP interface.
//!
//! 1. `ingest` (criterion): decode and dispatch of a 1,260-cell skin's
//!    datagrams in memory, on one core, at 1, ~20 and ~70 frames per datagram.
//! 2. Over loopback, the load generator (`skin loadgen`'s engine) sends real
//!    datagrams from 16 port sockets to an `Interface` polled on one thread:
//!    - flat out in full datagrams: frames per second decoded, and frames per
//!      second of the receiving thread's CPU time (the one-core capacity);
//!    - clock-driven at 315,000 frames/s (1,260 cells at 250 Hz), each port
//!      sending every 1 ms, and again with one datagram per frame: frames
//!      lost, the receiving thread's CPU load, and the socket receive buffer;
//!    - recording on (`skin run --record`: every datagram and the ROS 2
//!      topics into an MCAP file) at 1,260 cells and at the 74 cells of
//!      HRP-2 (5 ports), against the same without recording: loss, CPU
//!      and messages written per second;
//!    - with `--features ros2`, publishing on (`--ros2`: the ROS 2 topics
//!      over Zenoh, to a subscriber in the same process connected over
//!      loopback TCP; and over DDS, to a `/skin/cells` subscriber in the
//!      same process on a participant of its own, loopback only): loss, the
//!      receiving thread's CPU and the other threads' (load generator,
//!      Zenoh's runtime or RustDDS's threads), and messages and bytes the
//!      subscriber got per second;
//!    - with `--features foxglove` (or `ros2`), the Foxglove view on
//!      (`--foxglove`), a WebSocket client in the same process subscribed
//!      to every channel: loss, the receiving thread's CPU and the other
//!      threads' (load generator, the view's thread, the SDK's runtime, the
//!      client), and messages and bytes the client got per second.
//!
//! `cargo bench -p skin-host --bench interface [--features ros2]` (about 4 minutes);
//! `SKIN_BENCH_SECONDS` sets the length of each loopback run (default 10);
//! `SKIN_BENCH_ONLY_PUBLISH=1` runs only publishing (Zenoh, DDS, Foxglove) and its baselines.

use std::hint::black_box;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput};
use skin_host::config::{InterfaceConfig, PortConfig};
use skin_host::interface::loadgen::{LoadGen, LoadSpec, Pace, SimSkin};
use skin_host::interface::{EventKind, Ingest, Interface, InterfaceCounters};
use skin_host::recording::Session;
use skin_protocol::message::AccelRange;

/// The skin of the requirement: 1,260 cells at 250 Hz on 16 ports.
fn heavy_skin(flush_us: u64) -> LoadSpec {
    LoadSpec { flush_us, ..LoadSpec::default() }
}

fn source(port: usize) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 20_000 + port as u16))
}

/// `seconds` of the skin's datagrams: (port, bytes, frames).
fn datagrams(spec: LoadSpec, seconds: f64) -> Vec<(usize, Vec<u8>, usize)> {
    let ports = usize::from(spec.ports);
    let mut skin = SimSkin::new(spec).expect("valid spec");
    let end_us = (seconds * 1e6) as u64;
    skin.generate(end_us);
    skin.flush_all(end_us);
    let mut out = Vec::new();
    for p in 0..ports {
        out.extend(skin.outgoing(p).map(|(d, frames)| (p, d.to_vec(), frames)));
    }
    out
}

fn ingest(c: &mut Criterion) {
    let mut group = c.benchmark_group("ingest");
    group.sample_size(20).measurement_time(Duration::from_secs(8));
    for flush_us in [0, 1000, 1_000_000] {
        let spec = heavy_skin(flush_us);
        let ports: Vec<PortConfig> =
            (0..spec.ports).map(|p| PortConfig { number: p, address: Some(source(usize::from(p))) }).collect();
        let mut set = datagrams(spec, 0.2);
        let frames: usize = set.iter().map(|(_, _, f)| f).sum();
        let per_port = set.iter().filter(|(p, _, _)| *p == 0).count() as u32;
        let label = format!("{:.0}", frames as f64 / set.len() as f64);
        let mut interface = Ingest::new(&ports);
        let mut events = Vec::with_capacity(2 * frames);
        let mut pass = 0u32;
        group.throughput(Throughput::Elements(frames as u64));
        group.bench_function(BenchmarkId::new("frames_per_datagram", label), |b| {
            b.iter(|| {
                // Each pass continues every port's sequence, as a running skin would.
                pass += 1;
                let mut samples = 0usize;
                for (port, bytes, _) in &mut set {
                    let seq = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]).wrapping_add(per_port);
                    bytes[4..8].copy_from_slice(&seq.to_le_bytes());
                    events.clear();
                    interface.datagram(source(*port), bytes, u64::from(pass) * 200_000, &mut events);
                    samples += events.iter().filter(|e| matches!(e.kind, EventKind::Sample(_))).count();
                }
                black_box(samples)
            })
        });
        assert!(interface.counters().balanced());
        assert_eq!(interface.counters().frames.accepted, interface.counters().frames.received);
    }
    group.finish();
}

/// CPU time of the calling thread in seconds (Linux), for the load it carries.
fn thread_cpu_s() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(text.split_whitespace().next()?.parse::<f64>().ok()? / 1e9)
}

/// UDP receive-buffer overflows of the whole system (Linux), an independent
/// witness of loss in the kernel.
fn rcvbuf_errors() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/net/snmp").ok()?;
    let mut udp = text.lines().filter(|l| l.starts_with("Udp:"));
    let names: Vec<&str> = udp.next()?.split_whitespace().collect();
    let values: Vec<&str> = udp.next()?.split_whitespace().collect();
    values.get(names.iter().position(|n| *n == "RcvbufErrors")?)?.parse().ok()
}

/// What the receiving thread does with what it hears besides decoding it.
#[derive(Clone)]
enum Output {
    Nothing,
    /// Records into this MCAP file.
    Record(std::path::PathBuf),
    /// Publishes the ROS 2 topics over Zenoh to a subscriber.
    #[cfg(feature = "ros2")]
    Publish,
    /// Publishes the ROS 2 topics over DDS to a `/skin/cells` subscriber.
    #[cfg(feature = "ros2")]
    PublishDds,
    /// Serves the Foxglove view to a subscribed client.
    #[cfg(feature = "foxglove")]
    Foxglove,
}

/// CPU time of the process's live threads in seconds (Linux): a thread that ended is not counted.
fn process_cpu_s() -> Option<f64> {
    let mut ns = 0.0;
    for task in std::fs::read_dir("/proc/self/task").ok()?.flatten() {
        let text = std::fs::read_to_string(task.path().join("schedstat")).unwrap_or_default();
        ns += text.split_whitespace().next().and_then(|t| t.parse::<f64>().ok()).unwrap_or(0.0);
    }
    Some(ns / 1e9)
}

/// Messages and bytes a subscriber got.
#[cfg(any(feature = "ros2", feature = "foxglove"))]
type Counts = Arc<(std::sync::atomic::AtomicU64, std::sync::atomic::AtomicU64)>;

/// A Zenoh subscriber to everything `node` publishes, counting messages and bytes.
#[cfg(feature = "ros2")]
fn subscriber(node: &skin_host::ros::rmw_zenoh::Node) -> (zenoh::Session, zenoh::pubsub::Subscriber<()>, Counts) {
    use zenoh::Wait;
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", "\"peer\"").expect("mode");
    config.insert_json5("scouting/multicast/enabled", "false").expect("scouting");
    config.insert_json5("listen/endpoints", "[]").expect("listen");
    config.insert_json5("connect/endpoints", &serde_json::to_string(&node.locators()).expect("json")).expect("connect");
    let session = zenoh::open(config).wait().expect("open the subscriber's session");
    let counts = Arc::new((std::sync::atomic::AtomicU64::new(0), std::sync::atomic::AtomicU64::new(0)));
    let c = counts.clone();
    let sub = session
        .declare_subscriber("0/**")
        .callback(move |s| {
            c.0.fetch_add(1, Ordering::Relaxed);
            c.1.fetch_add(s.payload().len() as u64, Ordering::Relaxed);
        })
        .wait()
        .expect("subscribe");
    // Until the subscription has reached the publisher's side.
    thread::sleep(Duration::from_millis(500));
    (session, sub, counts)
}

/// `sensor_msgs/PointCloud2` as serde reads it from CDR.
#[cfg(feature = "ros2")]
#[derive(serde::Deserialize)]
#[allow(dead_code, reason = "decoded whole, as a subscriber would; only the data's length is counted")]
struct PointCloud2 {
    stamp: (i32, u32),
    frame_id: String,
    height: u32,
    width: u32,
    fields: Vec<(String, u32, u8, u32)>,
    is_bigendian: bool,
    point_step: u32,
    row_step: u32,
    data: Vec<u8>,
    is_dense: bool,
}

/// A DDS subscriber to `/skin/cells` in `domain` (its own participant,
/// loopback only), taking on its own thread until the returned flag is set;
/// counts messages and point-data bytes.
#[cfg(feature = "ros2")]
fn dds_subscriber(domain: u16) -> (Arc<AtomicBool>, Counts) {
    use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions};
    let participant = rustdds::DomainParticipantBuilder::new(domain)
        .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
        .build()
        .expect("the subscriber's participant");
    let context = ros2_client::dds::Context::from_domain_participant(participant).expect("context");
    let mut node = context.new_node(NodeName::new("/", "bench").expect("name"), NodeOptions::new()).expect("node");
    let qos = ros2_client::QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 10 });
    let topic = node
        .create_topic(
            &Name::parse("/skin/cells").expect("topic"),
            MessageTypeName::new("sensor_msgs", "PointCloud2"),
            &qos,
        )
        .expect("topic");
    let sub = node.create_subscription::<PointCloud2>(&topic, Some(qos)).expect("subscription");
    let counts = Arc::new((std::sync::atomic::AtomicU64::new(0), std::sync::atomic::AtomicU64::new(0)));
    let done = Arc::new(AtomicBool::new(false));
    let (c, d) = (counts.clone(), done.clone());
    thread::spawn(move || {
        let _alive = (&context, &node);
        while !d.load(Ordering::Relaxed) {
            match sub.take() {
                Ok(Some((cloud, _))) => {
                    c.0.fetch_add(1, Ordering::Relaxed);
                    c.1.fetch_add(cloud.data.len() as u64, Ordering::Relaxed);
                }
                _ => thread::sleep(Duration::from_micros(500)),
            }
        }
    });
    // Until discovery has matched it with the publisher's participant.
    thread::sleep(Duration::from_millis(500));
    (done, counts)
}

/// A Foxglove client at `addr` that subscribes to every channel advertised
/// and counts the messages and bytes it gets: a plain WebSocket client over
/// a `TcpStream` (RFC 6455: one upgrade request, masked text frames out,
/// unmasked frames in), so the bench needs no WebSocket crate.
#[cfg(feature = "foxglove")]
fn foxglove_client(addr: SocketAddr, stop: Arc<AtomicBool>) -> (thread::JoinHandle<()>, Counts) {
    use std::io::{BufRead, BufReader, Read, Write};
    let counts: Counts = Arc::new((std::sync::atomic::AtomicU64::new(0), std::sync::atomic::AtomicU64::new(0)));
    let c = counts.clone();
    let mut tcp = std::net::TcpStream::connect(addr).expect("connect to the view");
    tcp.set_read_timeout(Some(Duration::from_millis(200))).expect("timeout");
    write!(
        tcp,
        "GET / HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
         Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\
         Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
    )
    .expect("upgrade request");
    let client = thread::spawn(move || {
        let mut reader = BufReader::new(tcp.try_clone().expect("clone"));
        let mut line = String::new();
        while reader.read_line(&mut line).expect("upgrade answer") > 2 {
            line.clear();
        }
        let mut next_id = 1u32;
        while !stop.load(Ordering::Relaxed) {
            let mut head = [0u8; 2];
            match reader.read_exact(&mut head) {
                Ok(()) => {}
                Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => continue,
                Err(_) => break,
            }
            let len = match head[1] & 0x7f {
                126 => {
                    let mut l = [0u8; 2];
                    reader.read_exact(&mut l).expect("length");
                    usize::from(u16::from_be_bytes(l))
                }
                127 => {
                    let mut l = [0u8; 8];
                    reader.read_exact(&mut l).expect("length");
                    u64::from_be_bytes(l) as usize
                }
                n => usize::from(n),
            };
            let mut payload = vec![0u8; len];
            reader.read_exact(&mut payload).expect("payload");
            if head[0] & 0x0f == 2 {
                c.0.fetch_add(1, Ordering::Relaxed);
                c.1.fetch_add(len as u64, Ordering::Relaxed);
                continue;
            }
            // A text frame: subscribe to what an advertise offers.
            let text: serde_json::Value = serde_json::from_slice(&payload).unwrap_or_default();
            let Some(channels) = text["channels"].as_array().filter(|_| text["op"] == "advertise") else { continue };
            let subscriptions: Vec<serde_json::Value> = channels
                .iter()
                .map(|ch| {
                    next_id += 1;
                    serde_json::json!({"id": next_id, "channelId": ch["id"]})
                })
                .collect();
            let body = serde_json::json!({"op": "subscribe", "subscriptions": subscriptions}).to_string();
            let mut frame = vec![0x81u8];
            match body.len() {
                n if n < 126 => frame.push(0x80 | n as u8),
                n => {
                    frame.push(0x80 | 126);
                    frame.extend_from_slice(&(n as u16).to_be_bytes());
                }
            }
            // A client masks what it sends; a zero mask leaves it as it is.
            frame.extend_from_slice(&[0; 4]);
            frame.extend_from_slice(body.as_bytes());
            tcp.write_all(&frame).expect("subscribe");
        }
    });
    (client, counts)
}

struct Received {
    counters: InterfaceCounters,
    /// Messages and bytes the Zenoh subscriber got, when publishing.
    published: Option<(u64, u64)>,
    samples: u64,
    cpu_s: Option<f64>,
    busy_s: f64,
    recv_buffer_bytes: usize,
    /// Messages recorded, and the file's size in bytes, when recording.
    recorded: Option<(u32, u64)>,
}

/// Runs the load generator against an interface polled on its own thread,
/// with `output`.
fn loopback(
    spec: LoadSpec,
    pace: Pace,
    seconds: f64,
    output: Output,
) -> (skin_host::interface::loadgen::LoadReport, Received) {
    let config = InterfaceConfig {
        listen: SocketAddr::from(([127, 0, 0, 1], 0)),
        ports: (0..spec.ports).map(|number| PortConfig { number, address: None }).collect(),
        ..InterfaceConfig::default()
    };
    let mut interface = Interface::bind(&config).expect("bind the interface on loopback");
    let host = interface.local_addr();
    let stop = Arc::new(AtomicBool::new(false));
    let receiver = {
        let stop = stop.clone();
        thread::spawn(move || {
            // Reads what the Zenoh subscriber got, when publishing.
            #[allow(unused_mut)]
            let mut published: Option<Box<dyn Fn() -> (u64, u64)>> = None;
            let mut session = match &output {
                Output::Nothing => None,
                Output::Record(p) => Some(Session::create(p, AccelRange::G2, false).expect("create")),
                #[cfg(feature = "ros2")]
                Output::Publish => {
                    use skin_host::ros::rmw_zenoh::{Node, ZenohConfig};
                    let node = Node::open(ZenohConfig::default()).expect("open the Zenoh node");
                    let (zenoh_session, zenoh_subscriber, counts) = subscriber(&node);
                    published = Some(Box::new(move || {
                        let _alive = (&zenoh_session, &zenoh_subscriber);
                        (counts.0.load(Ordering::Relaxed), counts.1.load(Ordering::Relaxed))
                    }));
                    let mut s = Session::live(AccelRange::G2, false);
                    s.add_outlet(Box::new(node));
                    Some(s)
                }
                #[cfg(feature = "ros2")]
                Output::PublishDds => {
                    use skin_host::ros::dds::{DdsConfig, Node};
                    let domain = 200 + (std::process::id() % 30) as u16;
                    let config = DdsConfig { domain, node: "skin".to_owned(), localhost_only: true };
                    let node = Node::open(&config).expect("open the DDS node");
                    let (done, counts) = dds_subscriber(domain);
                    published = Some(Box::new(move || {
                        done.store(true, Ordering::Relaxed);
                        (counts.0.load(Ordering::Relaxed), counts.1.load(Ordering::Relaxed))
                    }));
                    let mut s = Session::live(AccelRange::G2, false);
                    s.add_outlet(Box::new(node));
                    Some(s)
                }
                #[cfg(feature = "foxglove")]
                Output::Foxglove => {
                    let (view, feed) = skin_host::foxglove::FoxgloveView::start(SocketAddr::from(([127, 0, 0, 1], 0)))
                        .expect("start the Foxglove view");
                    let done = Arc::new(AtomicBool::new(false));
                    let (client, counts) = foxglove_client(view.local_addr(), done.clone());
                    // Until the client has subscribed.
                    thread::sleep(Duration::from_millis(500));
                    let view = std::cell::Cell::new(Some((view, client)));
                    published = Some(Box::new(move || {
                        if let Some((view, client)) = view.take() {
                            let stats = view.finish();
                            println!("    the view: {stats:?}");
                            done.store(true, Ordering::Relaxed);
                            let _ = client.join();
                        }
                        (counts.0.load(Ordering::Relaxed), counts.1.load(Ordering::Relaxed))
                    }));
                    let mut s = Session::live(AccelRange::G2, false);
                    s.add_view(feed);
                    Some(s)
                }
            };
            let cpu0 = thread_cpu_s();
            let mut events = Vec::new();
            let (mut first, mut last, mut samples) = (None, Instant::now(), 0u64);
            let start = Instant::now();
            loop {
                events.clear();
                let timeout = Duration::from_millis(50);
                let n = match &mut session {
                    Some(s) if s.records_datagrams() => {
                        interface.poll_tapped(timeout, &mut events, &mut |from, now_us, bytes| {
                            s.datagram(from, now_us, bytes)
                        })
                    }
                    _ => interface.poll(timeout, &mut events),
                }
                .expect("poll");
                if let Some(s) = &mut session {
                    s.events(&events, start.elapsed().as_secs_f64());
                }
                if n > 0 {
                    first.get_or_insert_with(Instant::now);
                    last = Instant::now();
                    samples += events.iter().filter(|e| matches!(e.kind, EventKind::Sample(_))).count() as u64;
                } else if stop.load(Ordering::Relaxed) {
                    break;
                }
            }
            let cpu1 = thread_cpu_s();
            let recorded = session.and_then(|s| {
                let written = s.written();
                let path = s.finish().expect("finish the recording")?;
                Some((written, std::fs::metadata(&path).map_or(0, |m| m.len())))
            });
            // What is still in flight arrives.
            thread::sleep(Duration::from_millis(if published.is_some() { 300 } else { 0 }));
            let published = published.map(|count| count());
            Received {
                recorded,
                published,
                counters: *interface.counters(),
                samples,
                cpu_s: cpu1.zip(cpu0).map(|(b, a)| b - a),
                busy_s: first.map_or(0.0, |f| (last - f).as_secs_f64()),
                recv_buffer_bytes: interface.recv_buffer_bytes(),
            }
        })
    };
    let mut generator = LoadGen::new(spec, host).expect("open the load generator's sockets");
    let sent = generator.run(Duration::from_secs_f64(seconds), pace, |_| {});
    stop.store(true, Ordering::Relaxed);
    (sent, receiver.join().expect("receiver thread"))
}

/// How many datagrams of `frames` frames the default receive buffer holds
/// while nobody reads: the longest burst (or stall of the receiver) the
/// interface survives.
fn buffer_depth(frames: usize) -> (usize, usize) {
    let config = InterfaceConfig { listen: SocketAddr::from(([127, 0, 0, 1], 0)), ..InterfaceConfig::default() };
    let mut interface = Interface::bind(&config).expect("bind the interface on loopback");
    let sender = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind a sender");
    let datagram = vec![0u8; 16 + 20 * frames];
    for _ in 0..1_000_000 {
        if sender.send_to(&datagram, interface.local_addr()).is_err() {
            break;
        }
    }
    let mut events = Vec::new();
    while interface.poll(Duration::from_millis(100), &mut events).expect("poll") > 0 {}
    (interface.counters().datagrams.received as usize, interface.recv_buffer_bytes())
}

fn loopback_report(seconds: f64) {
    for frames in [1, 20] {
        let (held, granted) = buffer_depth(frames);
        println!(
            "receive buffer {granted} bytes granted: holds {held} datagrams of {frames} frame(s) unread, \
             {:.0} ms of a 315,000 frames/s skin",
            1e3 * (held * frames) as f64 / 315_000.0
        );
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "\nLoopback, {seconds} s per run (load generator and interface each on one thread; \
         {} cores, load average {})",
        thread::available_parallelism().map_or(0, |n| n.get()),
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
    );
    let flat = heavy_skin(1_000_000);
    let drops0 = rcvbuf_errors();
    let (sent, got) = loopback(flat, Pace::FlatOut, seconds, Output::Nothing);
    let f = got.counters.frames;
    println!(
        "  flat out, {:.1} frames/datagram: sent {} frames, decoded {} ({} samples dispatched), lost {}\n    \
         {:.0} frames/s decoded over {:.2} s; receiving thread: {}",
        sent.frames as f64 / sent.datagrams.max(1) as f64,
        sent.frames,
        f.accepted,
        got.samples,
        sent.frames - f.accepted.min(sent.frames),
        f.accepted as f64 / got.busy_s.max(1e-9),
        got.busy_s,
        got.cpu_s.map_or("CPU time unknown".into(), |cpu| format!(
            "{cpu:.2} s CPU = {:.0} frames per CPU-second",
            f.accepted as f64 / cpu
        )),
    );
    println!("    kernel UDP receive-buffer overflows (system-wide): {}", delta(drops0, rcvbuf_errors()));

    let file = std::env::temp_dir().join(format!("skin-bench-{}.mcap", std::process::id()));
    let hrp2 = LoadSpec { cells: 74, ports: 5, ..heavy_skin(1000) };
    #[allow(unused_mut)]
    let mut runs = vec![
        (heavy_skin(1000), "each port sends every 1 ms", Output::Nothing),
        (heavy_skin(0), "one datagram per frame", Output::Nothing),
        (heavy_skin(1000), "each port sends every 1 ms, RECORDING", Output::Record(file.clone())),
        (hrp2.clone(), "74 cells on 5 ports, each sends every 1 ms", Output::Nothing),
        (hrp2.clone(), "74 cells on 5 ports, each sends every 1 ms, RECORDING", Output::Record(file.clone())),
    ];
    #[cfg(feature = "ros2")]
    runs.extend([
        (heavy_skin(1000), "each port sends every 1 ms, PUBLISHING over Zenoh", Output::Publish),
        (hrp2.clone(), "74 cells on 5 ports, each sends every 1 ms, PUBLISHING over Zenoh", Output::Publish),
        (heavy_skin(1000), "each port sends every 1 ms, PUBLISHING over DDS", Output::PublishDds),
        (hrp2.clone(), "74 cells on 5 ports, each sends every 1 ms, PUBLISHING over DDS", Output::PublishDds),
    ]);
    #[cfg(feature = "foxglove")]
    runs.extend([
        (heavy_skin(1000), "each port sends every 1 ms, PUBLISHING to Foxglove", Output::Foxglove),
        (hrp2, "74 cells on 5 ports, each sends every 1 ms, PUBLISHING to Foxglove", Output::Foxglove),
    ]);
    // Publishing and its baselines alone.
    if std::env::var_os("SKIN_BENCH_ONLY_PUBLISH").is_some() {
        runs.retain(|(_, what, _)| !what.contains("RECORDING") && !what.contains("one datagram per frame"));
    }
    for (spec, what, output) in runs {
        let rate = spec.sample_rate_hz();
        let drops0 = rcvbuf_errors();
        let process0 = process_cpu_s();
        let (sent, got) = loopback(spec, Pace::RealTime, seconds, output);
        let process_cpu = process_cpu_s().zip(process0).map(|(b, a)| b - a);
        let c = got.counters;
        let lost = sent.frames - c.frames.accepted.min(sent.frames);
        println!(
            "  {rate:.0} frames/s clock-driven, {what} ({:.1} frames/datagram): sent {} frames in {} datagrams \
             over {:.2} s = {:.0} frames/s ({} send errors; sender at worst {} us behind its clock)\n    \
             lost {lost} frames ({:.4} %), datagrams missing by sequence {}, rejected {}, \
             receiving thread {}; socket receive buffer {} bytes granted (asked {})",
            sent.frames as f64 / sent.datagrams.max(1) as f64,
            sent.frames,
            sent.datagrams,
            sent.wall_time_s,
            sent.frames as f64 / sent.wall_time_s,
            sent.send_errors,
            sent.behind_max_us,
            100.0 * lost as f64 / sent.frames.max(1) as f64,
            c.datagrams.missing,
            c.datagrams.rejected_total() + c.frames.rejected_total(),
            got.cpu_s.map_or("CPU unknown".into(), |cpu| format!("{:.1} % of a core", 100.0 * cpu / sent.wall_time_s)),
            got.recv_buffer_bytes,
            InterfaceConfig::default().recv_buffer_bytes,
        );
        println!(
            "    kernel UDP receive-buffer overflows (system-wide): {}; the other threads (load generator; publishing: Zenoh's runtime or RustDDS's threads and the subscriber, or the view's thread, the SDK's runtime and the client): {}",
            delta(drops0, rcvbuf_errors()),
            process_cpu.map_or("CPU unknown".into(), |cpu| format!("{:.1} % of a core", 100.0 * cpu / sent.wall_time_s))
        );
        if let Some((messages, bytes)) = got.published {
            println!(
                "    the subscriber got {messages} messages = {:.1} per second, {:.2} MB/s",
                messages as f64 / sent.wall_time_s,
                bytes as f64 / 1e6 / sent.wall_time_s
            );
        }
        if let Some((messages, bytes)) = got.recorded {
            println!(
                "    recorded {messages} messages = {:.0} per second, {:.1} MB = {:.1} MB/s",
                f64::from(messages) / sent.wall_time_s,
                bytes as f64 / 1e6,
                bytes as f64 / 1e6 / sent.wall_time_s
            );
        }
    }
    let _ = std::fs::remove_file(&file);
}

fn delta(before: Option<u64>, after: Option<u64>) -> String {
    match (before, after) {
        (Some(a), Some(b)) => (b - a).to_string(),
        _ => "unknown".into(),
    }
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    ingest(&mut criterion);
    criterion.final_summary();
    let seconds = std::env::var("SKIN_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(10.0);
    loopback_report(seconds);
}
