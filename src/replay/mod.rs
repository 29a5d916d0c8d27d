//! Closed-loop counterfactual evaluation on recorded trials: what a model and strategy
//! would have done, through the live detector code on the replay backend
//! ([`backend`], [`crate::runner::replay`]), scored against the marker track.
//!
//! The recorded world cannot react, so a replayed reaction is judged only up to the
//! recorded hand's own reaction: later than that, the recording shows the live regrasp,
//! not the slip continuing, and the verdict is `after_logged` (undetermined).

pub mod backend;

use std::sync::atomic::AtomicBool;

use crate::online::classify::Reaction;
use crate::online::strategy::Strategy;
use crate::outcome::{drop_time, rest_after, CatchSpec};
use crate::runner::devices::ScenarioError;
use crate::runner::monitor::WatchLimits;
use crate::runner::replay::{run_replay, ArmedWindow, ReplayParams};
use crate::runner::{Fault, Online, RunRecord, TICK_S};
use crate::slip::labels::trial_onset;
use crate::slip::slip_model::SlipModel;
use crate::trial::{is_reaction, Trial};

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReplayVerdict {
    /// Reacted after the onset, before the recorded hand did and before the object fell
    /// past the drop limit.
    Detected,
    /// Reacted before the onset (by more than the marker's lag), or with no slip at all.
    FalsePositive,
    /// No reaction although the object slipped and nothing caught it in the recording, or a
    /// reaction only once it had fallen past the drop limit or come to rest.
    Missed,
    /// Would have reacted (or not) only after the recorded hand's reaction: unknown.
    AfterLogged,
    /// No slip and no reaction.
    NoSlip,
    /// The replay stopped at a sensor fault, as the live run would have.
    Aborted,
}

/// What one model and strategy would have done on one recorded trial.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ReplayOutcome {
    pub trial: String,
    pub trial_id: String,
    pub model: String,
    pub strategy: String,
    pub window: String,
    pub onset_s: Option<f64>,
    pub reaction_s: Option<f64>,
    pub reaction_sensor: Option<u8>,
    pub reaction_seq: Option<u64>,
    /// Reaction time after the onset, s (negative: before it).
    pub latency_s: Option<f64>,
    /// Frames of the reacting sensor from the onset to the reaction (negative: before).
    pub latency_frames: Option<i64>,
    pub verdict: ReplayVerdict,
    /// The first reaction the log holds, s.
    pub logged_reaction_s: Option<f64>,
    /// Same frame (time, sensor and sequence number) as the logged reaction; `None` unless
    /// this is the model (by SHA-256) and strategy the trial ran with.
    pub matches_logged: Option<bool>,
    pub fault: Option<String>,
}

/// The first reaction in the log: (frame time, sensor, seq).
pub fn logged_reaction(trial: &Trial) -> Option<(f64, u8, u64)> {
    let e = trial.events.iter().find(|e| is_reaction(e))?;
    Some((
        e.data.get("frame_time_s")?.as_f64()?,
        e.data.get("sensor")?.as_u64()? as u8,
        e.data.get("seq")?.as_u64()?,
    ))
}

/// Replays `trial` through `model` and `strategy` on the replay backend.
pub fn replay_trial(
    trial: &Trial,
    model: &SlipModel,
    strategy: Strategy,
) -> Result<(RunRecord, &'static str), ScenarioError> {
    let (window, source) = ArmedWindow::of(trial);
    let first = trial.arrivals_s.first().copied().unwrap_or(0.0);
    let last = trial.arrivals_s.last().copied().unwrap_or(0.0);
    // Tick as the live runner did: its polls fell on the recorded arrival times.
    let (mut devices, _) = backend::replay_devices(trial, first - TICK_S);
    let params = ReplayParams {
        window,
        end_s: last + 0.1,
        watch: WatchLimits::default(),
    };
    let online = Online { model, strategy };
    let record = run_replay(&mut devices, &params, online, &AtomicBool::new(false))?;
    Ok((record, source))
}

