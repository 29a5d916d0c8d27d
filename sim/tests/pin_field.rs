//! What the simulated TacTips show: pin motion for as long as the object slides, grip
//! changes with a mean vector that is still mostly radial, and the same frames for the
//! same seed.

use tmo_hal::{Clock, Hand, MarkerSample, MarkerTracker, PinFrame, TactileSensor};
use tmo_sim::{FaultRates, HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};

fn config(seed: u64, closure: f64, start: ObjectStart, faults: FaultRates) -> SimConfig {
    SimConfig {
        seed,
        rig: RigSetup::Hand(HandSetup {
            object: "crisps_can".into(),
            initial_closure: closure,
            start,
            ..Default::default()
        }),
        faults,
        ..Default::default()
    }
}

fn contact_closure() -> f64 {
    SimRig::new(config(0, 0.0, ObjectStart::OnTable, FaultRates::none()))
        .unwrap()
        .probe()
        .contact_closure()
        .unwrap()
}

/// Mean pin velocity vector and mean pin speed between two frames, px per frame.
fn mean_velocity(prev: &PinFrame, cur: &PinFrame) -> ([f64; 2], f64) {
    let n = cur.pins.len() as f64;
    let (mut sx, mut sy, mut speed) = (0.0, 0.0, 0.0);
    for (a, b) in prev.pins.iter().zip(&cur.pins) {
        let (dx, dy) = ((b[0] - a[0]) as f64, (b[1] - a[1]) as f64);
        sx += dx;
        sy += dy;
        speed += (dx * dx + dy * dy).sqrt();
    }
    ([sx / n, sy / n], speed / n)
}

/// Runs a slow release with no reaction; returns all frames and the true onset.
fn release(seed: u64, faults: FaultRates) -> (Vec<PinFrame>, Vec<MarkerSample>, f64) {
    let q0 = contact_closure() + 0.04;
    let rig = SimRig::new(config(seed, q0, ObjectStart::InHand, faults)).unwrap();
    let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
    let mut sensors = rig.tactile_sensors();
    let mut markers = rig.marker_tracker();
    let (mut frames, mut samples) = (Vec::new(), Vec::new());
    while clock.now_s() < 6.0 {
        let q = (q0 - 0.01 * clock.now_s()).max(0.0);
        hand.set_targets([q, q, q, 0.0]).unwrap();
        clock.sleep(0.005);
        for s in sensors.iter_mut() {
            while let Some(f) = s.next_frame().unwrap() {
                frames.push(f);
            }
        }
        while let Some(m) = markers.next_sample().unwrap() {
            samples.push(m);
        }
    }
    let onset = *probe.events().slip_onsets_s.first().expect("slip happened");
    (frames, samples, onset)
}

/// Median of `v` (sorted copy).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn slip_signal_stays_above_noise_for_the_whole_slide() {
    let (frames, samples, onset) = release(11, FaultRates::none());
    // the slide ends when the object has fallen out of the grasp (half its length, 125 mm)
    let start = samples[0].object_mm;
    let end = samples
        .iter()
        .find(|m| start - m.object_mm > 100.0)
        .map(|m| m.time_s)
        .expect("the object slid out");
    assert!(end - onset > 15.0 / 60.0, "a slide of at least 15 frames");
    for sensor in 0..3u8 {
        let own: Vec<&PinFrame> = frames.iter().filter(|f| f.sensor == sensor).collect();
        let (mut still, mut sliding) = (Vec::new(), Vec::new());
        for w in own.windows(2) {
            let (v, _) = mean_velocity(w[0], w[1]);
            let t = w[1].time_s;
            if t > 0.2 && t < onset - 0.3 {
                still.push(v[0].hypot(v[1]));
            } else if t > onset + 0.05 && t < end {
                sliding.push(v[0].hypot(v[1]));
            }
        }
        let noise = median(&still);
        // well above the noise over the slide, and above it in each of its first three
        // quarters (weakest while the slip creeps; in the last quarter the object leaves the
        // grasp at over 0.5 m/s, its surface passes faster than the skin can follow and the
        // signal fades towards noise)
        assert!(median(&sliding) > 2.0 * noise, "sensor {sensor}");
        for quarter in sliding.chunks(sliding.len().div_ceil(4)).take(3) {
            let m = median(quarter);
            assert!(
                m > 1.2 * noise,
                "sensor {sensor}: sliding |mean v| {m} against noise {noise}"
            );
        }
    }
}

