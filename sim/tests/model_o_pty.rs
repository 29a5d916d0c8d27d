//! The Model O hand backend (dynamixel2 on a serial port) against the simulated hand served
//! as a Dynamixel Protocol 2.0 bus on a pseudo-terminal.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::Hand;
use tmo_sim::serve::dynamixel::PtyServoBus;
use tmo_sim::serve::{serve, ServedDevices};
use tmo_sim::{SimConfig, SimRig};

fn config(port: String) -> ModelOConfig {
    ModelOConfig {
        port,
        baud: 57600,
        ids: [1, 2, 3, 4],
        min: [1200, 1150, 2900, 2048],
        max: [2900, 2850, 1200, 2600],
        current_limit_ma: 300,
    }
}

#[test]
fn the_hand_backend_drives_the_served_simulated_fingers() {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let flag = stop.clone();
    let server = std::thread::spawn(move || {
        let rig = SimRig::new(SimConfig::default()).unwrap();
        let bus = PtyServoBus::open(rig.hand(), config(String::new())).unwrap();
        tx.send(bus.path.clone()).unwrap();
        let mut devices = ServedDevices {
            bus: Some(bus),
            ..Default::default()
        };
        serve(&rig, &mut devices, &flag).unwrap();
        devices.bus.unwrap().stats
    });
    let path = rx.recv().unwrap();
    let mut hand = ModelOHand::open(config(path.display().to_string())).unwrap();
    hand.set_targets([0.3, 0.3, 0.3, 0.0]).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut q = [0.0; 4];
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
        q = hand.present_positions().unwrap();
        if q[..3].iter().all(|v| (v - 0.3).abs() < 2e-3) {
            break;
        }
    }
    // one encoder count is 1/1700 of the range
    assert!(q[..3].iter().all(|v| (v - 0.3).abs() < 2e-3), "{q:?}");
    hand.set_torque_limit(0.5).unwrap();
    stop.store(true, Ordering::Relaxed);
    let stats = server.join().unwrap();
    assert!(stats.goal_writes >= 4, "{stats:?}");
    assert_eq!(stats.unsupported, 0, "{stats:?}");
}
