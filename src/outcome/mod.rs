//! Outcome of a catch trial (hand release, slip rail), scored from the marker track and the
//! time the hand reacted, so sim, replay and real trials are scored by the same code
//! (SPEC.md, "Trial outcome definitions"):
//!
//! - onset: the change point of the relative track before it falls past the drop
//!   threshold ([`find_onset`]); the track is the object marker's height minus the hand
//!   marker's, so an arm that moves is not slip;
//! - FP: the hand reacted before the onset (whatever followed; `dropped` records a fall),
//!   by more than the marker's own lag: a 60 Hz marker with 0.3 mm of noise sees a fall
//!   one or two samples after it began, so a tactile reaction inside that window is not
//!   early;
//! - FN: the object was dropped: it fell more than the drop limit below its held height;
//! - TP: the hand reacted after the onset and the object came to rest held;
//! - a reaction where the onset detector finds no slip is judged by how far the object
//!   settled across it ([`settle_across`]: the median height in the half second before the
//!   reaction against the half second after the catch): a settle past the drop threshold
//!   is a slip the detector's per-sample test missed in the noise (TP, D the settle); one
//!   the markers can tell from their own noise, but under the threshold, is "held, no
//!   measurable slip" (caught within a millimetre); none is an FP, a reaction to nothing
//!   (SPEC: no slip followed or preceded it);
//! - D: object height (relative to the hand) at the onset minus at rest after the catch.
//!
//! A trial with no onset and no reaction is a `NoSlip` trial (nothing to catch).
//!
//! On the simulator, [`truth_verdict`] gives a second verdict from ground truth (when gross
//! slip began, how far the object fell, whether it dropped), for a diagnostic of how often
//! the marker scoring agrees with it; it is never a feature or a label.

pub mod lift;

use tmo_hal::MarkerSample;

use crate::slip::labels::{find_onset, OnsetSpec};

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    TruePositive,
    FalsePositive,
    FalseNegative,
    /// Reacted, and the object never fell measurably.
    HeldNoSlip,
    NoSlip,
}

