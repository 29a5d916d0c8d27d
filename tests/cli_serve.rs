//! `tmo sim serve` in its own process, driven through the real backends' code (the
//! cameras and the hand bus over pseudo-terminals, the UR controller over loopback TCP),
//! from the hardware file it wrote.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::marker_camera::MarkerCamera;
use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::real::ur::UrArm;
use tmo_hal::{Arm, Hand, MarkerTracker, TactileSensor};

/// Kills the server however the test ends.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_real_backends_drive_the_served_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let served = dir.path().join("served.toml");
    let hw = Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    let _server = Server(
        Command::new(env!("CARGO_BIN_EXE_tmo"))
            .args(["sim", "serve", "--hardware"])
            .arg(&hw)
            .arg("--out")
            .arg(&served)
            .args(["--for", "60"])
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let deadline = Instant::now() + Duration::from_secs(20);
    while !served.exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let hw = tmo::hardware::load(&served).unwrap();
    let clock = RealClock::new();

    let mut cameras: Vec<JevoisSensor> = hw
        .cameras
        .fingertips
        .iter()
        .enumerate()
        .map(|(k, c)| {
            JevoisSensor::open(&c.port, c.baud, k as u8, hw.cameras.pins, 1.0, clock).unwrap()
        })
        .collect();
    let m = &hw.marker_camera;
    let mut markers = MarkerCamera::open(
        &m.port,
        m.baud,
        &m.object_marker,
        &m.hand_marker,
        1.0,
        clock,
    )
    .unwrap();
    let mut hand = ModelOHand::open(ModelOConfig {
        port: hw.hand.port.clone(),
        baud: hw.hand.baud,
        ids: hw.hand.ids,
        min: hw.hand.min,
        max: hw.hand.max,
        current_limit_ma: hw.hand.current_limit_ma,
    })
    .unwrap();
    let mut arm = UrArm::connect(
        &hw.arm.host,
        hw.arm.rtde_port,
        hw.arm.script_port,
        f64::from(hw.arm.frequency_hz),
    )
    .unwrap();

    let z0 = arm.tcp_pose().unwrap().position_mm[2];
    hand.set_targets([0.3, 0.3, 0.3, 0.0]).unwrap();
    arm.move_linear([0.0, 0.0, 5.0], 50.0).unwrap();
    let (mut frames, mut samples, mut z) = ([0usize; 3], 0usize, z0);
    let until = Instant::now() + Duration::from_secs(10);
    while Instant::now() < until {
        for (k, c) in cameras.iter_mut().enumerate() {
            while c.next_frame().unwrap().is_some() {
                frames[k] += 1;
            }
        }
        while markers.next_sample().unwrap().is_some() {
            samples += 1;
        }
        z = arm.tcp_pose().unwrap().position_mm[2];
        let q = hand.present_positions().unwrap();
        let done = (z - z0 - 5.0).abs() < 0.05
            && q[..3].iter().all(|v| (v - 0.3).abs() < 2e-3)
            && frames.iter().all(|&n| n >= 20)
            && samples >= 20;
        if done {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!((z - z0 - 5.0).abs() < 0.05, "arm at {z}, from {z0}");
    assert!(frames.iter().all(|&n| n >= 20), "{frames:?}");
    assert!(samples >= 20, "{samples} marker samples");
    let q = hand.present_positions().unwrap();
    assert!(q[..3].iter().all(|v| (v - 0.3).abs() < 2e-3), "{q:?}");
}
