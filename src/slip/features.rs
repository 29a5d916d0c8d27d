//! Per-frame features (paper, "Tactile Data"): pin velocities in polar form with their angles
//! centred on the circular mean, so the features do not depend on the slip direction.
//!
//! For `N` pins a frame gives `2N` values: `dr_1..dr_N, dtheta_1..dtheta_N`, where
//! `dx_i = x_i(t) - x_i(t-1)`, `dr_i = hypot(dx_i, dy_i)`, `theta_i = atan2(dy_i, dx_i)`, and
//! `dtheta_i = wrap(theta_i - mean_circ(theta))` into `(-pi, pi]`, with
//! `mean_circ(theta) = atan2(sum sin theta_i, sum cos theta_i)`.
//!
//! Imperfect input:
//! - A **dropped frame** (sequence gap `g > 1`) divides the displacement by `g`, so features
//!   stay "per frame" as the classifier was trained.
//! - A **mis-detected pin** (the tracker jumped to another blob) would dominate the frame; any
//!   pin that moved more than [`FeatureSpec::max_pin_step_px`] in one frame (20 px, far beyond
//!   what a skin moves in 1/60 s) is treated as missing: its velocity is zero and it takes no
//!   part in the circular mean. So one bad pin cannot poison the other 29 features. The frame
//!   after, when the pin comes back, is treated the same way.
//! - A frame with a **different pin count** from the previous one gives no features (an error
//!   the caller counts), and a **stale** frame (pins repeated) gives all-zero velocities,
//!   which look static — as they should, nothing was seen to move.

use tmo_hal::PinFrame;

/// The units of a sensor's element positions (tmo's own pins: image pixels).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Image pixels (tracked pins or markers).
    #[default]
    Px,
    /// A sensor's raw counts (magnetic or capacitive taxels).
    Counts,
    /// Millimetres.
    Mm,
}

impl Units {
    pub fn name(self) -> &'static str {
        match self {
            Units::Px => "px",
            Units::Counts => "counts",
            Units::Mm => "mm",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        [Units::Px, Units::Counts, Units::Mm]
            .into_iter()
            .find(|u| u.name() == text)
    }
}

/// How features are computed; part of every model file. `pins` is the sensor's element
/// count (30 for the T-MO's TacTips), `max_pin_step_px` the per-frame step beyond which an
/// element counts as lost, in `units`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FeatureSpec {
    pub pins: usize,
    pub max_pin_step_px: f32,
    /// Model files before imports existed were all tracked pins in px.
    #[serde(default)]
    pub units: Units,
    /// The frames' rate (median interval), Hz, when known: velocities are per frame, so a
    /// model trained at one rate does not read frames at a very different one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_rate_hz: Option<f32>,
}

/// Frame rates closer than this (relative) are the same rate for a model.
const RATE_TOLERANCE: f32 = 0.15;

/// Trials whose frame rates differ by more than 15 %: velocities are per
/// frame, so the same slip moves an element further per frame at a lower rate. Each
/// trial's own frames are what the method needs evenly spaced; different rates between
/// trials are allowed and said.
#[derive(Debug, Clone, PartialEq)]
pub struct RateSpread {
    pub slowest: (String, f64),
    pub fastest: (String, f64),
    pub trials: usize,
}

impl RateSpread {
    /// The spread of `(trial, rate in Hz)`, if it is wider than the tolerance.
    pub fn of(rates: &[(&str, f64)]) -> Option<Self> {
        let slowest = rates.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
        let fastest = rates.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
        (fastest.1 - slowest.1 > f64::from(RATE_TOLERANCE) * slowest.1).then(|| Self {
            slowest: (slowest.0.to_string(), slowest.1),
            fastest: (fastest.0.to_string(), fastest.1),
            trials: rates.len(),
        })
    }
}

impl std::fmt::Display for RateSpread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frame rates differ between the {} trials, from {:.1} Hz (`{}`) to {:.1} Hz (`{}`): velocities are per frame, so the same slip reads faster per frame at the lower rate",
            self.trials, self.slowest.1, self.slowest.0, self.fastest.1, self.fastest.0
        )
    }
}

/// Fastest frame rate a feature spec may state, Hz: ten times the fastest tactile sensors
/// (magnetic taxels at about 1 kHz); beyond it a rate is a mistake (a period in ms, say).
pub const MAX_FRAME_RATE_HZ: f32 = 10_000.0;

