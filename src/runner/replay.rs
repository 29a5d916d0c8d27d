//! The replay runner: the live [`FrameMonitor`](super::monitor::FrameMonitor) (watchdog, per-frame classification,
//! `NFr x NSen` detector) on the live control tick, over any backend, with the detector armed
//! exactly when the recorded runner had it armed. It stops at the first reaction: after
//! the recorded hand reacted the recorded world no longer shows what an unanswered slip
//! would have done, so later reactions would mean nothing.
//!
//! It does not re-run the protocol's state machine: a recorded world cannot follow its
//! commands, so the window comes from the log instead.

use std::sync::atomic::AtomicBool;

use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::monitor::{Verdict, WatchLimits};
use super::trial_run::TrialRun;
use super::{Online, RunRecord, SETTLE_S};
use crate::runner::devices::{Devices, ScenarioError};
use crate::trial::Trial;

/// When the detector counts frames.
#[derive(Debug, Clone, PartialEq)]
pub enum ArmedWindow {
    /// The runner logged each change (`/detector` `armed` / `disarmed` at the poll time
    /// of the first batch fed that way).
    Logged(Vec<(f64, bool)>),
    /// From a phase or time on: batches polled after `from_s` (or at it, if `inclusive`).
    From { from_s: f64, inclusive: bool },
}

/// Slack on logged times, s (they went through a nanosecond log format).
const SLACK_S: f64 = 1e-6;

impl ArmedWindow {
    /// The window of a recorded trial, and where it came from: logged changes; else the
    /// release phase (hand release, as its runner arms); else the `armed_s` the runner
    /// recorded; else from the settle time after the first frame (collect logs of rigs
    /// without phases).
    pub fn of(trial: &Trial) -> (Self, &'static str) {
        let changes: Vec<(f64, bool)> = trial
            .events
            .iter()
            .filter(|e| e.topic == "/detector")
            .filter_map(|e| match e.data.get("event")?.as_str()? {
                "armed" => Some((e.time_s, true)),
                "disarmed" => Some((e.time_s, false)),
                _ => None,
            })
            .collect();
        if !changes.is_empty() {
            return (ArmedWindow::Logged(changes), "logged");
        }
        let releasing = trial
            .events
            .iter()
            .find(|e| e.topic == "/phase" && e.data["phase"] == "releasing");
        if let Some(e) = releasing {
            let w = ArmedWindow::From {
                from_s: e.time_s,
                inclusive: false,
            };
            return (w, "release phase");
        }
        if let Some(a) = trial
            .meta
            .parameters
            .get("armed_s")
            .and_then(|v| v.parse().ok())
        {
            let w = ArmedWindow::From {
                from_s: a,
                inclusive: true,
            };
            return (w, "armed_s");
        }
        let first = trial.arrivals_s.first().copied().unwrap_or(0.0);
        let w = ArmedWindow::From {
            from_s: first + SETTLE_S,
            inclusive: true,
        };
        (w, "settle time")
    }

    /// Is a batch polled at `poll_s` fed armed?
    pub fn armed(&self, poll_s: f64) -> bool {
        match self {
            ArmedWindow::Logged(changes) => changes
                .iter()
                .take_while(|(t, _)| *t <= poll_s + SLACK_S)
                .last()
                .is_some_and(|(_, a)| *a),
            ArmedWindow::From { from_s, inclusive } => {
                if *inclusive {
                    poll_s >= from_s - SLACK_S
                } else {
                    poll_s > from_s + SLACK_S
                }
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct ReplayParams {
    pub window: ArmedWindow,
    /// Stop here if nothing happened, s.
    pub end_s: f64,
    pub watch: WatchLimits,
}

pub fn run_replay<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &ReplayParams,
    online: Online<'_>,
    stop: &AtomicBool,
) -> Result<RunRecord, ScenarioError>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    let mut run = TrialRun::begin(dev, Some(online), p.watch);
    let (mut reaction, mut fault) = (None, None);
    while dev.clock.now_s() < p.end_s {
        let waiting = p.window.armed(dev.clock.now_s());
        match run
            .step(dev, waiting, |now| p.window.armed(now), stop)?
            .verdict
        {
            Verdict::Continue => {}
            Verdict::Abort(f) => {
                fault = Some(f);
                break;
            }
            Verdict::React(r) => {
                reaction = Some(r);
                break;
            }
        }
    }
    Ok(run.finish(dev.clock.now_s(), None, reaction, fault))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_arm_the_batches_the_runner_armed() {
        let logged = ArmedWindow::Logged(vec![(1.0, true), (2.0, false)]);
        assert!(!logged.armed(0.999));
        assert!(logged.armed(1.0));
        assert!(logged.armed(1.999));
        assert!(!logged.armed(2.0));
        let strict = ArmedWindow::From {
            from_s: 1.0,
            inclusive: false,
        };
        assert!(!strict.armed(1.0) && strict.armed(1.001));
        let inclusive = ArmedWindow::From {
            from_s: 1.0,
            inclusive: true,
        };
        assert!(inclusive.armed(1.0) && !inclusive.armed(0.999));
    }
}
