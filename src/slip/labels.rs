//! Labels from the marker track (paper, "Single Finger"; SPEC.md "Slip detection method" 3).
//!
//! The slip onset is found from marker heights, never from simulator truth. Slip is *detected*
//! at the first marker sample at which the object is more than `drop_threshold_mm` below its
//! held height and stays so for the next `confirm_samples` samples (a slip caught within
//! them still counts: the object moved; one noisy sample does not). Its
//! *onset* is the change point before that: the first sample of the run, ending in the
//! detection, in which the track (a centred 3-sample mean, which cuts the noise of two
//! markers by sqrt 3) is more than `resolution_mm` below the held height (and the sample
//! itself half that). So an object that
//! began to fall 0.6 mm before the 1 mm mark gets its onset there, not one or two samples
//! late. Heights are taken relative to the hand marker when the track has one, so an object
//! carried by a moving arm is "held". The held height is the median of the `hold_window_s`
//! before the detection, which tolerates marker noise.
//!
//! Frames of each sensor that arrive at or after the onset are `slip`, up to `n_slip` of them
//! and only while the object is still slipping ([`slip_end`]: not once it has come to rest on
//! a table or an end stop, or slid out of the grasp); earlier frames are `static`; later ones
//! are not used. A track with no onset labels every frame static.

use tmo_hal::MarkerSample;

use super::Class;
use crate::trial::Trial;

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OnsetSpec {
    pub drop_threshold_mm: f64,
    pub hold_window_s: f64,
    pub confirm_samples: usize,
    /// Measure the object relative to the hand marker.
    pub relative_to_hand: bool,
    /// Smallest fall below the held height that the change point counts as motion, mm:
    /// about twice the noise of the smoothed relative track (0.3 mm per marker).
    #[serde(default = "default_resolution_mm")]
    pub resolution_mm: f64,
    /// Samples over which the object must move less than the resolution to be at rest.
    #[serde(default = "default_rest_samples")]
    pub rest_samples: usize,
}

fn default_resolution_mm() -> f64 {
    0.5
}

fn default_rest_samples() -> usize {
    6
}

/// Most slip frames a label may take: ten thousand frames is minutes of slip at any
/// tactile sensor's rate, far past any slip a grasp survives.
pub const MAX_N_SLIP: usize = 10_000;

impl OnsetSpec {
    /// Whether the onset rule's numbers are ones it can work with; the error says which.
    pub fn check(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "`{name}` = {}: expected a positive number",
                    crate::quote::number(v)
                ))
            }
        };
        positive("drop_threshold_mm", self.drop_threshold_mm)?;
        positive("hold_window_s", self.hold_window_s)?;
        positive("resolution_mm", self.resolution_mm)?;
        if !(1..=10_000).contains(&self.confirm_samples)
            || !(1..=10_000).contains(&self.rest_samples)
        {
            return Err(format!(
                "`confirm_samples` = {}, `rest_samples` = {}: expected 1..=10000 samples",
                self.confirm_samples, self.rest_samples
            ));
        }
        Ok(())
    }
}

impl Default for OnsetSpec {
    fn default() -> Self {
        Self {
            drop_threshold_mm: 1.0,
            hold_window_s: 0.5,
            confirm_samples: 5,
            relative_to_hand: true,
            resolution_mm: default_resolution_mm(),
            rest_samples: default_rest_samples(),
        }
    }
}

/// The heights the onset rules read: relative to the hand (or not), as the spec says.
fn heights(track: &[MarkerSample], spec: &OnsetSpec) -> Vec<f64> {
    track
        .iter()
        .map(|m| {
            if spec.relative_to_hand {
                m.object_mm - m.hand_mm
            } else {
                m.object_mm
            }
        })
        .collect()
}

