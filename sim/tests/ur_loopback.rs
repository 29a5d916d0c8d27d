//! The UR arm backend against the simulated arm served as a UR controller on loopback:
//! RTDE negotiation, state streaming, and URScript moves that the simulated arm follows.

use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use tmo_hal::real::ur::{UrArm, UrError};
use tmo_hal::Arm;
use tmo_sim::serve::ur::CONTROLLER_VERSION;
use tmo_sim::serve::{serve_ur, UrServeStats};
use tmo_sim::{SimConfig, SimRig};

type Served = (
    u16,
    u16,
    Arc<AtomicBool>,
    std::thread::JoinHandle<UrServeStats>,
);

fn serve() -> Served {
    serve_at(0, 0)
}

/// A controller on these ports (0: any free ones).
fn serve_at(rtde_port: u16, script_port: u16) -> Served {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let flag = stop.clone();
    let server = std::thread::spawn(move || {
        let rig = SimRig::new(SimConfig::default()).unwrap();
        let rtde = TcpListener::bind(("127.0.0.1", rtde_port)).unwrap();
        let script = TcpListener::bind(("127.0.0.1", script_port)).unwrap();
        tx.send((
            rtde.local_addr().unwrap().port(),
            script.local_addr().unwrap().port(),
        ))
        .unwrap();
        serve_ur(&rig, rtde, script, &flag).unwrap()
    });
    let (r, s) = rx.recv().unwrap();
    (r, s, stop, server)
}

/// The first error reading the arm's pose within 3 s.
fn first_error(arm: &mut UrArm) -> Option<UrError> {
    let deadline = Instant::now() + Duration::from_secs(3);
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
        if let Err(e) = arm.tcp_pose() {
            return Some(e);
        }
    }
    None
}

#[test]
fn the_arm_backend_drives_the_served_simulated_arm() {
    let (rtde_port, script_port, stop, server) = serve();
    let mut arm = UrArm::connect("127.0.0.1", rtde_port, script_port, 125.0).unwrap();
    let start = arm.tcp_pose().unwrap().position_mm;
    assert!(
        (start[2] - SimConfig::default().arm.start_mm[2]).abs() < 1e-6,
        "{start:?}"
    );

    arm.move_linear([0.0, 0.0, 10.0], 50.0).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut z = start[2];
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
        z = arm.tcp_pose().unwrap().position_mm[2];
        if (z - (start[2] + 10.0)).abs() < 0.05 {
            break;
        }
    }
    // the controller's own accelerations may overshoot by a few micrometres
    assert!((z - (start[2] + 10.0)).abs() < 0.05, "reached {z}");
    arm.stop().unwrap();
    // let the server read the last line before it stops
    std::thread::sleep(Duration::from_millis(100));
    drop(arm);
    stop.store(true, Ordering::Relaxed);
    let stats = server.join().unwrap();
    assert_eq!((stats.rtde_clients, stats.script_clients), (1, 1));
    assert!(stats.data_packages > 10, "{stats:?}");
    assert_eq!(stats.script_lines, 2, "movel and stopl");
    assert_eq!(stats.script_errors, 0);
    assert_eq!(CONTROLLER_VERSION.0, 3);
}

#[test]
fn a_server_that_goes_away_is_an_error_of_the_next_call() {
    let (rtde_port, script_port, stop, server) = serve();
    let mut arm = UrArm::connect("127.0.0.1", rtde_port, script_port, 125.0).unwrap();
    arm.tcp_pose().unwrap();
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
    // the listener and connections are gone: state stops, then reads fail
    let e = first_error(&mut arm).expect("an error once the controller is gone");
    assert_eq!(
        tmo_hal::Error::kind(&e),
        tmo_hal::ErrorKind::Disconnected,
        "{e}"
    );
}

/// A controller that restarts: the call that meets the lost connection fails; the next one
/// reconnects, stops the arm first, then does its work.
#[test]
fn after_a_lost_connection_the_next_call_reconnects_and_stops_the_arm_first() {
    let (rtde_port, script_port, stop, server) = serve();
    let mut arm = UrArm::connect("127.0.0.1", rtde_port, script_port, 125.0).unwrap();
    arm.tcp_pose().unwrap();
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
    first_error(&mut arm).expect("an error once the controller is gone");
    assert_eq!(arm.reconnects, 0);
    // the controller comes back on its ports
    let (_, _, stop, server) = serve_at(rtde_port, script_port);
    let pose = arm.tcp_pose().expect("reconnected");
    assert!((pose.position_mm[2] - SimConfig::default().arm.start_mm[2]).abs() < 1e-6);
    assert_eq!(arm.reconnects, 1);
    arm.move_linear([0.0, 0.0, 5.0], 50.0).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    drop(arm);
    stop.store(true, Ordering::Relaxed);
    let stats = server.join().unwrap();
    assert_eq!((stats.rtde_clients, stats.script_clients), (1, 1));
    assert_eq!(
        stats.script_lines, 2,
        "stopl on reconnecting, then the movel"
    );
    assert_eq!(stats.script_errors, 0);
}

/// After a move the host did not watch, the next move starts from where the arm is now,
/// not from the state the socket had buffered before.
#[test]
fn moves_start_from_the_newest_state_not_a_buffered_one() {
    let (rtde_port, script_port, stop, server) = serve();
    let mut arm = UrArm::connect("127.0.0.1", rtde_port, script_port, 125.0).unwrap();
    let start = arm.tcp_pose().unwrap().position_mm[2];
    arm.move_linear([0.0, 0.0, 10.0], 50.0).unwrap();
    std::thread::sleep(Duration::from_millis(800)); // unwatched: state piles up in the socket
    arm.move_linear([0.0, 0.0, 10.0], 50.0).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut z = start;
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
        z = arm.tcp_pose().unwrap().position_mm[2];
        if (z - (start + 20.0)).abs() < 0.05 {
            break;
        }
    }
    assert!(
        (z - (start + 20.0)).abs() < 0.05,
        "ended at {z}, started at {start}"
    );
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
}

#[test]
fn a_script_line_with_no_end_is_refused_not_buffered() {
    use std::io::{Read, Write};
    let (_, script_port, stop, server) = serve();
    let mut raw = std::net::TcpStream::connect(("127.0.0.1", script_port)).unwrap();
    raw.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    // 4 MB without a newline: the controller drops the client after its line limit
    let chunk = vec![b'x'; 64 * 1024];
    let mut sent = 0usize;
    for _ in 0..64 {
        match raw.write_all(&chunk) {
            Ok(()) => sent += chunk.len(),
            Err(_) => break,
        }
    }
    let mut buf = [0u8; 16];
    let closed = match raw.read(&mut buf) {
        Ok(0) => true,
        Err(e) => e.kind() == std::io::ErrorKind::ConnectionReset,
        Ok(_) => false,
    };
    assert!(closed, "the controller kept a line of {sent} bytes open");
    stop.store(true, Ordering::Relaxed);
    let stats = server.join().unwrap();
    assert_eq!(stats.script_lines, 0);
    assert!(stats.script_errors >= 1);
}