impl Verdict {
    /// What a person reads in a table.
    pub fn label(self) -> &'static str {
        match self {
            Verdict::TruePositive => "TP",
            Verdict::FalsePositive => "FP",
            Verdict::FalseNegative => "FN",
            Verdict::HeldNoSlip => "held, no measurable slip",
            Verdict::NoSlip => "no slip",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CatchOutcome {
    pub verdict: Verdict,
    pub onset_s: Option<f64>,
    pub reaction_s: Option<f64>,
    /// Reaction time after the onset, s (negative for an early reaction).
    pub latency_s: Option<f64>,
    pub dropped: bool,
    /// D, mm: only for a caught object.
    pub slip_distance_mm: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CatchSpec {
    pub onset: OnsetSpec,
    pub drop_limit_mm: f64,
    /// The object is at rest when the mean heights of the two halves of the last
    /// `rest_window_s` differ by less than this.
    pub rest_tolerance_mm: f64,
    pub rest_window_s: f64,
    /// How long before the marker onset a reaction may come and still count as after it.
    pub marker_lag_s: f64,
    /// The windows of the held height before a reaction and of the height after its
    /// catch, s relative to the reaction ([`settle_across`]).
    pub settle_before_s: (f64, f64),
    pub settle_after_s: (f64, f64),
    /// The smallest settle that counts as motion, mm, however quiet the markers are.
    pub settle_floor_mm: f64,
}

impl Default for CatchSpec {
    fn default() -> Self {
        Self {
            onset: OnsetSpec::default(),
            drop_limit_mm: 80.0,
            rest_tolerance_mm: 1.0,
            rest_window_s: 0.5,
            marker_lag_s: 0.07,
            // Before: the second up to 0.1 s before the reaction, leaving out the frames
            // in which the detector was seeing a slip begin. After: the second from 0.2 s
            // on, when a regrasp (8 ms latency, 50 ms servo loop, tendon slack) has caught
            // the object. A second each side: 60 samples, so that a few tenths of a mm
            // stand out of two markers' noise.
            settle_before_s: (-1.1, -0.1),
            settle_after_s: (0.2, 1.2),
            settle_floor_mm: 0.1,
        }
    }
}

fn relative_height(m: &MarkerSample) -> f64 {
    m.object_mm - m.hand_mm
}

/// Scores one trial from its marker track and the first reaction of the hand, if any.
pub fn score_catch(
    track: &[MarkerSample],
    reaction_s: Option<f64>,
    spec: &CatchSpec,
) -> CatchOutcome {
    let onset_s = find_onset(track, &spec.onset).map(|o| o.time_s);
    // Held height: the median before the onset (or before the reaction, or over the track).
    let until = onset_s.or(reaction_s).unwrap_or(f64::INFINITY);
    let mut before: Vec<f64> = track
        .iter()
        .filter(|m| m.time_s < until)
        .map(relative_height)
        .collect();
    before.sort_by(f64::total_cmp);
    let held = before.get(before.len() / 2).copied();
    let lowest = track
        .iter()
        .filter(|m| m.time_s >= until)
        .map(relative_height)
        .fold(f64::INFINITY, f64::min);
    let dropped = match held {
        Some(h) => lowest < h - spec.drop_limit_mm,
        None => false,
    };
    let at_rest = rest_height(track, spec);
    let settle = match (onset_s, reaction_s) {
        (None, Some(r)) => settle_across(track, r, spec),
        _ => None,
    };
    let verdict = match (onset_s, reaction_s) {
        // An early reaction is the detector's error whatever followed; `dropped` says that.
        (Some(o), Some(r)) if r < o - spec.marker_lag_s => Verdict::FalsePositive,
        (None, Some(_)) => match settle {
            Some(s) if s.fall_mm >= spec.onset.drop_threshold_mm => Verdict::TruePositive,
            Some(s) if s.fall_mm <= s.still_mm => Verdict::FalsePositive,
            // settled measurably but less than the threshold, or too short a track to say
            _ => Verdict::HeldNoSlip,
        },
        (_, _) if dropped => Verdict::FalseNegative,
        (Some(_), Some(_)) if at_rest.is_some() => Verdict::TruePositive,
        // reacted but never came to rest, or slipped with no reaction and not yet dropped
        (Some(_), _) => Verdict::FalseNegative,
        (None, None) => Verdict::NoSlip,
    };
    let onset_height =
        onset_s.and_then(|o| track.iter().find(|m| m.time_s >= o).map(relative_height));
    CatchOutcome {
        verdict,
        onset_s,
        reaction_s,
        latency_s: onset_s.zip(reaction_s).map(|(o, r)| r - o),
        dropped,
        slip_distance_mm: match (verdict, onset_height, at_rest, settle) {
            (Verdict::TruePositive, Some(o), Some(rest), _) => Some((o - rest).max(0.0)),
            (Verdict::TruePositive, None, _, Some(s)) => Some(s.fall_mm),
            _ => None,
        },
    }
}

/// How far the object settled across a reaction, and the least settle the markers can tell
/// from their noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settle {
    /// Relative height before the reaction minus after its catch (20 % trimmed means of
    /// the two windows), mm.
    pub fall_mm: f64,
    /// Three standard errors of that difference at the track's own noise, and at least
    /// `settle_floor_mm`. The noise is the median absolute step between samples before the
    /// reaction, over sqrt 2, as a normal standard deviation; a 20 % trimmed mean's
    /// standard error is 1.06 sigma / sqrt n for normal noise, and it shrugs off a
    /// mis-detected marker.
    pub still_mm: f64,
}

/// The settle across a reaction at `reaction_s`; `None` when either window has fewer than
/// ten samples.
pub fn settle_across(track: &[MarkerSample], reaction_s: f64, spec: &CatchSpec) -> Option<Settle> {
    let window = |(a, b): (f64, f64)| -> Vec<f64> {
        track
            .iter()
            .filter(|m| m.time_s >= reaction_s + a && m.time_s < reaction_s + b)
            .map(relative_height)
            .collect()
    };
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let trimmed_mean = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let cut = s.len() / 5;
        let kept = &s[cut..s.len() - cut];
        kept.iter().sum::<f64>() / kept.len() as f64
    };
    let (before, after) = (window(spec.settle_before_s), window(spec.settle_after_s));
    if before.len() < 10 || after.len() < 10 {
        return None;
    }
    let steps: Vec<f64> = before.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let sigma = median(&steps) / 0.6745 / std::f64::consts::SQRT_2;
    let se = 1.06 * sigma * (1.0 / before.len() as f64 + 1.0 / after.len() as f64).sqrt();
    Some(Settle {
        fall_mm: trimmed_mean(&before) - trimmed_mean(&after),
        still_mm: (3.0 * se).max(spec.settle_floor_mm),
    })
}

/// What the simulator knows of a trial (its ground truth), as a trial log records it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TruthRecord {
    /// Onset of the first slip that fell measurably (see `MEASURABLE_FALL_MM`).
    pub measurable_slip_s: Option<f64>,
    /// Onset of the trial's first gross slip, however far it fell.
    pub first_slip_s: Option<f64>,
    pub drop_s: Option<f64>,
}

