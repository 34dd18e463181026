//! The simulated robot and skin over loopback UDP, driven by a bare host:
//! the robot link by hand, the interface by the network's minimal host.

use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

use skin_protocol::frame::Kind;
use skin_protocol::interface::{Datagram, MAX_DATAGRAM};
use skin_protocol::robot_link::{self, FromRobot, Refusal, ToRobot};
use skin_sim::endpoint::{Batching, Endpoint, EndpointConfig, Pacing, Running, Served};
use skin_sim::network::host::Host;
use skin_sim::network::NetworkConfig;

/// An endpoint on loopback in lockstep, sending the skin's datagrams to `host`.
fn lockstep(host: SocketAddr) -> EndpointConfig {
    EndpointConfig {
        robot: "127.0.0.1:0".parse().unwrap(),
        host,
        pacing: Pacing::Lockstep,
        batching: Batching::default(),
        network: NetworkConfig::default(),
    }
}

fn ask(robot: &UdpSocket, to: SocketAddr, request: &ToRobot) -> FromRobot {
    let mut buf = [0u8; robot_link::MAX_DATAGRAM];
    let n = robot_link::encode(request, &mut buf).unwrap();
    robot.send_to(&buf[..n], to).unwrap();
    let (n, _) = robot.recv_from(&mut buf).expect("the endpoint answers");
    robot_link::decode(&buf[..n]).unwrap()
}

fn command(seq: u32, velocities: &[f64]) -> ToRobot {
    ToRobot::Command { seq, velocities: velocities.iter().copied().collect() }
}

#[test]
fn a_bare_host_organizes_the_skin_and_moves_the_robot_in_lockstep() {
    let interface = UdpSocket::bind("127.0.0.1:0").unwrap();
    interface.set_nonblocking(true).unwrap();
    let config = lockstep(interface.local_addr().unwrap());
    let running = Running::spawn(move || Endpoint::hrp2(3, config)).unwrap();
    let (robot_addr, ports) = (running.robot, running.interfaces.clone());
    assert_eq!(ports.len(), 5, "the five interface ports of HRP-2");

    let robot = UdpSocket::bind("127.0.0.1:0").unwrap();
    robot.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let FromRobot::Info { dofs, period_us, lockstep } = ask(&robot, robot_addr, &ToRobot::Hello) else {
        panic!("hello is answered with info")
    };
    assert_eq!((dofs, period_us, lockstep), (14, 4000, true));
    let FromRobot::DofName { index: 3, name } = ask(&robot, robot_addr, &ToRobot::DofName { index: 3 }) else {
        panic!("a name")
    };
    assert_eq!(name.as_str(), "RARM_JOINT3");
    assert!(matches!(
        ask(&robot, robot_addr, &ToRobot::DofName { index: 14 }),
        FromRobot::Refused { reason: Refusal::NoSuchDof, .. }
    ));
    assert!(matches!(
        ask(&robot, robot_addr, &command(1, &[0.0; 3])),
        FromRobot::Refused { seq: 1, reason: Refusal::WrongLength }
    ));
    let mut nan = [0.0; 14];
    nan[5] = f64::NAN;
    assert!(matches!(
        ask(&robot, robot_addr, &command(1, &nan)),
        FromRobot::Refused { reason: Refusal::NotFinite, .. }
    ));
    robot.send_to(b"not a request", robot_addr).unwrap();

    // One second of robot time: the elbow turns at 0.5 rad/s while the
    // bare host hands out IDs.
    let mut host = Host::new();
    let mut buf = [0u8; MAX_DATAGRAM + 1];
    let (mut samples, mut first_time_us, mut last) = (0usize, None, None);
    let mut velocities = [0.0; 14];
    velocities[3] = 0.5;
    for seq in 1..=250u32 {
        let FromRobot::State { seq: s, time_us, positions } = ask(&robot, robot_addr, &command(seq, &velocities))
        else {
            panic!("a command is answered with feedback")
        };
        assert_eq!(s, seq);
        first_time_us.get_or_insert(time_us);
        last = Some((time_us, positions));
        while let Ok((n, from)) = interface.recv_from(&mut buf) {
            let d = Datagram::parse(&buf[..n]).expect("the skin sends datagrams");
            assert_eq!(from, ports[usize::from(d.header().interface)], "each port sends from its own socket");
            samples += d.frames().filter(|f| f.as_ref().is_ok_and(|f| f.kind() == Kind::Sample)).count();
            for reply in host.receive(&buf[..n]) {
                interface.send_to(&reply, from).unwrap();
            }
        }
    }
    let (time_us, positions) = last.unwrap();
    assert_eq!((first_time_us, time_us), (Some(4000), 1_000_000), "one period per command");
    let home = skin_model::robot::hrp2::robot().home()[3];
    assert!((positions[3] - home - 0.5).abs() < 0.02, "the elbow moved {} rad", positions[3] - home);
    // A retry of the last command is answered again without moving.
    let again = ask(&robot, robot_addr, &command(250, &velocities));
    assert!(matches!(again, FromRobot::State { time_us: 1_000_000, .. }));

    let truth = running.stop().unwrap();
    let ids = truth.ids;
    let mut unique = ids.clone();
    unique.sort_unstable();
    unique.dedup();
    assert!(ids.iter().all(|a| a.is_cell()) && unique.len() == 74, "all 74 cells have unique IDs");
    assert!(samples > 74 * 100, "{samples} samples reached the host");
    let Served { ticks, rejected, refused, datagrams_up, .. } = truth.served;
    assert_eq!((ticks, rejected, refused), (250, 1, 2));
    assert!(datagrams_up > 0);
    for (id, table) in &truth.neighbours {
        assert_eq!(host.table(*id), Some(table), "{id} reported its true neighbours");
    }
    let frames: u64 = truth.latency_us.iter().map(|(_, n)| n).sum();
    assert!(frames as usize >= samples, "every sample delivered has a latency");
}

