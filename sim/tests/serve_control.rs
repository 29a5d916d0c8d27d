//! The served simulator's control port: a reset builds the next trial's world behind the
//! same served devices, and a world the served devices do not fit is refused with why.

use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::Hand;
use tmo_sim::serve::control::{ControlError, ControlPort, SimControlClient};
use tmo_sim::serve::dynamixel::PtyServoBus;
use tmo_sim::serve::{serve_controlled, PtyCamera, ServedDevices};
use tmo_sim::{HandSetup, RailSetup, RigSetup, SimConfig, SimRig};

fn bus_config(port: String) -> ModelOConfig {
    ModelOConfig {
        port,
        baud: 57600,
        ids: [1, 2, 3, 4],
        min: [1200, 1150, 2900, 2048],
        max: [2900, 2850, 1200, 2600],
        current_limit_ma: 300,
    }
}

fn hand_world(initial_closure: f64) -> SimConfig {
    SimConfig {
        rig: RigSetup::Hand(HandSetup {
            initial_closure,
            ..Default::default()
        }),
        ..SimConfig::default()
    }
}

fn settled_fingers(hand: &mut ModelOHand, to: f64) -> [f64; 4] {
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut q = hand.present_positions().unwrap();
    while Instant::now() < deadline && q[..3].iter().any(|v| (v - to).abs() > 2e-3) {
        std::thread::sleep(Duration::from_millis(20));
        q = hand.present_positions().unwrap();
    }
    q
}

#[test]
fn a_reset_sets_the_next_world_up_behind_the_same_devices() {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let flag = stop.clone();
    let server = std::thread::spawn(move || {
        let rig = SimRig::new(hand_world(0.1)).unwrap();
        let bus = PtyServoBus::open(rig.hand(), bus_config(String::new())).unwrap();
        let cameras = rig
            .tactile_sensors()
            .into_iter()
            .map(|s| PtyCamera::open(s, "pins").unwrap())
            .collect();
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let mut control = ControlPort::new(listener).unwrap();
        tx.send((bus.path.clone(), addr)).unwrap();
        let mut devices = ServedDevices {
            bus: Some(bus),
            cameras,
            ..Default::default()
        };
        serve_controlled(&rig, &mut devices, Some(&mut control), None, &flag).unwrap();
        control.resets
    });
    let (path, addr) = rx.recv().unwrap();
    let mut hand = ModelOHand::open(bus_config(path.display().to_string())).unwrap();
    assert!((settled_fingers(&mut hand, 0.1)[0] - 0.1).abs() < 2e-3);
    hand.set_targets([0.3, 0.3, 0.3, 0.0]).unwrap();
    assert!((settled_fingers(&mut hand, 0.3)[0] - 0.3).abs() < 2e-3);

    let mut control = SimControlClient::connect(&addr).unwrap();
    control.reset(&hand_world(0.05)).unwrap();
    // the new world's fingers stand where it starts them, read over the same bus
    let q = hand.present_positions().unwrap();
    assert!(q[..3].iter().all(|v| (v - 0.05).abs() < 2e-3), "{q:?}");
    // and the bus drives them as before
    hand.set_targets([0.2, 0.2, 0.2, 0.0]).unwrap();
    assert!((settled_fingers(&mut hand, 0.2)[0] - 0.2).abs() < 2e-3);

    // the rail rig has one fingertip; three cameras are served here
    let rail = SimConfig {
        rig: RigSetup::Rail(RailSetup::default()),
        ..SimConfig::default()
    };
    match control.reset(&rail) {
        Err(ControlError::Refused(why)) => assert!(why.contains("--rig"), "{why}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    // nonsense physics is refused with the field that is wrong
    let mut heavy = hand_world(0.1);
    heavy.physics.gravity_m_s2 = 1e300;
    match control.reset(&heavy) {
        Err(ControlError::Refused(why)) => assert!(why.contains("physics.gravity_m_s2"), "{why}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    stop.store(true, Ordering::Relaxed);
    assert_eq!(server.join().unwrap(), 1);
}

#[test]
fn a_garbled_request_is_answered_with_why_and_the_port_serves_on() {
    use std::io::{BufRead, BufReader, Write};
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let mut port = ControlPort::new(listener).unwrap();
    let client = std::thread::spawn(move || {
        let mut raw = std::net::TcpStream::connect(&addr).unwrap();
        raw.write_all(b"hello\n").unwrap();
        let mut answer = String::new();
        BufReader::new(raw).read_line(&mut answer).unwrap();
        let mut control = SimControlClient::connect(&addr).unwrap();
        (answer, control.reset(&hand_world(0.1)))
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    let config = loop {
        assert!(Instant::now() < deadline, "no reset arrived");
        if let Some((k, config)) = port.poll().unwrap() {
            port.answer(k, Ok(())).unwrap();
            break config;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let (answer, reset) = client.join().unwrap();
    assert!(
        answer.contains("\"error\"") && answer.contains("reset"),
        "{answer}"
    );
    reset.unwrap();
    assert_eq!(config, hand_world(0.1));
    assert_eq!(port.resets, 1);
}

/// Issue 41, S-a: a client that sends and never reads its answers used to freeze the serve
/// loop once its socket filled (the answers were written blocking). Now it is dropped, and
/// another client's reset is answered meanwhile.
#[test]
fn a_client_that_never_reads_stops_nobody() {
    use std::io::Write;
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let mut port = ControlPort::new(listener).unwrap();
    let flooder_addr = addr.clone();
    // garbled requests as fast as the socket takes them, answers never read
    let flooder = std::thread::spawn(move || {
        let mut raw = std::net::TcpStream::connect(&flooder_addr).unwrap();
        let lines = b"x\n".repeat(4096);
        let started = Instant::now();
        while started.elapsed() < Duration::from_secs(20) {
            if raw.write_all(&lines).is_err() {
                return true; // dropped by the server
            }
        }
        false
    });
    let resetter = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(500));
        let mut control = SimControlClient::connect(&addr).unwrap();
        control.reset(&hand_world(0.1))
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut answered = false;
    while !(answered && flooder.is_finished()) {
        assert!(Instant::now() < deadline, "the serve loop stalled");
        if let Some((k, _)) = port.poll().unwrap() {
            port.answer(k, Ok(())).unwrap();
            answered = true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    resetter.join().unwrap().unwrap();
    assert!(
        flooder.join().unwrap(),
        "the flooding client was not dropped"
    );
}
