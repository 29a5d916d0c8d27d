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
//! slept the whole 1 kHz tick, in the same run). `TICK_US=100` shortens the control tick.

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
use tmo_hal::real::clock::RealClock;
use tmo_hal::real::dynamixel::{instruction, Decoder, Packet};
use tmo_hal::real::jevois::format_fine2;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::sim::serve_jevois::open_pty;
use tmo_hal::{Clock, Hand, TactileSensor};

const PINS: usize = 30;
const TRIALS: usize = 200;

fn model() -> ModelFile {
    ModelFile::threshold_model(PINS, vec![0], 0.5)
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
fn measure(wait: Wait, tick_s: f64) -> Vec<f64> {
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

    let never = AtomicBool::new(false);
    let mut monitor = FrameMonitor::new(1, Some(online), WatchLimits::default(), mclock.now_s());
    let mut events = Vec::new();
    let mut reactions = 0;
    while reactions < TRIALS {
        // the runners' control tick
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
        match monitor.feed(&batch, mclock.now_s(), true, &never, &mut events) {
            Verdict::React(_) => {
                hand.set_targets([0.5, 0.5, 0.5, 0.0]).expect("hand");
                monitor.rearm();
                reactions += 1;
            }
            Verdict::Abort(f) => panic!("fault {f:?}"),
            Verdict::Continue => {}
        }
        events.clear();
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
    latencies_us.sort_by(f64::total_cmp);
    latencies_us
}

fn main() {
    let tick_s = std::env::var("TICK_US")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(tmo::runner::TICK_S, |us| us * 1e-6);
    let mut medians = Vec::new();
    for (wait, name) in [
        (Wait::Tick, "tick only (previous runner)"),
        (Wait::TickOrInput, "tick or input (runner now)"),
    ] {
        let latencies_us = measure(wait, tick_s);
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
        "now / previous: median {:.2}, p99 {:.2}",
        medians[1].0 / medians[0].0,
        medians[1].1 / medians[0].1
    );
}