/// Centred 3-sample mean (the ends use what they have).
fn smoothed(h: &[f64]) -> Vec<f64> {
    (0..h.len())
        .map(|i| {
            let lo = i.saturating_sub(1);
            let hi = (i + 2).min(h.len());
            h[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect()
}

/// A detected slip: when it started (the change point), when it was detected (the sample
/// past the drop threshold) and the held height before it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Onset {
    pub time_s: f64,
    pub detected_s: f64,
    pub held_mm: f64,
}

/// Time of the marker sample where slip starts, if the object fell.
pub fn slip_onset(track: &[MarkerSample], spec: &OnsetSpec) -> Option<f64> {
    find_onset(track, spec).map(|o| o.time_s)
}

/// The slip onset with its detection and held height, if the object fell.
pub fn find_onset(track: &[MarkerSample], spec: &OnsetSpec) -> Option<Onset> {
    let h = heights(track, spec);
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
        if h[i..=end].iter().all(|&x| x < limit) {
            let smooth = smoothed(&h);
            // The mean also reads the next sample: the raw sample must have moved too, or
            // the last held sample would count as falling.
            let moved = held - spec.resolution_mm;
            let mut k = i;
            while k > start && smooth[k - 1] < moved && h[k - 1] < held - spec.resolution_mm / 2.0 {
                k -= 1;
            }
            return Some(Onset {
                time_s: track[k].time_s,
                detected_s: track[i].time_s,
                held_mm: held,
            });
        }
    }
    None
}

/// When slip that began at `onset` stopped being slip on the fingers: the first sample from
/// which the object moved less than the resolution over the next `rest_samples` samples (it
/// landed, reached an end stop or was held again), or at which it had slid more than
/// `max_slide_mm` below its held height (out of the grasp: half its length, for objects of
/// known size). `None` while it was still slipping when the track ended.
pub fn slip_end(
    track: &[MarkerSample],
    onset: &Onset,
    spec: &OnsetSpec,
    max_slide_mm: Option<f64>,
) -> Option<f64> {
    let h = smoothed(&heights(track, spec));
    let first = track.iter().position(|m| m.time_s >= onset.detected_s)?;
    let n = spec.rest_samples.max(2);
    for j in first..h.len() {
        if max_slide_mm.is_some_and(|m| onset.held_mm - h[j] > m) {
            return Some(track[j].time_s);
        }
        let window = &h[j..(j + n).min(h.len())];
        if window.len() == n {
            let (lo, hi) = window
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            if hi - lo < spec.resolution_mm {
                return Some(track[j].time_s);
            }
        }
    }
    None
}

/// The onset and end of slip in a trial's marker track, as labels use them.
/// `max_slide_mm`: how far the object can slide below its held height before it has left
/// the fingers (half its length: the contact spans its length about the grasp point), where
/// known.
pub fn slip_window(
    track: &[MarkerSample],
    max_slide_mm: Option<f64>,
    spec: &OnsetSpec,
) -> (Option<f64>, Option<f64>) {
    match find_onset(track, spec) {
        Some(o) => (Some(o.time_s), slip_end(track, &o, spec, max_slide_mm)),
        None => (None, None),
    }
}

/// The number of frames in `seconds` at `rate_hz` (at least one): a slip window given in
/// time, for sensors at other rates than the TacTips' 60 Hz.
pub fn frames_in(seconds: f64, rate_hz: f64) -> usize {
    ((seconds * rate_hz).round() as usize).max(1)
}

/// A trial's imported slip labels (`/label` track: time, slip), in time order; empty for
/// trials labelled by their marker track.
pub fn label_track(trial: &Trial) -> Vec<(f64, bool)> {
    trial
        .events
        .iter()
        .filter(|e| e.topic == crate::trial::LABEL_TOPIC)
        .filter_map(|e| Some((e.time_s, e.data.get("slip")?.as_bool()?)))
        .collect()
}

/// The onset and end of slip in a trial: from its imported label track when it has one (the
/// first slip label, and the first static label after it), otherwise from its marker track
/// ([`slip_window`]).
pub fn trial_slip_window(trial: &Trial, spec: &OnsetSpec) -> (Option<f64>, Option<f64>) {
    let labels = label_track(trial);
    if labels.is_empty() {
        let max_slide_mm = trial.meta.object_length_mm().map(|l| l / 2.0);
        return slip_window(&trial.markers, max_slide_mm, spec);
    }
    let onset = labels.iter().find(|l| l.1).map(|l| l.0);
    let end = onset.and_then(|o| labels.iter().find(|l| l.0 > o && !l.1).map(|l| l.0));
    (onset, end)
}

/// A trial's slip onset: from its label track when it has one, else its marker track.
pub fn trial_onset(trial: &Trial, spec: &OnsetSpec) -> Option<f64> {
    let labels = label_track(trial);
    if labels.is_empty() {
        return slip_onset(&trial.markers, spec);
    }
    labels.iter().find(|l| l.1).map(|l| l.0)
}

/// Labels for frames arriving at `frame_times_s` (one sensor, in order): `Some(class)` for
/// frames used, `None` for frames after the `n_slip` slip frames or at or after the slip's
/// end (`slip_end_s`).
pub fn label_frames(
    frame_times_s: &[f64],
    onset_s: Option<f64>,
    slip_end_s: Option<f64>,
    n_slip: usize,
) -> Vec<Option<Class>> {
    let mut slip_seen = 0;
    frame_times_s
        .iter()
        .map(|&t| match onset_s {
            Some(_) if slip_end_s.is_some_and(|end| t >= end) => None,
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
    fn a_window_in_seconds_is_the_frames_of_the_sensors_rate() {
        assert_eq!(frames_in(13.0 / 60.0, 60.0), 13);
        assert_eq!(frames_in(0.5, 59.8), 30);
        assert_eq!(frames_in(0.5, 100.0), 50);
        assert_eq!(frames_in(0.001, 30.0), 1);
    }

    #[test]
    fn onset_is_the_first_sample_a_millimetre_down() {
        let onset = slip_onset(&track(Some(1.0), 2.0), &OnsetSpec::default()).unwrap();
        // 1 mm at g takes 14.3 ms: the first sample past that is 1/60 s after the fall starts,
        // 1.36 mm down (noise is under 0.13 mm)
        assert!((onset - 61.0 / 60.0).abs() < 1e-9, "{onset}");
    }

    /// Held at 0, then sliding down at `speed` mm/s from `start_s`, with +-0.3 mm of
    /// deterministic noise on the object marker.
    fn slow_slide(start_s: f64, speed: f64, stop_after_mm: f64) -> Vec<MarkerSample> {
        (0..180)
            .map(|i| {
                let t = i as f64 / 60.0;
                let fall = ((t - start_s).max(0.0) * speed).min(stop_after_mm);
                let noise = 0.6 * (((i * 7919) % 17) as f64 / 17.0 - 0.5);
                MarkerSample {
                    time_s: t,
                    object_mm: 100.0 - fall + noise,
                    hand_mm: 200.0,
                }
            })
            .collect()
    }

    #[test]
    fn the_onset_is_the_change_point_before_the_millimetre_mark() {
        // 30 mm/s: the object takes 33 ms (2 samples) to fall 1 mm, and 17 ms to pass the
        // 0.5 mm resolution
        let t = slow_slide(1.0, 30.0, 50.0);
        let o = find_onset(&t, &OnsetSpec::default()).unwrap();
        assert!(o.detected_s >= 1.0 + 1.0 / 30.0, "{o:?}");
        assert!(o.time_s < o.detected_s, "{o:?}");
        assert!((o.time_s - 1.0).abs() <= 2.0 / 60.0 + 1e-9, "{o:?}");
        // a coarser resolution walks back less far
        let coarse = OnsetSpec {
            resolution_mm: 0.95,
            ..Default::default()
        };
        let c = find_onset(&t, &coarse).unwrap();
        assert!(c.time_s >= o.time_s, "{c:?} {o:?}");
    }

    #[test]
    fn slip_ends_when_the_object_lands_or_leaves_the_grasp() {
        // slides 20 mm at 60 mm/s from 1 s, then rests (landed): ends about 1.33 s
        let t = slow_slide(1.0, 60.0, 20.0);
        let spec = OnsetSpec::default();
        let o = find_onset(&t, &spec).unwrap();
        let end = slip_end(&t, &o, &spec, None).unwrap();
        assert!((1.25..1.40).contains(&end), "{end}");
        // out of the grasp after 10 mm
        let out = slip_end(&t, &o, &spec, Some(10.0)).unwrap();
        assert!((1.1..1.22).contains(&out), "{out}");
        // a slide still going when the track ends has no end
        let going = slow_slide(1.0, 60.0, 1000.0);
        let o = find_onset(&going, &spec).unwrap();
        assert_eq!(slip_end(&going, &o, &spec, None), None);
    }

    #[test]
    fn no_frame_after_the_slip_ended_is_labelled_slip() {
        let times: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let labels = label_frames(&times, Some(0.5), Some(0.85), 15);
        use Class::*;
        assert!(labels[..5].iter().all(|l| *l == Some(Static)));
        assert!(labels[5..9].iter().all(|l| *l == Some(Slip)));
        assert!(labels[9..].iter().all(|l| l.is_none()), "{labels:?}");
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
        let labels = label_frames(&times, Some(0.25), None, 2);
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
        assert!(label_frames(&times, None, None, 2)
            .iter()
            .all(|l| *l == Some(Static)));
    }
}
