//! Issue 41: a stuck or malicious client of `tmo sim serve` (its control port) or of the
//! live view changes no other client's frame rate by more than 5 %. Each test measures a
//! well-behaved client's frames per second alone, then with the bad client beside it.
//! A phase lasts `TMO_STUCK_CLIENT_S` seconds (default 6, for CI; the five-minute
//! run is `TMO_STUCK_CLIENT_S=300 cargo test --release --test stuck_clients`).

mod common;

use std::io::Write;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::TactileSensor;
use tungstenite::Message;

fn phase() -> Duration {
    let s = std::env::var("TMO_STUCK_CLIENT_S")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(6.0);
    Duration::from_secs_f64(s)
}

/// The largest change of the good client's rate the bad one may cause.
const TOLERANCE: f64 = 0.05;

fn serve(d: &Path, extra: &[&str]) -> Child {
    let hw = Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    let lifetime = (3.0 * phase().as_secs_f64() + 60.0).to_string();
    Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["sim", "serve", "--hardware"])
        .arg(&hw)
        .args(["--out", "served.toml", "--for", &lifetime])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn check(alone: f64, beside: f64, what: &str) {
    assert!(alone > 30.0, "{what}: {alone:.1} frames/s alone");
    let change = (beside - alone).abs() / alone;
    assert!(
        change <= TOLERANCE,
        "{what}: {alone:.2} frames/s alone, {beside:.2} beside the stuck client ({:.1} %)",
        100.0 * change
    );
    eprintln!(
        "{what}: {alone:.2} frames/s alone, {beside:.2} beside the stuck client over {:?} each ({:+.2} %)",
        phase(),
        100.0 * (beside - alone) / alone
    );
}

type Ws = tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<std::net::TcpStream>>;

/// Waits for the advertisement and subscribes to `topics` (all channels if empty).
fn subscribe(ws: &mut Ws, topics: &[&str]) {
    loop {
        let Message::Text(text) = ws.read().unwrap() else {
            continue;
        };
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        if v["op"] != "advertise" {
            continue;
        }
        let subscriptions: Vec<serde_json::Value> = v["channels"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| topics.is_empty() || topics.iter().any(|t| c["topic"] == *t))
            .enumerate()
            .map(|(k, c)| serde_json::json!({"id": k + 1, "channelId": c["id"]}))
            .collect();
        let subscribe = serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
        ws.send(Message::text(subscribe.to_string())).unwrap();
        return;
    }
}

/// Message-data frames per second `ws` receives over `span`.
fn rate(ws: &mut Ws, span: Duration) -> f64 {
    let started = Instant::now();
    let mut n = 0u64;
    while started.elapsed() < span {
        match ws.read() {
            Ok(Message::Binary(b)) if b.first() == Some(&1) => n += 1,
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) => panic!("the good viewer lost its connection: {e}"),
        }
    }
    n as f64 / started.elapsed().as_secs_f64()
}

/// A viewer that subscribes to every channel and then never reads: the server's queue for
/// it fills, and the SDK must drop its messages (or it) rather than hold up the others.
#[test]
fn a_stuck_live_viewer_slows_no_other_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = serve(dir.path(), &["--live", "127.0.0.1:0"]);
    let url = common::live::address(&mut child);
    let mut good = common::live::connect(&url, "foxglove.sdk.v1").unwrap();
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = good.get_ref() {
        s.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
    }
    subscribe(&mut good, &["/tactile/0"]);
    rate(&mut good, Duration::from_secs(1));
    let alone = rate(&mut good, phase());
    let mut stuck = common::live::connect(&url, "foxglove.sdk.v1").unwrap();
    subscribe(&mut stuck, &[]);
    let beside = rate(&mut good, phase());
    drop(stuck);
    child.kill().unwrap();
    child.wait().unwrap();
    check(alone, beside, "live view, /tactile/0");
}

/// A control-port client that floods garbled requests and never reads the answers: the
/// served cameras' frames to the rig's own reader keep their rate.
#[test]
fn a_stuck_control_client_slows_no_camera() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = serve(d, &[]);
    let deadline = Instant::now() + Duration::from_secs(20);
    while !d.join("served.toml").exists() {
        assert!(Instant::now() < deadline, "no served hardware file");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(200));
    let hw = tmo::runner::hardware::load(&d.join("served.toml")).unwrap();
    let cam = &hw.cameras.fingertips[0];
    let mut sensor = JevoisSensor::open(
        &cam.port,
        cam.baud,
        0,
        hw.cameras.pins,
        5.0,
        RealClock::new(),
    )
    .unwrap();
    let frames_per_s = |sensor: &mut JevoisSensor, span: Duration| {
        let started = Instant::now();
        let mut n = 0u64;
        while started.elapsed() < span {
            match sensor.next_frame().unwrap() {
                Some(_) => n += 1,
                None => std::thread::sleep(Duration::from_millis(1)),
            }
        }
        n as f64 / started.elapsed().as_secs_f64()
    };
    frames_per_s(&mut sensor, Duration::from_secs(1));
    let alone = frames_per_s(&mut sensor, phase());
    let control = hw.served_simulator.unwrap().control;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flooding = stop.clone();
    let flooder = std::thread::spawn(move || {
        let mut raw = std::net::TcpStream::connect(&control).unwrap();
        let lines = b"x\n".repeat(4096);
        let mut dropped = false;
        while !flooding.load(std::sync::atomic::Ordering::Relaxed) {
            if raw.write_all(&lines).is_err() {
                // dropped by the server: connect again and go on
                dropped = true;
                match std::net::TcpStream::connect(&control) {
                    Ok(again) => raw = again,
                    Err(_) => std::thread::sleep(Duration::from_millis(10)),
                }
            }
        }
        dropped
    });
    let beside = frames_per_s(&mut sensor, phase());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let dropped = flooder.join().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    check(alone, beside, "served camera 0");
    assert!(dropped, "the flooding client was never dropped");
}