impl FeatureSpec {
    /// Whether the spec's numbers are ones features can be computed with: every model (a
    /// file of tmo's own or an ONNX model's `tmo.features`) is checked here. The error
    /// names the field within the spec and what was expected.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if !(1..=100_000).contains(&self.pins) {
            return Err((
                "pins",
                format!("expected 1..=100000 pins, got {}", self.pins),
            ));
        }
        if !(self.max_pin_step_px.is_finite() && self.max_pin_step_px > 0.0) {
            return Err((
                "max_pin_step_px",
                format!("expected a positive number, got {}", self.max_pin_step_px),
            ));
        }
        if let Some(rate) = self.frame_rate_hz {
            if !(rate.is_finite() && rate > 0.0 && rate <= MAX_FRAME_RATE_HZ) {
                return Err((
                    "frame_rate_hz",
                    format!("expected the frames' rate in Hz, above 0 and at most {MAX_FRAME_RATE_HZ}, got {rate}"),
                ));
            }
        }
        Ok(())
    }

    pub fn new(pins: usize) -> Self {
        Self {
            pins,
            max_pin_step_px: 20.0,
            units: Units::Px,
            frame_rate_hz: None,
        }
    }

    /// What in `data` (the features of some trials) differs from `self` so that a model made
    /// with `self` cannot read it, if anything: `(what, data's value, self's value)`. The
    /// element count, units and step limit must agree; the frame rate may differ
    /// ([`FeatureSpec::rate_differs`] says when to warn).
    pub fn mismatch(&self, data: &FeatureSpec) -> Option<(&'static str, String, String)> {
        if self.pins != data.pins {
            return Some((
                "elements (pins) per sensor",
                data.pins.to_string(),
                self.pins.to_string(),
            ));
        }
        if self.units != data.units {
            return Some((
                "units",
                data.units.name().to_string(),
                self.units.name().to_string(),
            ));
        }
        if self.max_pin_step_px != data.max_pin_step_px {
            let limit = |s: &FeatureSpec| {
                if s.max_pin_step_px == f32::MAX {
                    "none".to_string()
                } else {
                    format!("{} {}", s.max_pin_step_px, s.units.name())
                }
            };
            return Some(("element step limit", limit(data), limit(self)));
        }
        None
    }

    /// A warning when `data`'s frame rate is more than 15 % from `self`'s (a model's
    /// training rate): velocities are per frame, so it reads the same slip at another
    /// speed per frame.
    pub fn rate_differs(&self, data: &FeatureSpec) -> Option<String> {
        let (m, d) = (self.frame_rate_hz?, data.frame_rate_hz?);
        ((m - d).abs() > RATE_TOLERANCE * m).then(|| {
            format!(
                "the trials' frame rate is {d:.1} Hz, the model's training data's {m:.1} Hz: velocities are per frame, so the model reads their slips at another speed per frame"
            )
        })
    }

    pub fn len(&self) -> usize {
        2 * self.pins
    }

    pub fn is_empty(&self) -> bool {
        self.pins == 0
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeatureError {
    #[error("sensor {sensor} frame {seq}: expected {expected} pins, got {got}")]
    PinCount {
        sensor: u8,
        seq: u64,
        expected: usize,
        got: usize,
    },
    #[error("sensor {sensor} frame {seq} does not follow frame {previous}")]
    OutOfOrder { sensor: u8, seq: u64, previous: u64 },
}

/// Features of `current` given the sensor's `previous` frame, written into `out` (cleared
/// first, `2N` values).
pub fn frame_features(
    spec: &FeatureSpec,
    previous: &PinFrame,
    current: &PinFrame,
    out: &mut Vec<f32>,
) -> Result<(), FeatureError> {
    for f in [previous, current] {
        if f.pins.len() != spec.pins {
            return Err(FeatureError::PinCount {
                sensor: f.sensor,
                seq: f.seq,
                expected: spec.pins,
                got: f.pins.len(),
            });
        }
    }
    if current.seq <= previous.seq {
        return Err(FeatureError::OutOfOrder {
            sensor: current.sensor,
            seq: current.seq,
            previous: previous.seq,
        });
    }
    let gap = (current.seq - previous.seq) as f32;
    out.clear();
    out.resize(spec.len(), 0.0);
    let (dr, dtheta) = out.split_at_mut(spec.pins);
    let (mut sum_sin, mut sum_cos) = (0.0f64, 0.0f64);
    let max_step2 = spec.max_pin_step_px * spec.max_pin_step_px;
    for (i, (a, b)) in previous.pins.iter().zip(&current.pins).enumerate() {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        if dx * dx + dy * dy > max_step2 || !(dx.is_finite() && dy.is_finite()) {
            dr[i] = f32::NAN; // marks the pin as missing until the loop below
            continue;
        }
        let (dx, dy) = (dx / gap, dy / gap);
        let theta = dy.atan2(dx);
        dr[i] = dx.hypot(dy);
        dtheta[i] = theta;
        sum_sin += f64::from(theta.sin());
        sum_cos += f64::from(theta.cos());
    }
    let mean = sum_sin.atan2(sum_cos) as f32;
    for i in 0..spec.pins {
        if dr[i].is_nan() {
            dr[i] = 0.0;
            dtheta[i] = 0.0;
        } else {
            dtheta[i] = wrap_angle(dtheta[i] - mean);
        }
    }
    Ok(())
}

/// Wraps an angle into `(-pi, pi]`.
pub fn wrap_angle(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let mut w = a % TAU;
    if w <= -PI {
        w += TAU;
    } else if w > PI {
        w -= TAU;
    }
    w
}

/// Norm of the mean pin velocity, px per frame (the threshold classifier's `v`), from a
/// feature vector: the centring rotates every velocity by the same angle, so the norm of
/// the mean is unchanged.
pub fn mean_velocity_norm(features: &[f32]) -> f32 {
    let n = features.len() / 2;
    if n == 0 {
        return 0.0;
    }
    let (dr, dtheta) = features.split_at(n);
    let (mut sx, mut sy) = (0.0f32, 0.0f32);
    for (r, t) in dr.iter().zip(dtheta) {
        sx += r * t.cos();
        sy += r * t.sin();
    }
    (sx / n as f32).hypot(sy / n as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn any_number_of_elements_in_any_units_gives_two_features_each() {
        // a 16-taxel skin in raw counts: a step of 300 counts is a measurement there
        let spec = FeatureSpec {
            pins: 16,
            max_pin_step_px: f32::MAX,
            units: Units::Counts,
            frame_rate_hz: Some(60.0),
        };
        let prev = frame(1, (0..16).map(|i| [i as f32 * 1000.0, 16000.0]).collect());
        let cur = frame(2, prev.pins.iter().map(|p| [p[0] + 300.0, p[1]]).collect());
        let mut out = Vec::new();
        frame_features(&spec, &prev, &cur, &mut out).unwrap();
        assert_eq!(out.len(), 32);
        assert!(
            out[..16].iter().all(|&r| (r - 300.0).abs() < 1e-3),
            "{out:?}"
        );
        assert!(out[16..].iter().all(|&a| a.abs() < 1e-6), "{out:?}");
        // tmo's 20 px pin guard would take every such step for a lost element
        frame_features(&FeatureSpec::new(16), &prev, &cur, &mut out).unwrap();
        assert!(out.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn rates_that_differ_are_said_not_refused() {
        let at = |hz: f32| FeatureSpec {
            frame_rate_hz: Some(hz),
            ..FeatureSpec::new(16)
        };
        assert_eq!(at(60.0).mismatch(&at(30.0)), None);
        assert!(at(60.0).rate_differs(&at(55.0)).is_none());
        let why = at(60.0).rate_differs(&at(30.0)).unwrap();
        assert!(why.contains("30.0 Hz") && why.contains("60.0 Hz"), "{why}");
        assert_eq!(RateSpread::of(&[("a", 58.8), ("b", 60.0)]), None);
        let spread = RateSpread::of(&[("a", 58.8), ("slow", 39.2), ("b", 60.0)]).unwrap();
        assert_eq!(spread.slowest, ("slow".to_string(), 39.2));
        assert_eq!(spread.fastest, ("b".to_string(), 60.0));
        assert_eq!(RateSpread::of(&[]), None);
    }

    fn frame(seq: u64, pins: Vec<[f32; 2]>) -> PinFrame {
        PinFrame {
            sensor: 0,
            seq,
            time_s: seq as f64 / 60.0,
            pins,
        }
    }

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    #[test]
    fn hand_computed_velocities_and_centred_angles() {
        // Pin 0 moves (+3, +4): r 5, angle atan2(4, 3) = 0.9273.
        // Pin 1 moves (0, +2): r 2, angle pi/2.
        let a = frame(1, vec![[10.0, 10.0], [20.0, 20.0]]);
        let b = frame(2, vec![[13.0, 14.0], [20.0, 22.0]]);
        let mut f = Vec::new();
        frame_features(&FeatureSpec::new(2), &a, &b, &mut f).unwrap();
        assert!(close(f[0], 5.0) && close(f[1], 2.0));
        let t0 = 4f32.atan2(3.0);
        let t1 = PI / 2.0;
        let mean = (t0.sin() + t1.sin()).atan2(t0.cos() + t1.cos());
        assert!(close(f[2], t0 - mean) && close(f[3], t1 - mean), "{f:?}");
        // centred angles of two pins are symmetric about zero
        assert!(close(f[2], -f[3]));
    }

    #[test]
    fn angles_wrap_around_plus_minus_pi() {
        // Both pins move nearly along -x: angles just below +pi and just above -pi. Their
        // circular mean is pi (not 0), so the centred angles are small, not near +-pi.
        let a = frame(1, vec![[10.0, 10.0], [20.0, 20.0]]);
        let b = frame(2, vec![[9.0, 10.1], [19.0, 19.9]]);
        let mut f = Vec::new();
        frame_features(&FeatureSpec::new(2), &a, &b, &mut f).unwrap();
        let expected = 0.1f32.atan2(1.0);
        assert!(
            close(f[2].abs(), expected) && close(f[3].abs(), expected),
            "{f:?}"
        );
        assert!(f[2] * f[3] < 0.0);
        assert!(close(wrap_angle(3.0 * PI / 2.0), -PI / 2.0));
        assert!(close(wrap_angle(-PI), PI));
        assert!(close(wrap_angle(PI), PI));
    }

    #[test]
    fn features_do_not_depend_on_slip_direction() {
        let rest: Vec<[f32; 2]> = (0..5).map(|i| [i as f32 * 10.0, 0.0]).collect();
        let moved = |angle: f32| -> Vec<[f32; 2]> {
            rest.iter()
                .enumerate()
                .map(|(i, p)| {
                    let (r, a) = (1.0 + i as f32 * 0.1, angle + i as f32 * 0.05);
                    [p[0] + r * a.cos(), p[1] + r * a.sin()]
                })
                .collect()
        };
        let spec = FeatureSpec::new(5);
        let (mut f1, mut f2) = (Vec::new(), Vec::new());
        frame_features(
            &spec,
            &frame(1, rest.clone()),
            &frame(2, moved(0.3)),
            &mut f1,
        )
        .unwrap();
        frame_features(
            &spec,
            &frame(1, rest.clone()),
            &frame(2, moved(2.9)),
            &mut f2,
        )
        .unwrap();
        for (a, b) in f1.iter().zip(&f2) {
            assert!((a - b).abs() < 1e-4, "{f1:?} vs {f2:?}");
        }
    }

    #[test]
    fn dropped_frame_is_scaled_to_per_frame_velocity() {
        let a = frame(1, vec![[0.0, 0.0]]);
        let b = frame(3, vec![[4.0, 0.0]]);
        let mut f = Vec::new();
        frame_features(&FeatureSpec::new(1), &a, &b, &mut f).unwrap();
        assert!(close(f[0], 2.0));
    }

    #[test]
    fn misdetected_pin_is_ignored_not_poisoning_the_frame() {
        let a = frame(1, vec![[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]);
        let b = frame(2, vec![[0.0, 1.0], [10.0, 1.0], [300.0, 250.0]]);
        let mut f = Vec::new();
        frame_features(&FeatureSpec::new(3), &a, &b, &mut f).unwrap();
        assert_eq!(&f[..3], &[1.0, 1.0, 0.0]);
        // the two good pins both move along +y, the circular mean ignores the bad one
        assert!(close(f[3], 0.0) && close(f[4], 0.0) && f[5] == 0.0);
    }

    #[test]
    fn wrong_pin_count_and_order_are_errors() {
        let mut f = Vec::new();
        let spec = FeatureSpec::new(2);
        let e = frame_features(
            &spec,
            &frame(1, vec![[0.0; 2]; 2]),
            &frame(2, vec![[0.0; 2]; 3]),
            &mut f,
        )
        .unwrap_err();
        assert!(matches!(e, FeatureError::PinCount { got: 3, .. }));
        let e = frame_features(
            &spec,
            &frame(2, vec![[0.0; 2]; 2]),
            &frame(2, vec![[0.0; 2]; 2]),
            &mut f,
        )
        .unwrap_err();
        assert!(matches!(e, FeatureError::OutOfOrder { .. }));
    }

    #[test]
    fn mean_velocity_norm_matches_cartesian_mean() {
        let a = frame(1, vec![[0.0, 0.0], [10.0, 0.0]]);
        let b = frame(2, vec![[1.0, 1.0], [13.0, 0.0]]);
        let mut f = Vec::new();
        frame_features(&FeatureSpec::new(2), &a, &b, &mut f).unwrap();
        // mean (dx, dy) = (2, 0.5)
        assert!(close(mean_velocity_norm(&f), 2f32.hypot(0.5)));
    }
}