#[test]
fn closing_off_centre_gives_a_mean_vector_but_less_colinear_than_slip() {
    let rig = SimRig::new(config(5, 0.0, ObjectStart::OnTable, FaultRates::none())).unwrap();
    let (mut clock, mut hand) = (rig.clock(), rig.hand());
    let mut sensors = rig.tactile_sensors();
    let q = contact_closure() + 0.06;
    let mut frames = Vec::new();
    while clock.now_s() < 2.0 {
        // close at 5 % of range per second, as data collection does
        let target = (contact_closure() - 0.02 + 0.05 * clock.now_s()).min(q);
        hand.set_targets([target, target, target, 0.0]).unwrap();
        clock.sleep(0.01);
        for s in sensors.iter_mut() {
            while let Some(f) = s.next_frame().unwrap() {
                frames.push(f);
            }
        }
    }
    for sensor in 0..3u8 {
        let own: Vec<&PinFrame> = frames.iter().filter(|f| f.sensor == sensor).collect();
        let (mut noise, mut moving) = (Vec::new(), Vec::new());
        for w in own.windows(2) {
            let (v, speed) = mean_velocity(w[0], w[1]);
            if w[1].time_s < 0.3 {
                noise.push((v[0].hypot(v[1]), speed));
            } else {
                moving.push((v[0].hypot(v[1]), speed));
            }
        }
        // frames in which the pins move clearly faster than noise alone moves them
        let noise_speed = median(&noise.iter().map(|n| n.1).collect::<Vec<_>>());
        let closing: Vec<(f64, f64)> = moving
            .into_iter()
            .filter(|m| m.1 > 1.2 * noise_speed)
            .collect();
        let noise: Vec<f64> = noise.iter().map(|n| n.0).collect();
        assert!(
            closing.len() >= 3,
            "sensor {sensor}: closing moved the pins"
        );
        let noise = noise.iter().cloned().fold(0.0, f64::max);
        let strongest = closing.iter().map(|c| c.0).fold(0.0, f64::max);
        assert!(
            strongest > 1.3 * noise,
            "sensor {sensor}: grip change |mean v| {strongest} against noise {noise}"
        );
        // radial spreading dominates: the mean vector is a fraction of the mean speed
        let ratio = median(&closing.iter().map(|c| c.0 / c.1).collect::<Vec<_>>());
        assert!(ratio < 0.7, "sensor {sensor}: |mean v| / speed {ratio}");
    }
}

#[test]
fn same_seed_same_frames_different_seed_different_frames() {
    let faults = FaultRates {
        pin_misdetect: 0.01,
        dropped_frame: 0.02,
        stale_frame: 0.02,
    };
    let a = release(21, faults.clone());
    let b = release(21, faults.clone());
    let c = release(22, faults);
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
    assert_eq!(a.2, b.2);
    assert_ne!(a.0, c.0);
    assert_ne!(a.1, c.1);
}