/// Scores a replayed reaction against the recording.
pub fn judge(
    trial: &Trial,
    reaction: Option<Reaction>,
    fault: Option<Fault>,
    spec: &CatchSpec,
) -> (ReplayVerdict, Option<f64>, Option<i64>) {
    let onset = trial_onset(trial, &spec.onset);
    let logged = logged_reaction(trial).map(|l| l.0);
    let latency = reaction.zip(onset).map(|(r, o)| r.time_s - o);
    let frames = reaction.zip(onset).map(|(r, o)| {
        let (lo, hi) = if r.time_s >= o {
            (o, r.time_s)
        } else {
            (r.time_s, o)
        };
        let n = trial
            .frames
            .iter()
            .filter(|f| f.sensor == r.sensor && f.time_s > lo && f.time_s <= hi)
            .count() as i64;
        if r.time_s >= o {
            n
        } else {
            -n
        }
    });
    // A reaction once the object had fallen past the drop limit, or had come to rest (on
    // the table below a low lift), catches nothing.
    // Only what happened before the recorded hand reacted counts: after that a rest may be
    // its catch.
    let too_late_s = onset
        .and_then(|o| {
            let d = drop_time(&trial.markers, o, spec);
            let r = rest_after(&trial.markers, o, spec);
            d.into_iter().chain(r).reduce(f64::min)
        })
        .filter(|t| logged.is_none_or(|l| *t < l));
    let verdict = match (reaction, onset) {
        _ if fault.is_some() && reaction.is_none() => ReplayVerdict::Aborted,
        (Some(r), _) if logged.is_some_and(|l| r.time_s > l + 1e-9) => ReplayVerdict::AfterLogged,
        // reacting once the object is gone catches nothing
        (Some(r), _) if too_late_s.is_some_and(|d| r.time_s > d) => ReplayVerdict::Missed,
        (Some(r), Some(o)) if r.time_s < o - spec.marker_lag_s => ReplayVerdict::FalsePositive,
        (Some(_), Some(_)) => ReplayVerdict::Detected,
        (Some(_), None) => ReplayVerdict::FalsePositive,
        (None, Some(_)) if logged.is_some() => ReplayVerdict::AfterLogged,
        (None, Some(_)) => ReplayVerdict::Missed,
        (None, None) => ReplayVerdict::NoSlip,
    };
    (verdict, latency, frames)
}

/// A model to replay, as named on the command line.
#[derive(Clone, Copy)]
pub struct ModelRef<'m> {
    pub name: &'m str,
    pub sha256: &'m str,
    pub file: &'m SlipModel,
}

/// Why a trial could not be replayed: the replay failed, or the model gave no finite value
/// for a frame (offline, an error, as `tmo evaluate` makes it; never an aborted replay).
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("{model}: the slip value of sensor {sensor}'s frame {seq} is {output}, not a finite number: a non-finite value is neither slip nor static")]
    ModelOutput {
        model: String,
        sensor: u8,
        seq: u64,
        output: crate::online::classify::BadOutput,
    },
}