#[test]
fn addresses_beyond_this_machine_are_refused() {
    let config = lockstep("192.0.2.1:7700".parse().unwrap());
    let e = Endpoint::hrp2(0, config).err().expect("a host off this machine is refused");
    assert!(e.to_string().contains("127.0.0.1"), "{e}");
}

#[test]
fn any_bytes_on_the_robot_link_are_counted_and_change_nothing() {
    use rand::{Rng, SeedableRng};
    let config = lockstep("127.0.0.1:9".parse().unwrap());
    let running = Running::spawn(move || Endpoint::hrp2(0, config)).unwrap();
    let robot = UdpSocket::bind("127.0.0.1:0").unwrap();
    robot.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut garbage = 0;
    for k in 0..500 {
        // A question now and then keeps the endpoint's receive buffer from overflowing.
        if k % 20 == 0 {
            assert!(matches!(ask(&robot, running.robot, &ToRobot::Hello), FromRobot::Info { dofs: 14, .. }));
        }
        let len = rng.random_range(0..600);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.random()).collect();
        // Half of them with a valid header, so the body decoder is exercised too.
        if rng.random() && len >= 3 {
            bytes[..3].copy_from_slice(&[b'R', b'L', robot_link::VERSION]);
        }
        if robot_link::decode::<ToRobot>(&bytes).is_err() {
            garbage += 1;
            robot.send_to(&bytes, running.robot).unwrap();
        }
    }
    // Another host is refused while the first one is talking; a host that
    // starts over on a new socket once the first fell silent is served.
    let again = UdpSocket::bind("127.0.0.1:0").unwrap();
    again.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    assert!(matches!(ask(&again, running.robot, &ToRobot::Hello), FromRobot::Refused { reason: Refusal::Busy, .. }));
    std::thread::sleep(Duration::from_millis(2100));
    assert!(matches!(ask(&again, running.robot, &ToRobot::Hello), FromRobot::Info { dofs: 14, .. }));
    let truth = running.stop().unwrap();
    assert_eq!((truth.served.rejected, truth.served.ticks, truth.served.other_hosts), (garbage, 0, 1));
}