/// The verdict ground truth gives, by the rules of [`score_catch`] where the markers can
/// see: an early reaction is an FP whatever followed; a drop is an FN; a reaction at or
/// after the onset that held is a TP. Where the markers cannot see (the object never fell
/// measurably), ground truth still can: a reaction that came before any gross slip is the
/// paper's FP ("action triggered before slip"); one that came after gross slip began and
/// caught it within the measurable fall is "held, no measurable slip".
pub fn truth_verdict(truth: &TruthRecord, reaction_s: Option<f64>) -> Verdict {
    match (truth.measurable_slip_s, reaction_s) {
        (Some(o), Some(r)) if r < o => Verdict::FalsePositive,
        _ if truth.drop_s.is_some() => Verdict::FalseNegative,
        (Some(_), Some(_)) => Verdict::TruePositive,
        (Some(_), None) => Verdict::FalseNegative,
        (None, Some(r)) if truth.first_slip_s.is_some_and(|s| s <= r) => Verdict::HeldNoSlip,
        (None, Some(_)) => Verdict::FalsePositive,
        (None, None) => Verdict::NoSlip,
    }
}

/// Over pairs of (marker verdict, truth verdict if known): how many have a truth verdict,
/// and in how many the two agree; `None` when none has one.
pub fn truth_agreement(
    pairs: impl IntoIterator<Item = (Verdict, Option<Verdict>)>,
) -> Option<(usize, usize)> {
    let (mut n, mut agree) = (0, 0);
    for (marker, truth) in pairs {
        if let Some(t) = truth {
            n += 1;
            agree += usize::from(t == marker);
        }
    }
    (n > 0).then_some((n, agree))
}

/// When the object had fallen more than the drop limit below its held height (the median
/// relative height before `onset_s`), if it did.
pub fn drop_time(track: &[MarkerSample], onset_s: f64, spec: &CatchSpec) -> Option<f64> {
    let mut before: Vec<f64> = track
        .iter()
        .filter(|m| m.time_s < onset_s)
        .map(relative_height)
        .collect();
    before.sort_by(f64::total_cmp);
    let held = *before.get(before.len() / 2)?;
    track
        .iter()
        .find(|m| m.time_s >= onset_s && relative_height(m) < held - spec.drop_limit_mm)
        .map(|m| m.time_s)
}