/// Replays and judges one trial.
pub fn evaluate(
    trial: &Trial,
    trial_path: &str,
    model: ModelRef<'_>,
    strategy: Strategy,
    spec: &CatchSpec,
) -> Result<ReplayOutcome, ReplayError> {
    let (record, source) = replay_trial(trial, model.file, strategy)?;
    if let Some(Fault::ModelOutput {
        sensor,
        seq,
        output,
    }) = record.fault
    {
        return Err(ReplayError::ModelOutput {
            model: model.name.to_string(),
            sensor,
            seq,
            output,
        });
    }
    let (verdict, latency_s, latency_frames) = judge(trial, record.reaction, record.fault, spec);
    let logged = logged_reaction(trial);
    let r = record.reaction;
    Ok(ReplayOutcome {
        trial: trial_path.to_string(),
        trial_id: trial.meta.trial_id.clone(),
        model: model.name.to_string(),
        strategy: strategy.to_string(),
        window: source.to_string(),
        onset_s: trial_onset(trial, &spec.onset),
        reaction_s: r.map(|r| r.time_s),
        reaction_sensor: r.map(|r| r.sensor),
        reaction_seq: r.map(|r| r.seq),
        latency_s,
        latency_frames,
        verdict,
        logged_reaction_s: logged.map(|l| l.0),
        // Only the model and strategy the trial ran with can be compared with its log.
        matches_logged: (trial.meta.model_sha256.as_deref() == Some(model.sha256)
            && trial.meta.parameters.get("strategy") == Some(&strategy.to_string()))
        .then(|| match (logged, r) {
            (Some(l), Some(r)) => l == (r.time_s, r.sensor, r.seq),
            (None, None) => true,
            _ => false,
        }),
        fault: record
            .fault
            .map(|f| serde_json::to_string(&f).unwrap_or_default()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmo_hal::MarkerSample;

    fn trial_with_fall(fall_at: f64) -> Trial {
        trial_with_fall_onto(fall_at, f64::INFINITY)
    }

    /// The object falls from `fall_at` and lands `depth_mm` lower.
    fn trial_with_fall_onto(fall_at: f64, depth_mm: f64) -> Trial {
        let mut t = crate::trial::tests::sample_trial();
        t.events.clear();
        t.markers = (0..200)
            .map(|i| {
                let time_s = i as f64 / 60.0;
                let fall = (time_s - fall_at).max(0.0);
                MarkerSample {
                    time_s,
                    object_mm: 300.0 - (0.5 * 9810.0 * fall * fall).min(depth_mm),
                    hand_mm: 360.0,
                }
            })
            .collect();
        t
    }

    fn at(time_s: f64) -> Option<Reaction> {
        Some(Reaction {
            time_s,
            sensor: 0,
            seq: 1,
        })
    }

    #[test]
    fn reactions_are_judged_against_the_onset_and_the_logged_reaction() {
        let spec = CatchSpec::default();
        let t = trial_with_fall(1.0);
        let onset = trial_onset(&t, &spec.onset).unwrap();
        assert_eq!(
            judge(&t, at(onset + 0.05), None, &spec).0,
            ReplayVerdict::Detected
        );
        assert_eq!(
            judge(&t, at(0.5), None, &spec).0,
            ReplayVerdict::FalsePositive
        );
        assert_eq!(judge(&t, None, None, &spec).0, ReplayVerdict::Missed);
        // 80 mm of free fall takes 0.13 s: a reaction after that is too late
        assert_eq!(
            judge(&t, at(onset + 0.5), None, &spec).0,
            ReplayVerdict::Missed
        );
        let (_, latency, _) = judge(&t, at(onset + 0.05), None, &spec);
        assert!((latency.unwrap() - 0.05).abs() < 1e-9);
        // once the log holds a reaction, anything later (or nothing) is undetermined
        let mut caught = t.clone();
        caught.events.push(crate::runner::event(
            onset + 0.02,
            "/detector",
            serde_json::json!({"event": "reaction", "frame_time_s": onset + 0.02, "sensor": 0, "seq": 9}),
        ));
        assert_eq!(
            judge(&caught, at(onset + 0.05), None, &spec).0,
            ReplayVerdict::AfterLogged
        );
        assert_eq!(
            judge(&caught, None, None, &spec).0,
            ReplayVerdict::AfterLogged
        );
        assert_eq!(
            judge(&caught, at(onset + 0.01), None, &spec).0,
            ReplayVerdict::Detected
        );
        // a short fall onto the table: once the object lies there, a reaction is too late
        let landed = trial_with_fall_onto(1.0, 30.0);
        assert_eq!(
            judge(&landed, at(onset + 0.03), None, &spec).0,
            ReplayVerdict::Detected
        );
        assert_eq!(
            judge(&landed, at(onset + 1.0), None, &spec).0,
            ReplayVerdict::Missed
        );
        let still = trial_with_fall(99.0);
        assert_eq!(judge(&still, None, None, &spec).0, ReplayVerdict::NoSlip);
        assert_eq!(
            judge(&still, at(1.0), None, &spec).0,
            ReplayVerdict::FalsePositive
        );
    }
}
