//! Latency through the real backend: from the last byte of a slipping fingertip frame
//! arriving at the host (written into the camera's pseudo-terminal) to the first byte of
//! the resulting hand command leaving it (readable on the servo bus's pseudo-terminal).
//!
//! The host side is the production code: `JevoisSensor` (reader thread, line parser),
//! `FrameMonitor` (classification and a 1Fr1Sen detector) polled on the runners' 1 kHz
//! tick or as a frame arrives, and `ModelOHand` (dynamixel2 sync write). The devices are
//! played by this program: a camera streaming still frames at 60 fps with one slipping frame
//! at a random moment, and a servo bus answering the hand's start-up and timing the sync
//! write.
//!
//! Run: `cargo bench --bench backend_latency` (prints median and p99 over the trials, for the
//! runner's wait, which wakes on a frame's arrival, and for the previous runner's, which
//! slept the whole 1 kHz tick, in the same run), and for the runner now with its live view
//! serving every frame and event to a connected viewer that reads slowly (`tmo run --live`).
//! `TICK_US=100` shortens the control tick. `LATENCY_MODEL=tests/fixtures/onnx/svm_rbf.onnx`
//! runs the loop with that model (any model of 30 pins that calls the bench's uniform 2 px
//! shift slip and its still frames static) instead of the threshold model.

use std::fs::File;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use tmo::online::strategy::Strategy;
use tmo::runner::monitor::{FrameMonitor, Verdict, WatchLimits};
use tmo::runner::Online;
use tmo::slip::model::ModelFile;
use tmo::slip::slip_model::SlipModel;
use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::wire::dynamixel::{instruction, Decoder, Packet};
use tmo_hal::wire::jevois::format_fine2;
use tmo_hal::{Clock, Hand, TactileSensor};
use tmo_sim::serve::open_pty;

const PINS: usize = 30;
const TRIALS: usize = 200;
/// How long the slow viewer takes over each message it reads, ms.
const VIEWER_MS: u64 = 20;

fn model() -> SlipModel {
    match std::env::var("LATENCY_MODEL") {
        Ok(path) => SlipModel::load(std::path::Path::new(&path)).expect("LATENCY_MODEL loads"),
        Err(_) => ModelFile::threshold_model(PINS, vec![0], 0.5).into(),
    }
}

fn pins(shift: f32, jitter: f32) -> Vec<[f32; 2]> {
    (0..PINS)
        .map(|i| [40.0 + 10.0 * i as f32 + shift, 100.0 + jitter])
        .collect()
}

/// The servo bus: answers the hand's start-up, then reports when each sync write's first
/// byte could be read.
fn servo_bus(mut master: File, written: mpsc::Sender<Instant>, stop: Arc<AtomicBool>) {
    let mut decoder = Decoder::default();
    let mut buf = [0u8; 512];
    let mut in_packet = false;
    while !stop.load(Ordering::Relaxed) {
        match master.read(&mut buf) {
            Ok(n) if n > 0 => {
                let now = Instant::now();
                if !in_packet {
                    in_packet = true;
                    // the first byte of whatever the host sent next
                    let _ = written.send(now);
                }
                for p in decoder.push(&buf[..n]) {
                    in_packet = false;
                    let reply = match p.instruction {
                        instruction::PING => Some(Packet::status(p.id, 0, &[0xFC, 0x03, 52])),
                        instruction::WRITE => Some(Packet::status(p.id, 0, &[])),
                        _ => None,
                    };
                    if let Some(r) = reply {
                        let _ = master.write_all(&r.encode());
                    }
                }
            }
            _ => std::thread::sleep(Duration::from_micros(50)),
        }
    }
}

/// How the host waits between control ticks.
#[derive(Clone, Copy, PartialEq)]
enum Wait {
    /// The previous runner: sleep the whole tick, then poll.
    Tick,
    /// The runner now: wake at the tick or as soon as a frame arrives.
    TickOrInput,
}

