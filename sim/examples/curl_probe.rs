//! The fingertips' own slip in a slow release, measured on the mechanism alone (no finding
//! is computed): for each object, grasp angle and seed, the hand releases all three fingers
//! at the paper's speed from contact + 0.04 of the range, as `sim/tests/physics.rs` does,
//! until the object slips. Prints, per object and angle, the mean number of break-frees
//! of each fingertip's patch before the onset, how far each first break-free leads the
//! onset, and in how many seeds the two fingers first broke free in the same 16.7 ms frame.
//! The numbers the simulator's predictions quote (docs/standings.toml) come from here:
//! `cargo run --release -p tmo-sim --example curl_probe [-- SEEDS]`.

use tmo_hal::{Clock, Hand};
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

struct Release {
    onset_s: f64,
    first_s: [Option<f64>; 3],
    slips: [u32; 3],
}

fn release(object: &str, grasp_deg: f64, seed: u64) -> Option<Release> {
    let contact = SimRig::new(config(object, 0.0, ObjectStart::OnTable, grasp_deg, seed))
        .ok()?
        .probe()
        .contact_closure()?;
    let q0 = contact + 0.04;
    let cfg = config(object, q0, ObjectStart::InHand, grasp_deg, seed);
    let speed = 0.005 * cfg.servo.reference_speed_per_s;
    let rig = SimRig::new(cfg).ok()?;
    let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
    while clock.now_s() < 20.0 && probe.events().slip_onsets_s.is_empty() {
        let q = (q0 - speed * clock.now_s()).max(0.0);
        hand.set_targets([q, q, q, 0.0]).ok()?;
        clock.sleep(0.001);
    }
    let e = probe.events();
    let onset_s = *e.slip_onsets_s.first()?;
    Some(Release {
        onset_s,
        first_s: [0, 1, 2].map(|i| e.contact_first_slip_s[i]),
        slips: [0, 1, 2].map(|i| e.contact_slips[i]),
    })
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    println!("object angle | onset s | break-frees thumb f1 f2 | lead s thumb f1 f2 (n) | fingers same frame");
    for object in ["crisps_can", "toy_cat", "banana", "windex_bottle"] {
        for grasp in [0.0, 180.0] {
            let runs: Vec<Release> = (1..=seeds)
                .filter_map(|s| release(object, grasp, s))
                .collect();
            let n = runs.len() as f64;
            let onset = runs.iter().map(|r| r.onset_s).sum::<f64>() / n;
            let slips = [0, 1, 2].map(|i| runs.iter().map(|r| r.slips[i] as f64).sum::<f64>() / n);
            let lead = [0, 1, 2].map(|i| {
                let l: Vec<f64> = runs
                    .iter()
                    .filter_map(|r| r.first_s[i].map(|t| r.onset_s - t))
                    .collect();
                (l.iter().sum::<f64>() / l.len().max(1) as f64, l.len())
            });
            let both: Vec<&Release> = runs
                .iter()
                .filter(|r| r.first_s[1].is_some() && r.first_s[2].is_some())
                .collect();
            let same = both
                .iter()
                .filter(|r| {
                    let (a, b) = (r.first_s[1].unwrap(), r.first_s[2].unwrap());
                    (a * 60.0).floor() == (b * 60.0).floor()
                })
                .count();
            println!(
                "{object} {grasp:.0} | {onset:.2} | {:.1} {:.1} {:.1} | {:.2} ({}) {:.2} ({}) {:.2} ({}) | {same} of {}",
                slips[0], slips[1], slips[2], lead[0].0, lead[0].1, lead[1].0, lead[1].1, lead[2].0, lead[2].1, both.len()
            );
        }
    }
}
