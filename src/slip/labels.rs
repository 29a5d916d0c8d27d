//! Labels from the marker track (paper, "Single Finger"; SPEC.md "Slip detection method" 3).
//!
//! The slip onset is found from marker heights, never from simulator truth: the first marker
//! sample at which the object is more than `drop_threshold_mm` below its held height and stays
//! so, still falling, for the next `confirm_samples` samples. Heights are taken relative to the
//! hand marker when the track has one, so an object carried by a moving arm is "held". The held
//! height is the median of the `hold_window_s` before the sample, which tolerates marker noise.
//!
//! Frames of each sensor that arrive at or after the onset are `slip`, up to `n_slip` of them;
//! earlier frames are `static`; later ones are not used. A track with no onset labels every
//! frame static.

use tmo_hal::MarkerSample;

use super::Class;

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OnsetSpec {
    pub drop_threshold_mm: f64,
    pub hold_window_s: f64,
    pub confirm_samples: usize,
    /// Measure the object relative to the hand marker.
    pub relative_to_hand: bool,
}

impl Default for OnsetSpec {
    fn default() -> Self {
        Self {
            drop_threshold_mm: 1.0,
            hold_window_s: 0.5,
            confirm_samples: 5,
            relative_to_hand: true,
        }
    }
}

/// Time of the marker sample where slip starts, if the object fell.
pub fn slip_onset(track: &[MarkerSample], spec: &OnsetSpec) -> Option<f64> {
    let height = |m: &MarkerSample| {
        if spec.relative_to_hand {
            m.object_mm - m.hand_mm
        } else {
            m.object_mm
        }
    };
    let h: Vec<f64> = track.iter().map(height).collect();
    let mut window: Vec<f64> = Vec::new();
    let mut start = 0;
    for i in 0..h.len() {
        while track[i].time_s - track[start].time_s > spec.hold_window_s {
            start += 1;
        }
        // Need some history to know the held height.
        if i < start + 3 {
            continue;
        }
        window.clear();
        window.extend_from_slice(&h[start..i]);
        window.sort_by(f64::total_cmp);
        let held = window[window.len() / 2];
        let limit = held - spec.drop_threshold_mm;
        let end = i + spec.confirm_samples;
        if end >= h.len() {
            return None;
        }
        if h[i..=end].iter().all(|&x| x < limit) && h[end] < h[i] {
            return Some(track[i].time_s);
        }
    }
    None
}

/// Labels for frames arriving at `frame_times_s` (one sensor, in order): `Some(class)` for
/// frames used, `None` for frames after the `n_slip` slip frames.
pub fn label_frames(
    frame_times_s: &[f64],
    onset_s: Option<f64>,
    n_slip: usize,
) -> Vec<Option<Class>> {
    let mut slip_seen = 0;
    frame_times_s
        .iter()
        .map(|&t| match onset_s {
            Some(onset) if t >= onset => {
                slip_seen += 1;
                (slip_seen <= n_slip).then_some(Class::Slip)
            }
            _ => Some(Class::Static),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 60 Hz track: held at 300 mm, then falls at g from `fall_s`; tiny deterministic noise.
    fn track(fall_s: Option<f64>, seconds: f64) -> Vec<MarkerSample> {
        (0..(seconds * 60.0) as usize)
            .map(|i| {
                let t = i as f64 / 60.0;
                let noise = 0.25 * ((i * 7919) % 13) as f64 / 13.0 - 0.125;
                let fall = fall_s.map_or(0.0, |f| {
                    if t > f {
                        0.5 * 9810.0 * (t - f).powi(2)
                    } else {
                        0.0
                    }
                });
                MarkerSample {
                    time_s: t,
                    object_mm: 300.0 - fall + noise,
                    hand_mm: 360.0,
                }
            })
            .collect()
    }

    #[test]
    fn onset_is_the_first_sample_a_millimetre_down() {
        let onset = slip_onset(&track(Some(1.0), 2.0), &OnsetSpec::default()).unwrap();
        // 1 mm at g takes 14.3 ms: the first sample past that is 1/60 s after the fall starts,
        // 1.36 mm down (noise is under 0.13 mm)
        assert!((onset - 61.0 / 60.0).abs() < 1e-9, "{onset}");
    }

    #[test]
    fn a_held_object_has_no_onset() {
        assert_eq!(slip_onset(&track(None, 3.0), &OnsetSpec::default()), None);
    }

    #[test]
    fn a_single_noisy_sample_is_not_an_onset() {
        let mut t = track(None, 2.0);
        t[50].object_mm -= 5.0;
        assert_eq!(slip_onset(&t, &OnsetSpec::default()), None);
    }

    #[test]
    fn an_object_carried_up_by_the_hand_is_held() {
        let t: Vec<MarkerSample> = (0..120)
            .map(|i| {
                let z = 17.0 * i as f64 / 60.0;
                MarkerSample {
                    time_s: i as f64 / 60.0,
                    object_mm: 300.0 + z,
                    hand_mm: 360.0 + z,
                }
            })
            .collect();
        assert_eq!(slip_onset(&t, &OnsetSpec::default()), None);
        let absolute = OnsetSpec {
            relative_to_hand: false,
            ..Default::default()
        };
        assert_eq!(slip_onset(&t, &absolute), None);
    }

    #[test]
    fn frames_after_onset_are_slip_up_to_n_slip() {
        let times = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let labels = label_frames(&times, Some(0.25), 2);
        use Class::*;
        assert_eq!(
            labels,
            vec![
                Some(Static),
                Some(Static),
                Some(Slip),
                Some(Slip),
                None,
                None
            ]
        );
        assert!(label_frames(&times, None, 2)
            .iter()
            .all(|l| *l == Some(Static)));
    }
}