/// Latencies of `TRIALS` slips, us, sorted.
/// A viewer of the live view that subscribes to the thumb's pins and reads one message every
/// 20 ms, far slower than they come: the server must drop for it, never wait.
fn slow_viewer(url: String, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<usize> {
    use tungstenite::client::IntoClientRequest;
    std::thread::spawn(move || {
        let mut request = url.as_str().into_client_request().unwrap();
        request
            .headers_mut()
            .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
        let (mut ws, _) = tungstenite::connect(request).expect("viewer connects");
        let mut received = 0;
        while !stop.load(Ordering::Relaxed) {
            match ws.read() {
                Ok(tungstenite::Message::Text(t)) => {
                    let v: serde_json::Value = serde_json::from_str(&t).unwrap();
                    if v["op"] == "advertise" {
                        let subs: Vec<serde_json::Value> = v["channels"]
                            .as_array()
                            .unwrap()
                            .iter()
                            .map(|c| serde_json::json!({"id": c["id"], "channelId": c["id"]}))
                            .collect();
                        let msg = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                        ws.send(tungstenite::Message::text(msg.to_string()))
                            .unwrap();
                    }
                }
                Ok(tungstenite::Message::Binary(_)) => {
                    received += 1;
                    std::thread::sleep(Duration::from_millis(VIEWER_MS));
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
        received
    })
}

fn measure(wait: Wait, tick_s: f64, live: bool) -> Vec<f64> {
    let (mut camera, _camera_slave, camera_path) = open_pty().expect("camera pty");
    let (bus_master, _bus_slave, bus_path) = open_pty().expect("bus pty");
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, written) = mpsc::channel();
    let bus_stop = stop.clone();
    let bus = std::thread::spawn(move || servo_bus(bus_master, tx, bus_stop));

    let clock = RealClock::new();
    let mut hand = ModelOHand::open(ModelOConfig {
        port: bus_path.display().to_string(),
        baud: 1_000_000,
        ids: [1, 2, 3, 4],
        min: [1200, 1150, 2900, 2048],
        max: [2900, 2850, 1200, 2600],
        current_limit_ma: 300,
    })
    .expect("hand");
    let mut sensor = JevoisSensor::open(
        &camera_path.display().to_string(),
        115200,
        0,
        PINS,
        1.0,
        clock.clone(),
    )
    .expect("camera");
    // the start-up traffic's timestamps are not latencies
    std::thread::sleep(Duration::from_millis(50));
    while written.try_recv().is_ok() {}

    let model = model();
    let online = Online {
        model: &model,
        strategy: "1x1".parse::<Strategy>().unwrap(),
    };
    let mut mclock = clock;

    // The camera runs on its own clock, so slips arrive at any phase of the host's tick.
    let (slip_tx, slips) = mpsc::channel();
    let camera_stop = stop.clone();
    let camera_thread = std::thread::spawn(move || {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (mut shift, mut frame, mut next_slip) = (0.0f32, 0u64, rng.gen_range(5..15));
        let mut next = Instant::now();
        while !camera_stop.load(Ordering::Relaxed) {
            frame += 1;
            let slip = frame == next_slip;
            if slip {
                shift += 2.0;
                next_slip = frame + rng.gen_range(5..15);
            }
            let line = format_fine2(None, "pins", &pins(shift, 0.01 * (frame % 2) as f32));
            camera.write_all(line.as_bytes()).expect("camera write");
            if slip {
                let _ = slip_tx.send(Instant::now());
            }
            next += Duration::from_micros(16_667);
            std::thread::sleep(next.saturating_duration_since(Instant::now()));
        }
    });

    let view = live.then(|| tmo::live::LiveView::start("127.0.0.1:0".parse().unwrap(), 3).unwrap());
    let viewer = view.as_ref().map(|v| slow_viewer(v.url(), stop.clone()));
    let mut publisher = view.as_ref().map(|v| v.trial(0, false));
    let (mut frames, mut arrivals) = (Vec::new(), Vec::new());
    if viewer.is_some() {
        // the viewer connects and subscribes before the first slip counts
        std::thread::sleep(Duration::from_millis(200));
        while sensor.next_frame().expect("frame").is_some() {}
        while slips.try_recv().is_ok() {}
    }
    let never = AtomicBool::new(false);
    let mut monitor = FrameMonitor::new(1, Some(online), WatchLimits::default(), mclock.now_s());
    let mut events = Vec::new();
    let mut reactions = 0;
    while reactions < TRIALS {
        // the runners' control tick: the live view gets the last tick's data first
        if let Some(p) = &mut publisher {
            p.publish(mclock.now_s(), &frames, &arrivals, &[], &events);
        }
        match wait {
            Wait::Tick => mclock.sleep(tick_s),
            Wait::TickOrInput => {
                let next = mclock.now_s() + tick_s;
                mclock.wait_for_input_until(next);
            }
        }
        let mut batch = Vec::new();
        while let Some(f) = sensor.next_frame().expect("frame") {
            batch.push(f);
        }
        if publisher.is_some() {
            frames.extend(batch.iter().cloned());
            arrivals.extend(batch.iter().map(|_| mclock.now_s()));
        }
        match monitor.feed(&batch, mclock.now_s(), true, &never, &mut events) {
            Verdict::React(_) => {
                hand.set_targets([0.5, 0.5, 0.5, 0.0]).expect("hand");
                monitor.rearm();
                reactions += 1;
            }
            Verdict::Abort(f) => panic!("fault {f:?}"),
            Verdict::Continue => {}
        }
        if publisher.is_none() {
            events.clear();
        }
    }
    std::thread::sleep(Duration::from_millis(50));
    let sent: Vec<Instant> = slips.try_iter().collect();
    let out: Vec<Instant> = written.try_iter().collect();
    let mut latencies_us: Vec<f64> = sent
        .iter()
        .zip(&out)
        .map(|(t0, t1)| t1.saturating_duration_since(*t0).as_secs_f64() * 1e6)
        .collect();
    stop.store(true, Ordering::Relaxed);
    let _ = bus.join();
    let _ = camera_thread.join();
    if let Some(viewer) = viewer {
        // the server stops with the last handle on it; the viewer's read then ends
        drop(publisher);
        drop(view);
        let received = viewer.join().unwrap_or(0);
        println!(
            "  (the slow viewer read {received} of {} frames)",
            frames.len()
        );
    }
    latencies_us.sort_by(f64::total_cmp);
    latencies_us
}

const CONFIGS: [(Wait, bool, &str); 3] = [
    (Wait::Tick, false, "tick only (previous runner)"),
    (Wait::TickOrInput, false, "tick or input (runner now)"),
    (
        Wait::TickOrInput,
        true,
        "runner now, live view with a slow viewer",
    ),
];

fn main() {
    let tick_s = std::env::var("TICK_US")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(tmo::runner::TICK_S, |us| us * 1e-6);
    // Each configuration runs in a process of its own: a finished run's device threads
    // (pseudo-terminal readers) must not share the cores with the next run's.
    if let Some(k) = std::env::var("LATENCY_CONFIG")
        .ok()
        .and_then(|k| k.parse::<usize>().ok())
    {
        let (wait, live, _) = CONFIGS[k];
        let latencies_us = measure(wait, tick_s, live);
        let text: Vec<String> = latencies_us.iter().map(|l| l.to_string()).collect();
        println!("LATENCIES {}", text.join(" "));
        std::process::exit(0);
    }
    println!(
        "model: {}",
        std::env::var("LATENCY_MODEL").unwrap_or_else(|_| "threshold, 0.5 px per frame".into())
    );
    let mut medians = Vec::new();
    for (k, (_, _, name)) in CONFIGS.iter().enumerate() {
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .env("LATENCY_CONFIG", k.to_string())
            .output()
            .expect("the bench runs itself");
        let stdout = String::from_utf8_lossy(&out.stdout);
        print!(
            "{}",
            stdout
                .lines()
                .filter(|l| !l.starts_with("LATENCIES"))
                .map(|l| format!("{l}\n"))
                .collect::<String>()
        );
        let latencies_us: Vec<f64> = stdout
            .lines()
            .find_map(|l| l.strip_prefix("LATENCIES "))
            .unwrap_or_else(|| panic!("{name}: {}", String::from_utf8_lossy(&out.stderr)))
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        let at = |q: f64| {
            latencies_us
                [((q * latencies_us.len() as f64).ceil() as usize).clamp(1, latencies_us.len()) - 1]
        };
        println!(
            "backend latency, slip frame in -> hand command out, {name} (tick {:.0} us; {} slips): median {:.0} us, p90 {:.0} us, p99 {:.0} us, max {:.0} us",
            tick_s * 1e6,
            latencies_us.len(),
            at(0.5),
            at(0.9),
            at(0.99),
            latencies_us.last().copied().unwrap_or(f64::NAN)
        );
        medians.push((at(0.5), at(0.99)));
    }
    println!(
        "now / previous: median {:.2}, p99 {:.2}; live / now: median {:.2}, p99 {:.2}",
        medians[1].0 / medians[0].0,
        medians[1].1 / medians[0].1,
        medians[2].0 / medians[1].0,
        medians[2].1 / medians[1].1
    );
}
