//! Outcome of a lift (first-time lift and its calibration), from the marker track and the
//! runner's phase times (SPEC.md "first_time_lift"; paper Sec. VI-B):
//!
//! - **rise**: how far the object and the hand went up, from the median heights just before
//!   the lift to the median heights over the end of the hold, mm;
//! - **success**: the object was carried: it rose at least `carry_fraction` of what the hand
//!   rose (it was not left on the table, and it did not slide out during the hold);
//! - **lag**: how far the hand had risen when the object first rose `onset_threshold_mm`:
//!   the paper's "the hand must rise noticeably before the object" (the first grasp was
//!   too weak, so slip detection, not the starting grasp, did the lifting);
//! - **overgrasp** `o = (g_slip - g_min) / (g_min - g_cont)`, in the paper's first form
//!   `((g_slip - g_cont) - (g_min - g_cont)) / (g_min - g_cont)`: grasp strength taken as the
//!   closure past contact, with this trial's own contact closure and the calibrated minimal
//!   closure past contact, so that trial-to-trial spread in where contact is found cancels.

use tmo_hal::MarkerSample;

/// When the lift began and the hold ended (from the runner's `/phase` events), s.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LiftWindow {
    pub lift_start_s: f64,
    pub hold_end_s: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftSpec {
    /// Rise of the object that counts as it leaving the table, mm.
    pub onset_threshold_mm: f64,
    /// The object counts as carried if it rose this fraction of the hand's rise.
    pub carry_fraction: f64,
    /// Heights are medians over this long before the lift and before the hold ends, s.
    pub window_s: f64,
}

impl Default for LiftSpec {
    fn default() -> Self {
        Self {
            onset_threshold_mm: 1.0,
            carry_fraction: 0.5,
            window_s: 0.3,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rise {
    pub object_mm: f64,
    pub hand_mm: f64,
}

impl Rise {
    /// How far the hand went up the object, mm.
    pub fn slid_mm(&self) -> f64 {
        self.hand_mm - self.object_mm
    }
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LiftOutcome {
    pub success: bool,
    pub rise: Rise,
    /// Hand rise when the object left the table, mm (`None`: it never did).
    pub lag_mm: Option<f64>,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

fn heights_in(track: &[MarkerSample], from_s: f64, to_s: f64) -> Option<(f64, f64)> {
    let inside: Vec<&MarkerSample> = track
        .iter()
        .filter(|m| m.time_s >= from_s && m.time_s <= to_s)
        .collect();
    Some((
        median(inside.iter().map(|m| m.object_mm).collect())?,
        median(inside.iter().map(|m| m.hand_mm).collect())?,
    ))
}

/// How far object and hand rose over `w`; `None` if the track has no samples in a window.
pub fn rise(track: &[MarkerSample], w: &LiftWindow, spec: &LiftSpec) -> Option<Rise> {
    let (o0, h0) = heights_in(track, w.lift_start_s - spec.window_s, w.lift_start_s)?;
    let (o1, h1) = heights_in(track, w.hold_end_s - spec.window_s, w.hold_end_s)?;
    Some(Rise {
        object_mm: o1 - o0,
        hand_mm: h1 - h0,
    })
}

/// Scores one lift; `None` if the track does not cover the window.
pub fn score_lift(track: &[MarkerSample], w: &LiftWindow, spec: &LiftSpec) -> Option<LiftOutcome> {
    let r = rise(track, w, spec)?;
    let (o0, h0) = heights_in(track, w.lift_start_s - spec.window_s, w.lift_start_s)?;
    // Two samples in a row above the threshold, so one noisy sample does not count.
    let after: Vec<&MarkerSample> = track
        .iter()
        .filter(|m| m.time_s >= w.lift_start_s && m.time_s <= w.hold_end_s)
        .collect();
    let lag_mm = after
        .windows(2)
        .find(|p| p.iter().all(|m| m.object_mm - o0 > spec.onset_threshold_mm))
        .map(|p| p[0].hand_mm - h0);
    Some(LiftOutcome {
        success: r.hand_mm > 0.0 && r.object_mm >= spec.carry_fraction * r.hand_mm,
        rise: r,
        lag_mm,
    })
}

/// The paper's overgrasp; `None` when the calibrated closure past contact is not positive.
pub fn overgrasp(g_slip: f64, g_cont: f64, min_past_contact: f64) -> Option<f64> {
    (min_past_contact > 0.0).then(|| ((g_slip - g_cont) - min_past_contact) / min_past_contact)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand rises 20 mm/s from t = 1 s for 2 s; the object follows once the hand is
    /// `lag_mm` up, or stays on the table.
    fn track(lag_mm: Option<f64>) -> Vec<MarkerSample> {
        (0..300)
            .map(|i| {
                let t = i as f64 / 60.0;
                let hand = 100.0 + 20.0 * (t - 1.0).clamp(0.0, 2.0);
                let object = match lag_mm {
                    Some(l) => 100.0 + (hand - 100.0 - l).max(0.0),
                    None => 100.0,
                };
                MarkerSample {
                    time_s: t,
                    object_mm: object,
                    hand_mm: hand,
                }
            })
            .collect()
    }

    const W: LiftWindow = LiftWindow {
        lift_start_s: 1.0,
        hold_end_s: 4.5,
    };

    #[test]
    fn an_object_that_follows_the_hand_after_a_short_slide_is_lifted() {
        let o = score_lift(&track(Some(6.0)), &W, &LiftSpec::default()).unwrap();
        assert!(o.success);
        assert!((o.rise.hand_mm - 40.0).abs() < 1e-9);
        assert!((o.rise.slid_mm() - 6.0).abs() < 1e-9);
        let lag = o.lag_mm.unwrap();
        assert!(lag > 6.0 && lag < 8.0, "lag {lag}");
    }

    #[test]
    fn an_object_left_on_the_table_is_not_lifted() {
        let o = score_lift(&track(None), &W, &LiftSpec::default()).unwrap();
        assert!(!o.success);
        assert_eq!(o.lag_mm, None);
        assert!((o.rise.slid_mm() - 40.0).abs() < 1e-9);
    }

    #[test]
    fn a_track_that_misses_the_window_gives_no_score() {
        let late = LiftWindow {
            lift_start_s: 10.0,
            hold_end_s: 12.0,
        };
        assert_eq!(score_lift(&track(None), &late, &LiftSpec::default()), None);
    }

    #[test]
    fn overgrasp_is_the_extra_closure_past_the_minimum_over_the_minimum() {
        // contact at 0.50, minimum 0.04 past contact, slip detection ended at 0.56
        assert!((overgrasp(0.56, 0.50, 0.04).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(overgrasp(0.56, 0.50, 0.0), None);
    }
}