/// When the object, having slipped from `onset_s`, had come to rest for good (on a support,
/// or caught): the end of the first block of half a rest window from which the mean relative
/// heights of all later blocks stay within twice the rest tolerance. A stick-slip pause
/// followed by more slip is not rest.
pub fn rest_after(track: &[MarkerSample], onset_s: f64, spec: &CatchSpec) -> Option<f64> {
    let block_s = spec.rest_window_s / 2.0;
    let mut means: Vec<(f64, usize)> = Vec::new();
    for m in track.iter().filter(|m| m.time_s >= onset_s) {
        let k = ((m.time_s - onset_s) / block_s) as usize;
        if means.len() <= k {
            means.resize(k + 1, (0.0, 0));
        }
        means[k].0 += relative_height(m);
        means[k].1 += 1;
    }
    let means: Vec<(usize, f64)> = means
        .iter()
        .enumerate()
        .filter(|(_, (_, n))| *n > 0)
        .map(|(k, (sum, n))| (k, sum / *n as f64))
        .collect();
    // A rest needs at least a full window behind it.
    if means.len() < 2 {
        return None;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut start = None;
    for &(k, mean) in means.iter().rev() {
        lo = lo.min(mean);
        hi = hi.max(mean);
        if hi - lo >= 2.0 * spec.rest_tolerance_mm {
            break;
        }
        start = Some(k);
    }
    let k = start?;
    // The object may still have moved within block k: rest is certain from its end.
    (means.last().map(|l| l.0) > Some(k)).then(|| onset_s + (k + 1) as f64 * block_s)
}

/// Mean height over the last `rest_window_s` if the object was still there: the means of
/// the window's two halves differ by less than the tolerance. (A spread test would trip on
/// marker noise: the relative height carries both markers' noise, about 0.4 mm.)
fn rest_height(track: &[MarkerSample], spec: &CatchSpec) -> Option<f64> {
    let end = track.last()?.time_s;
    let tail: Vec<f64> = track
        .iter()
        .filter(|m| m.time_s >= end - spec.rest_window_s)
        .map(relative_height)
        .collect();
    if tail.len() < 6 {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (early, late) = tail.split_at(tail.len() / 2);
    ((mean(early) - mean(late)).abs() < spec.rest_tolerance_mm).then(|| mean(&tail))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 60 Hz track: held at 100 mm below the hand, slipping at 200 mm/s from `slip_s` for
    /// `slide_mm` (then held again), or falling freely if `slide_mm` is infinite.
    fn track(slip_s: Option<f64>, slide_mm: f64, seconds: f64) -> Vec<MarkerSample> {
        (0..(seconds * 60.0) as usize)
            .map(|i| {
                let t = i as f64 / 60.0;
                let fall = slip_s.map_or(0.0, |s| {
                    if t <= s {
                        0.0
                    } else if slide_mm.is_finite() {
                        (200.0 * (t - s)).min(slide_mm)
                    } else {
                        0.5 * 9810.0 * (t - s).powi(2)
                    }
                });
                let noise = 0.2 * (((i * 7919) % 11) as f64 / 11.0 - 0.5);
                MarkerSample {
                    time_s: t,
                    object_mm: 300.0 - fall + noise,
                    hand_mm: 400.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_reaction_after_onset_that_holds_the_object_is_a_true_positive() {
        let o = score_catch(
            &track(Some(1.0), 25.0, 3.0),
            Some(1.1),
            &CatchSpec::default(),
        );
        assert_eq!(o.verdict, Verdict::TruePositive);
        let onset = o.onset_s.unwrap();
        assert!((1.0..1.05).contains(&onset), "{onset}");
        assert!((o.latency_s.unwrap() - (1.1 - onset)).abs() < 1e-12);
        // D: from the first sample past 1 mm down to 25 mm down
        let d = o.slip_distance_mm.unwrap();
        assert!((d - 25.0).abs() < 3.5, "{d}");
    }

    #[test]
    fn reacting_before_onset_is_a_false_positive_and_a_fall_a_false_negative() {
        let spec = CatchSpec::default();
        let early = score_catch(&track(Some(1.0), 25.0, 3.0), Some(0.5), &spec);
        assert_eq!(early.verdict, Verdict::FalsePositive);
        assert!(early.latency_s.unwrap() < 0.0);
        // within the marker's lag before its onset: the fall had begun
        let prompt = score_catch(&track(Some(1.0), 25.0, 3.0), Some(0.97), &spec);
        assert_eq!(prompt.verdict, Verdict::TruePositive);
        assert!(prompt.latency_s.unwrap() < 0.0);
        // a reaction to nothing: the object never moved
        let never = score_catch(&track(None, 0.0, 3.0), Some(0.8), &spec);
        assert_eq!(never.verdict, Verdict::FalsePositive);
        // too early in the track to see what came before: not called an FP
        let unknown = score_catch(&track(None, 0.0, 3.0), Some(0.1), &spec);
        assert_eq!(unknown.verdict, Verdict::HeldNoSlip);

        let fell = score_catch(&track(Some(1.0), f64::INFINITY, 2.0), Some(1.2), &spec);
        assert_eq!(fell.verdict, Verdict::FalseNegative);
        assert!(fell.dropped && fell.slip_distance_mm.is_none());
        let unanswered = score_catch(&track(Some(1.0), f64::INFINITY, 2.0), None, &spec);
        assert_eq!(unanswered.verdict, Verdict::FalseNegative);
    }

    #[test]
    fn a_prompt_catch_under_a_millimetre_is_held_not_a_false_positive() {
        // slipping from 1.0 s, caught 0.6 mm down by a reaction 5 ms later: the markers
        // never see it cross the 1 mm threshold
        let o = score_catch(
            &track(Some(1.0), 0.6, 3.0),
            Some(1.005),
            &CatchSpec::default(),
        );
        assert_eq!(o.verdict, Verdict::HeldNoSlip);
        assert!(o.onset_s.is_none() && !o.dropped && o.slip_distance_mm.is_none());
    }

    /// Held 100 mm below the hand with noise `+noise, 0, -noise` repeating sample to
    /// sample, settling by `fall` mm over 30 ms from `at_s`.
    fn noisy_settle(at_s: f64, fall: f64, noise: f64) -> Vec<MarkerSample> {
        (0..240)
            .map(|i| {
                let t = i as f64 / 60.0;
                let f = fall * ((t - at_s) / 0.03).clamp(0.0, 1.0);
                MarkerSample {
                    time_s: t,
                    object_mm: 300.0 - f + noise * [1.0, 0.0, -1.0][i % 3],
                    hand_mm: 400.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_reaction_the_onset_detector_sees_nothing_around_is_judged_by_the_settle() {
        let spec = CatchSpec::default();
        // a 1.2 mm slip in 0.3 mm noise: no five samples in a row are past 1 mm, so the
        // detector finds no onset, but the half-second medians show the fall
        let missed = noisy_settle(1.2, 1.2, 0.3);
        assert!(find_onset(&missed, &spec.onset).is_none());
        let o = score_catch(&missed, Some(1.21), &spec);
        assert_eq!(o.verdict, Verdict::TruePositive);
        assert!((o.slip_distance_mm.unwrap() - 1.2).abs() < 0.05, "{o:?}");
        // 0.6 mm in the same noise: measurable, under the threshold
        let small = score_catch(&noisy_settle(1.2, 0.6, 0.3), Some(1.21), &spec);
        assert_eq!(small.verdict, Verdict::HeldNoSlip);
        // 0.12 mm in that noise cannot be told from none; in quiet markers it can
        let s = settle_across(&noisy_settle(1.2, 0.12, 0.3), 1.21, &spec).unwrap();
        assert!(s.fall_mm <= s.still_mm, "{s:?}");
        let quiet = score_catch(&noisy_settle(1.2, 0.12, 0.01), Some(1.21), &spec);
        assert_eq!(quiet.verdict, Verdict::HeldNoSlip);
        // a regrasp that lifts the object a little is no slip
        let lifted = score_catch(&noisy_settle(1.2, -0.3, 0.01), Some(1.21), &spec);
        assert_eq!(lifted.verdict, Verdict::FalsePositive);
    }

    #[test]
    fn truth_verdicts_follow_the_same_rules() {
        let slip = TruthRecord {
            measurable_slip_s: Some(1.0),
            first_slip_s: Some(1.0),
            drop_s: None,
        };
        assert_eq!(truth_verdict(&slip, Some(1.02)), Verdict::TruePositive);
        assert_eq!(truth_verdict(&slip, Some(0.9)), Verdict::FalsePositive);
        assert_eq!(truth_verdict(&slip, None), Verdict::FalseNegative);
        let dropped = TruthRecord {
            drop_s: Some(1.3),
            ..slip
        };
        assert_eq!(truth_verdict(&dropped, Some(1.1)), Verdict::FalseNegative);
        // the markers see nothing in either of these; ground truth tells them apart
        let still = TruthRecord::default();
        assert_eq!(truth_verdict(&still, Some(2.0)), Verdict::FalsePositive);
        assert_eq!(truth_verdict(&still, None), Verdict::NoSlip);
        let caught_within_a_mm = TruthRecord {
            first_slip_s: Some(1.96),
            ..still
        };
        assert_eq!(
            truth_verdict(&caught_within_a_mm, Some(2.0)),
            Verdict::HeldNoSlip
        );
        assert_eq!(
            truth_verdict(&caught_within_a_mm, Some(1.9)),
            Verdict::FalsePositive
        );
        use Verdict::*;
        let pairs = [
            (TruePositive, Some(TruePositive)),
            (FalsePositive, Some(HeldNoSlip)),
            (NoSlip, None),
        ];
        assert_eq!(truth_agreement(pairs), Some((2, 1)));
        assert_eq!(truth_agreement([(NoSlip, None)]), None);
    }

    #[test]
    fn a_still_object_and_a_still_hand_is_no_slip() {
        let o = score_catch(&track(None, 0.0, 3.0), None, &CatchSpec::default());
        assert_eq!(o.verdict, Verdict::NoSlip);
        assert!(!o.dropped && o.onset_s.is_none());
    }
}
