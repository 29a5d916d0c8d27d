//! Simulated seconds per wall-clock second of the `sim` backend: three TacTips at 60 fps,
//! marker tracker at 60 Hz, 1 kHz physics. Run with `cargo bench --bench sim_speed`.
//!
//! Two loops: the raw world (one long sleep, frames drained at the end of each simulated
//! second) and a 1 kHz control loop that polls every device each tick, as the runner does.

use std::time::Instant;

use tmo::runner::devices::Devices;
use tmo::runner::sim_presets::Script;
use tmo::runner::sim_presets::{self, Preset, PresetOptions};
use tmo_hal::{Clock, TactileSensor};
use tmo_sim::{SimConfig, SimRig};

fn rig(seed: u64) -> (SimRig, Script) {
    let base = SimConfig {
        seed,
        ..Default::default()
    };
    let (cfg, script) = sim_presets::build(Preset::Hold, &PresetOptions::default(), base).unwrap();
    (SimRig::new(cfg).unwrap(), script)
}

fn main() {
    let simulated_s = 60.0;
    let mut raw = Vec::new();
    let mut looped = Vec::new();
    for seed in 0..5 {
        let (r, _) = rig(seed);
        let mut clock = r.clock();
        let mut sensors = r.tactile_sensors();
        let mut frames = 0usize;
        let t0 = Instant::now();
        for s in 1..=simulated_s as usize {
            clock.sleep_until(s as f64);
            for sensor in sensors.iter_mut() {
                while sensor.next_frame().unwrap().is_some() {
                    frames += 1;
                }
            }
        }
        raw.push(simulated_s / t0.elapsed().as_secs_f64());
        assert!(frames > 3 * 59 * simulated_s as usize);

        let (r, script) = rig(seed);
        let mut devices = Devices {
            clock: r.clock(),
            hand: r.hand(),
            arm: r.arm(),
            markers: r.marker_tracker(),
            sensors: r.tactile_sensors(),
            live: None,
            state_period_s: None,
            in_flight: None,
        };
        let t0 = Instant::now();
        let rec = devices.run(script, simulated_s, |_| {}).unwrap();
        looped.push(simulated_s / t0.elapsed().as_secs_f64());
        assert!(rec.frames.len() > 3 * 59 * simulated_s as usize);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(|a, b| a.partial_cmp(b).unwrap());
        v[v.len() / 2]
    };
    println!("sim_speed: 3 sensors x 60 fps + markers + 1 kHz physics, {simulated_s} s simulated, 5 seeds, one core");
    println!(
        "  world alone:          median {:>8.0}x real time (min {:.0}x)",
        median(&mut raw),
        raw[0]
    );
    println!(
        "  with 1 kHz poll loop: median {:>8.0}x real time (min {:.0}x)",
        median(&mut looped),
        looped[0]
    );
}
