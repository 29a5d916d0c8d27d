//! Grasp destabilisation (SPEC.md "rice_pour"): the object is held with a light grasp
//! while mass is poured in; every time the strategy fires, the fingers close by `regrasp`
//! more and the detector starts afresh. Success is never dropping the object.

use std::sync::atomic::AtomicBool;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::approach::{ApproachStep, ContactApproach, ContactGrasp};
use super::monitor::{Verdict, WatchLimits};
use super::trial_run::TrialRun;
use super::{Fault, Online, RunRecord, SETTLE_S};
use crate::online::classify::Reaction;
use crate::runner::devices::{device, Devices, ScenarioError};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PourParams {
    /// Tighten by this fraction of the range on every response.
    pub regrasp: f64,
    /// Never close past this.
    pub max_closure: f64,
    /// How long the pour lasts (from when the grasp is set), s.
    pub duration_s: f64,
    /// Close on the object from contact first (on a rig, where an operator holds the empty
    /// container between the open fingers); without it the trial starts from the grasp the
    /// hand already has.
    pub contact: Option<ContactGrasp>,
    pub watch: WatchLimits,
}

/// The operator lets go once the hand holds the container: this long after the grasp.
const LET_GO_S: f64 = 1.0;

pub fn run_pour<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &PourParams,
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
    let mut targets = dev.hand.present_positions().map_err(device("hand"))?;
    dev.hand.set_targets(targets).map_err(device("hand"))?;
    run.log(t0, "/command/hand", json!({ "targets": targets }));
    let (mut first, mut fault): (Option<Reaction>, _) = (None, None);
    let mut pour_t0 = t0;
    if let Some(c) = p.contact {
        let from = targets[..3].iter().copied().fold(f64::INFINITY, f64::min);
        let mut approach = ContactApproach::new(c, dev.sensors.len(), from, t0);
        run.log(t0, "/phase", json!({"phase": "approaching"}));
        let grasped = loop {
            let now = dev.clock.now_s();
            match approach.step(now) {
                ApproachStep::Close(q) => {
                    targets[..3].fill(q);
                    dev.hand.set_targets(targets).map_err(device("hand"))?;
                }
                ApproachStep::Contact {
                    closure,
                    grasp,
                    deformation_px,
                } => {
                    run.log(
                        now,
                        "/phase",
                        json!({"phase": "contact", "closure": closure, "deformation_px": deformation_px}),
                    );
                    targets[..3].fill(grasp);
                    dev.hand.set_targets(targets).map_err(device("hand"))?;
                    run.log(now, "/command/hand", json!({ "targets": targets }));
                    break Ok(now);
                }
                ApproachStep::NoContact { deformation_px } => {
                    let f = Fault::NoContact { deformation_px };
                    run.log(now, "/fault", json!(f));
                    break Err(f);
                }
            }
            let step = run.step(dev, false, |_| false, stop)?;
            approach.observe(&run.rec.frames[step.first_new..]);
            if let Verdict::Abort(f) = step.verdict {
                break Err(f);
            }
        };
        match grasped {
            Ok(at) => {
                // the pour begins once the operator has let go
                while dev.clock.now_s() < at + LET_GO_S {
                    if let Verdict::Abort(f) = run.step(dev, false, |_| false, stop)?.verdict {
                        fault = Some(f);
                        break;
                    }
                }
                pour_t0 = dev.clock.now_s();
                run.log(pour_t0, "/phase", json!({"phase": "pouring"}));
            }
            Err(f) => fault = Some(f),
        }
        if fault.is_some() {
            let now = dev.clock.now_s();
            dev.hold_hand(now, &mut run.events)?;
        }
    }
    // a grasp that failed leaves nothing to pour into
    let pouring = fault.is_none();
    while pouring && dev.clock.now_s() - pour_t0 < p.duration_s {
        // armed from the tick on which the settling time ends
        let waiting = dev.clock.now_s() + super::TICK_S - pour_t0 >= SETTLE_S;
        let step = run.step(dev, waiting, |now| now - pour_t0 >= SETTLE_S, stop)?;
        let now = step.now;
        match step.verdict {
            Verdict::Continue => {}
            Verdict::Abort(f) => {
                // Make safe: the fingers hold; the arm stops below.
                fault = Some(f);
                dev.hold_hand(now, &mut run.events)?;
                break;
            }
            Verdict::React(r) => {
                first.get_or_insert(r);
                for t in targets.iter_mut().take(3) {
                    *t = (*t + p.regrasp).min(p.max_closure);
                }
                dev.hand.set_targets(targets).map_err(device("hand"))?;
                run.log(now, "/command/hand", json!({ "targets": targets }));
                run.monitor.rearm();
            }
        }
    }
    dev.arm.stop().map_err(device("arm"))?;
    let armed_s = pouring.then_some(pour_t0 + SETTLE_S);
    Ok(run.finish(dev.clock.now_s(), armed_s, first, fault))
}
