//! The pin noise of the null simulator (docs/standings.toml, `[[null]]`): the simulator
//! with the curl off (`physics.finger_roll_ratio` 0) and its pin noise raised until the
//! pins move as much before the object's onset as they do with the curl on, so a finding
//! that holds there holds on pin motion alone, not on the curl's structure.
//!
//! For each object, grasp angle and seed the hand releases all three fingers at the
//! paper's speed from contact + 0.04 of the range (as `curl_probe` does) with the curl on
//! and off, the same seed. Before the onset it sums every pin's frame-to-frame
//! displacement squared (px^2). Still pins under noise sigma give 4 sigma^2 a pin a frame
//! (two axes, two frames' draws), so the noise that gives the curl-off release the curl-on
//! release's pin motion is sqrt(sigma^2 + (on - off) / 4). Prints it per object and over all.
//! `cargo run --release -p tmo-sim --example null_noise [-- SEEDS]`.

use tmo_hal::{Clock, Hand, TactileSensor};
use tmo_sim::{FaultRates, HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};

fn config(object: &str, closure: f64, start: ObjectStart, grasp_deg: f64, seed: u64) -> SimConfig {
    SimConfig {
        seed,
        rig: RigSetup::Hand(HandSetup {
            object: object.into(),
            initial_closure: closure,
            start,
            grasp_deg,
            ..Default::default()
        }),
        faults: FaultRates::none(),
        ..Default::default()
    }
}

/// Mean squared frame-to-frame pin displacement before the onset (px^2 a pin a frame).
fn pin_motion(object: &str, grasp_deg: f64, seed: u64, roll_ratio: f64) -> Option<f64> {
    let contact = SimRig::new(config(object, 0.0, ObjectStart::OnTable, grasp_deg, seed))
        .ok()?
        .probe()
        .contact_closure()?;
    let q0 = contact + 0.04;
    let mut cfg = config(object, q0, ObjectStart::InHand, grasp_deg, seed);
    cfg.physics.finger_roll_ratio = roll_ratio;
    let speed = 0.005 * cfg.servo.reference_speed_per_s;
    let rig = SimRig::new(cfg).ok()?;
    let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
    let mut sensors = rig.tactile_sensors();
    let mut last: Vec<Option<Vec<[f32; 2]>>> = vec![None; sensors.len()];
    let (mut sum, mut n) = (0.0, 0u64);
    while clock.now_s() < 20.0 && probe.events().slip_onsets_s.is_empty() {
        let q = (q0 - speed * clock.now_s()).max(0.0);
        hand.set_targets([q, q, q, 0.0]).ok()?;
        for (i, s) in sensors.iter_mut().enumerate() {
            while let Some(f) = s.next_frame().ok()? {
                if let Some(prev) = &last[i] {
                    for (a, b) in f.pins.iter().zip(prev) {
                        let (dx, dy) = ((a[0] - b[0]) as f64, (a[1] - b[1]) as f64);
                        sum += dx * dx + dy * dy;
                        n += 1;
                    }
                }
                last[i] = Some(f.pins);
            }
        }
        clock.sleep(0.001);
    }
    probe.events().slip_onsets_s.first()?;
    Some(sum / n.max(1) as f64)
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    let sigma = SimConfig::default().tactip.noise_px;
    let roll = SimConfig::default().physics.finger_roll_ratio;
    println!("object angle | px^2 a pin a frame: curl on, off | matched noise px");
    let (mut all_on, mut all_off, mut count) = (0.0, 0.0, 0.0);
    for object in [
        "crisps_can",
        "toy_cat",
        "banana",
        "windex_bottle",
        "bleach_bottle",
    ] {
        for grasp in [0.0, 180.0] {
            let pairs: Vec<(f64, f64)> = (1..=seeds)
                .filter_map(|s| {
                    Some((
                        pin_motion(object, grasp, s, roll)?,
                        pin_motion(object, grasp, s, 0.0)?,
                    ))
                })
                .collect();
            let k = pairs.len() as f64;
            let on = pairs.iter().map(|p| p.0).sum::<f64>() / k;
            let off = pairs.iter().map(|p| p.1).sum::<f64>() / k;
            (all_on, all_off, count) = (all_on + on, all_off + off, count + 1.0);
            let matched = (sigma * sigma + ((on - off) / 4.0).max(0.0)).sqrt();
            println!("{object} {grasp:.0} | {on:.5} {off:.5} | {matched:.4}");
        }
    }
    let (on, off) = (all_on / count, all_off / count);
    let matched = (sigma * sigma + ((on - off) / 4.0).max(0.0)).sqrt();
    println!("all | {on:.5} {off:.5} | {matched:.4} (default {sigma})");
}
