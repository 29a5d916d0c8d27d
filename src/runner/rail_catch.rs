//! Single finger on the slip rail (SPEC.md "rail_catch"): the finger presses the object
//! against a low-friction rail and the arm retracts until the object slips; with a model,
//! on slip the arm stops, moves `forward_mm` back towards the object and the finger's
//! torque limit rises by `torque_step`.

use std::sync::atomic::AtomicBool;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerSample, MarkerTracker, TactileSensor};

use super::monitor::{Verdict, WatchLimits};
use super::trial_run::TrialRun;
use super::{Fault, Online, RunRecord, SETTLE_S};
use crate::online::classify::Reaction;
use crate::runner::devices::{device, Devices, ScenarioError};

/// How far below where it started the marker must see the object for it to have left the
/// fingertip (the outcome's drop limit): a trial ends its watch after that, as after a
/// reaction, rather than recording an empty rail until the retraction ends.
const DROPPED_MM: f64 = 80.0;

fn has_dropped(markers: &[MarkerSample]) -> bool {
    match (markers.first(), markers.last()) {
        (Some(first), Some(last)) => last.object_mm < first.object_mm - DROPPED_MM,
        _ => false,
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RailParams {
    pub retract_speed_mm_s: f64,
    pub retract_mm: f64,
    pub forward_mm: f64,
    pub forward_speed_mm_s: f64,
    /// Finger torque limit at the start, fraction of the maximum.
    pub torque_limit: f64,
    pub torque_step: f64,
    /// The torque limit never rises past this.
    pub max_torque: f64,
    pub observe_s: f64,
    pub max_duration_s: f64,
    pub watch: WatchLimits,
}

pub fn run_rail<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &RailParams,
    online: Option<Online<'_>>,
    stop: &AtomicBool,
) -> Result<RunRecord, ScenarioError>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    let mut run = TrialRun::begin(dev, online, p.watch);
    let t0 = run.t0;
    dev.hand
        .set_torque_limit(p.torque_limit)
        .map_err(device("hand"))?;
    run.log(t0, "/command/hand", json!({"torque_limit": p.torque_limit}));
    dev.arm
        .move_linear([-p.retract_mm, 0.0, 0.0], p.retract_speed_mm_s)
        .map_err(device("arm"))?;
    run.log(
        t0,
        "/command/arm",
        json!({"move_linear_mm": [-p.retract_mm, 0.0, 0.0], "speed_mm_s": p.retract_speed_mm_s}),
    );
    let (mut reaction, mut fault): (Option<Reaction>, Option<Fault>) = (None, None);
    let mut dropped_at = None;
    loop {
        let now = dev.clock.now_s();
        let watched = |at: Option<f64>| at.is_some_and(|t| now >= t + p.observe_s);
        if now - t0 >= p.max_duration_s
            || watched(reaction.map(|r| r.time_s))
            || watched(dropped_at)
        {
            break;
        }
        if dropped_at.is_none() && has_dropped(&run.rec.markers) {
            dropped_at = Some(now);
        }
        // armed from the tick on which the settling time ends
        let waiting = reaction.is_none() && now + super::TICK_S - t0 >= SETTLE_S;
        let unreacted = reaction.is_none();
        let step = run.step(dev, waiting, |now| unreacted && now - t0 >= SETTLE_S, stop)?;
        let now = step.now;
        match step.verdict {
            Verdict::Continue => {}
            Verdict::Abort(f) => {
                // Make safe: the fingers hold; the arm stops below.
                fault = Some(f);
                dev.hold_hand(now, &mut run.events)?;
                break;
            }
            Verdict::React(r) if reaction.is_none() => {
                reaction = Some(r);
                dev.arm.stop().map_err(device("arm"))?;
                dev.arm
                    .move_linear([p.forward_mm, 0.0, 0.0], p.forward_speed_mm_s)
                    .map_err(device("arm"))?;
                let torque = (p.torque_limit + p.torque_step).min(p.max_torque);
                dev.hand.set_torque_limit(torque).map_err(device("hand"))?;
                run.log(
                    now,
                    "/command/arm",
                    json!({"move_linear_mm": [p.forward_mm, 0.0, 0.0], "speed_mm_s": p.forward_speed_mm_s}),
                );
                run.log(now, "/command/hand", json!({"torque_limit": torque}));
            }
            Verdict::React(_) => {}
        }
    }
    dev.arm.stop().map_err(device("arm"))?;
    run.log(dev.clock.now_s(), "/command/arm", json!({"stop": true}));
    Ok(run.finish(dev.clock.now_s(), Some(t0 + SETTLE_S), reaction, fault))
}