#[test]
fn faults_appear_at_their_configured_rates() {
    let faults = FaultRates {
        pin_misdetect: 0.0,
        dropped_frame: 0.05,
        stale_frame: 0.05,
    };
    let (frames, _, _) = release(3, faults);
    let thumb: Vec<&PinFrame> = frames.iter().filter(|f| f.sensor == 0).collect();
    let gaps = thumb.windows(2).filter(|w| w[1].seq > w[0].seq + 1).count();
    let stale = thumb.windows(2).filter(|w| w[1].pins == w[0].pins).count();
    let n = thumb.len() as f64;
    assert!(
        (gaps as f64 / n - 0.05).abs() < 0.025,
        "dropped {gaps} of {n}"
    );
    assert!(
        (stale as f64 / n - 0.05).abs() < 0.025,
        "stale {stale} of {n}"
    );
    // 60 fps with its own clock
    let span = thumb.last().unwrap().time_s - thumb[0].time_s;
    let rate = (thumb.last().unwrap().seq - thumb[0].seq) as f64 / span;
    assert!((rate - 60.0).abs() < 0.1, "{rate} fps");
}

#[test]
fn the_contact_gauge_fires_at_a_light_touch() {
    // The paper's contact test: mean pin displacement from the untouched pins over 0.5 px.
    let rig = SimRig::new(config(9, 0.0, ObjectStart::OnTable, FaultRates::none())).unwrap();
    let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
    let mut sensors = rig.tactile_sensors();
    let start = contact_closure() - 0.02;
    let mut reference: Vec<Option<Vec<[f32; 2]>>> = vec![None; 3];
    while clock.now_s() < 3.0 {
        // close at 2 % of range per second, as the first-time lift does
        let q = start + 0.02 * clock.now_s();
        hand.set_targets([q, q, q, 0.0]).unwrap();
        clock.sleep(0.005);
        for (i, s) in sensors.iter_mut().enumerate() {
            while let Some(f) = s.next_frame().unwrap() {
                let reference = reference[i].get_or_insert_with(|| f.pins.clone());
                let d: f64 = reference
                    .iter()
                    .zip(&f.pins)
                    .map(|(a, b)| ((b[0] - a[0]) as f64).hypot((b[1] - a[1]) as f64))
                    .sum::<f64>()
                    / f.pins.len() as f64;
                if d > 0.5 {
                    let n = probe.state().normal_n[i];
                    assert!((0.05..=0.4).contains(&n), "sensor {i} fired at {n} N");
                    return;
                }
            }
        }
    }
    panic!("no sensor reached 0.5 px");
}

#[test]
fn the_rails_initial_contact_moves_the_pins_fast_with_a_mean_vector() {
    let rig = SimRig::new(SimConfig {
        seed: 4,
        rig: RigSetup::Rail(Default::default()),
        faults: FaultRates::none(),
        ..Default::default()
    })
    .unwrap();
    let mut clock = rig.clock();
    let mut sensors = rig.tactile_sensors();
    let mut frames = Vec::new();
    while clock.now_s() < 1.2 {
        clock.sleep(0.01);
        while let Some(f) = sensors[0].next_frame().unwrap() {
            frames.push(f);
        }
    }
    let (mut contact, mut held) = (Vec::new(), Vec::new());
    for w in frames.windows(2) {
        let (v, speed) = mean_velocity(&w[0], &w[1]);
        match w[1].time_s {
            t if t < 0.15 => contact.push((v[0].hypot(v[1]), speed)),
            // after the support let go (0.25 s) and the load came over (0.2 s)
            t if t > 0.8 => held.push((v[0].hypot(v[1]), speed)),
            _ => {}
        }
    }
    let held_mean_v = held.iter().map(|h| h.0).fold(0.0, f64::max);
    let held_speed = median(&held.iter().map(|h| h.1).collect::<Vec<_>>());
    let fastest = contact.iter().map(|c| c.1).fold(0.0, f64::max);
    let strongest = contact.iter().map(|c| c.0).fold(0.0, f64::max);
    // the press spreads the pins fast, and the curling finger drags the skin: a mean vector
    // well above what a held contact's noise gives
    assert!(fastest > 4.0 * held_speed, "{fastest} vs {held_speed}");
    assert!(
        strongest > 3.0 * held_mean_v,
        "{strongest} vs {held_mean_v}"
    );
}
