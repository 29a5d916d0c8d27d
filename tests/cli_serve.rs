//! `tmo sim serve` in its own process, driven through the real backends' code (the
//! cameras and the hand bus over pseudo-terminals, the UR controller over loopback TCP),
//! from the hardware file it wrote.

mod common;

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
            JevoisSensor::open(&c.port, c.baud, k as u8, hw.cameras.pins, 5.0, clock).unwrap()
        })
        .collect();
    let m = &hw.marker_camera;
    let mut markers = MarkerCamera::open(
        &m.port,
        m.baud,
        &m.object_marker,
        &m.hand_marker,
        5.0,
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

/// `tmo run --backend real` against `tmo sim serve`: the lift protocols end as they began, so
/// they run trial after trial unattended and are scored by the same code as on the sim.
#[test]
fn lift_protocols_run_on_the_real_backend_against_the_served_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tmo = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_tmo"))
            .current_dir(d)
            .args(args)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned()
                + &String::from_utf8_lossy(&out.stderr),
        )
    };
    let ok = |args: &[&str]| {
        let (code, text) = tmo(args);
        assert_eq!(code, Some(0), "{args:?}: {text}");
        text
    };
    common::collect_and_train(d, &["--trials", "8", "--seed", "5"], "train", "global.json");
    let hw = Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    let _server = Server(
        Command::new(env!("CARGO_BIN_EXE_tmo"))
            .current_dir(d)
            .args(["sim", "serve", "--hardware"])
            .arg(&hw)
            .args(["--out", "served.toml", "--for", "120"])
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let deadline = Instant::now() + Duration::from_secs(20);
    while !d.join("served.toml").exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    // A loaded CI machine can starve the emulator's real-time loop for a few hundred ms,
    // which real cameras do not do; give the watchdog room.
    let served = std::fs::read_to_string(d.join("served.toml")).unwrap();
    std::fs::write(
        d.join("served.toml"),
        served.replace("silent_limit_s = 0.25", "silent_limit_s = 2.0"),
    )
    .unwrap();
    let quick = "lift_height_mm = 20\nlift_speed_mm_s = 40\nhold_s = 0.5\nmasses_g = [0]\n";
    std::fs::write(
        d.join("cal.toml"),
        format!("kind = \"calibrate_lift\"\nobjects = [\"crisps_can\"]\n[calibrate_lift]\n{quick}"),
    )
    .unwrap();
    let out = ok(&[
        "run",
        "cal.toml",
        "--backend",
        "real",
        "--hardware",
        "served.toml",
        "--out",
        "cal",
    ]);
    assert!(out.contains("g_min.json"), "{out}");
    std::fs::write(
        d.join("lift.toml"),
        format!("kind = \"first_time_lift\"\nobjects = [\"crisps_can\"]\nmodels = [\"global.json\"]\nrepetitions = 2\n[first_time_lift]\n{quick}calibration = \"cal/g_min.json\"\n"),
    )
    .unwrap();
    ok(&[
        "run",
        "lift.toml",
        "--backend",
        "real",
        "--hardware",
        "served.toml",
        "--out",
        "lift",
    ]);
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(d.join("lift/outcomes.json")).unwrap())
            .unwrap();
    assert_eq!(rows.len(), 2);
    assert!(
        rows.iter()
            .all(|r| r["success"] == true && r["fault"].is_null()),
        "{rows:?}"
    );
    let trial = tmo::trial::read_trial(&d.join("lift/trial-00000.mcap")).unwrap();
    assert_eq!(trial.meta.backend, "real");
    assert!(trial.frames.len() > 100 && trial.markers.len() > 50);
    // the other kinds need the object put back by hand: refused, clearly
    std::fs::write(
        d.join("rail.toml"),
        "kind = \"rail_catch\"\nmodels = [\"global.json\"]\nstrategies = [\"1x1\"]\n",
    )
    .unwrap();
    let (code, text) = tmo(&[
        "run",
        "rail.toml",
        "--backend",
        "real",
        "--hardware",
        "served.toml",
        "--out",
        "rail",
    ]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("put back between trials"), "{text}");
}
