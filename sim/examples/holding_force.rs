//! The hand's holding force at full torque, measured on the simulator alone (the
//! outside-the-paper table, docs/outside.toml): the hand grips an object in the air with
//! its fingers commanded shut at full torque, mass is poured into the object at a steady
//! rate from 1 s on (as the rice pour does), and the holding force is the weight the
//! object had when it slipped, (mass + poured) g. Prints it per object, grasp and seed.
//! `cargo run --release -p tmo-sim --example holding_force [-- SEEDS]`.

use tmo_hal::{Clock, Hand};
use tmo_sim::{FaultRates, HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};

const POUR_G_PER_S: f64 = 400.0;
const POUR_START_S: f64 = 1.0;

fn holding_force_n(object: &str, grasp_deg: f64, seed: u64) -> Option<f64> {
    let cfg = SimConfig {
        seed,
        rig: RigSetup::Hand(HandSetup {
            object: object.into(),
            initial_closure: 1.0,
            start: ObjectStart::InHand,
            grasp_deg,
            pour_rate_g_per_s: POUR_G_PER_S,
            pour_start_s: POUR_START_S,
            ..Default::default()
        }),
        faults: FaultRates::none(),
        ..Default::default()
    };
    let mass_g = tmo_sim::objects::ObjectLibrary::built_in()
        .get(object)
        .ok()?
        .mass_g;
    let rig = SimRig::new(cfg).ok()?;
    let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
    hand.set_torque_limit(1.0).ok()?;
    while clock.now_s() < 120.0 && probe.events().slip_onsets_s.is_empty() {
        hand.set_targets([1.0, 1.0, 1.0, 0.0]).ok()?;
        clock.sleep(0.005);
    }
    let onset = *probe.events().slip_onsets_s.first()?;
    let poured = POUR_G_PER_S * (onset - POUR_START_S).max(0.0);
    Some((mass_g + poured) * 9.81e-3)
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    println!("object grasp | holding force N per seed | mean");
    for object in ["crisps_can", "soup_can", "mustard_bottle"] {
        for grasp in [0.0, 180.0] {
            let f: Vec<f64> = (1..=seeds)
                .filter_map(|s| holding_force_n(object, grasp, s))
                .collect();
            let mean = f.iter().sum::<f64>() / f.len().max(1) as f64;
            let shown: Vec<String> = f.iter().map(|x| format!("{x:.1}")).collect();
            println!("{object} {grasp:.0} | {} | {mean:.1}", shown.join(" "));
        }
    }
}
