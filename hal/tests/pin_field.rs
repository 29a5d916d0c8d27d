//! What the simulated TacTips show: co-linear pin motion at slip onset, radial motion while
//! closing, and the same frames for the same seed.

use tmo_hal::sim::{FaultRates, HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};
use tmo_hal::{Clock, Hand, MarkerSample, MarkerTracker, PinFrame, TactileSensor};

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

#[test]
fn slip_onset_gives_colinear_pin_motion_well_above_noise() {
    let (frames, _, onset) = release(11, FaultRates::none());
    for sensor in 0..3u8 {
        let own: Vec<&PinFrame> = frames.iter().filter(|f| f.sensor == sensor).collect();
        let mut static_norms = Vec::new();
        let mut best: Option<([f64; 2], f64)> = None;
        for w in own.windows(2) {
            let (v, speed) = mean_velocity(w[0], w[1]);
            let norm = v[0].hypot(v[1]);
            let t = w[1].time_s;
            if t > 0.2 && t < onset - 0.3 {
                static_norms.push(norm);
            } else if t >= onset
                && t < onset + 0.1
                && best.is_none_or(|(b, _)| norm > b[0].hypot(b[1]))
            {
                best = Some((v, speed));
            }
        }
        let noise = static_norms.iter().cloned().fold(0.0, f64::max);
        let (v, speed) = best.expect("frames after onset");
        let norm = v[0].hypot(v[1]);
        assert!(
            norm > 5.0 * noise,
            "sensor {sensor}: onset mean velocity {norm} vs static max {noise}"
        );
        assert!(
            norm / speed > 0.7,
            "sensor {sensor}: not co-linear: |mean| {norm}, mean speed {speed}"
        );
    }
}

#[test]
fn closing_on_an_object_moves_pins_radially() {
    let rig = SimRig::new(config(5, 0.0, ObjectStart::OnTable, FaultRates::none())).unwrap();
    let (mut clock, mut hand) = (rig.clock(), rig.hand());
    let mut sensors = rig.tactile_sensors();
    let q = contact_closure() + 0.06;
    hand.set_targets([q, q, q, 0.0]).unwrap();
    let mut frames = Vec::new();
    while clock.now_s() < 1.0 {
        clock.sleep(0.01);
        for s in sensors.iter_mut() {
            while let Some(f) = s.next_frame().unwrap() {
                frames.push(f);
            }
        }
    }
    let mut moving = 0;
    for sensor in 0..3u8 {
        let own: Vec<&PinFrame> = frames.iter().filter(|f| f.sensor == sensor).collect();
        for w in own.windows(2) {
            let (v, speed) = mean_velocity(w[0], w[1]);
            if speed > 0.3 {
                moving += 1;
                let ratio = v[0].hypot(v[1]) / speed;
                assert!(
                    ratio < 0.3,
                    "sensor {sensor} at {}: |mean| / speed = {ratio}",
                    w[1].time_s
                );
            }
        }
    }
    assert!(
        moving >= 3,
        "closing should move the pins ({moving} moving frames)"
    );
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
