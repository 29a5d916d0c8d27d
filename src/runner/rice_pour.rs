//! Grasp destabilisation (SPEC.md "rice_pour"): the object is held with a light grasp
//! while mass is poured in; every time the strategy fires, the fingers close by `regrasp`
//! more and the detector starts afresh. Success is never dropping the object.

use std::sync::atomic::AtomicBool;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::monitor::{FrameMonitor, Verdict, WatchLimits};
use super::{event, Online, RunRecord, SETTLE_S};
use crate::online::classify::Reaction;
use crate::scenario::{device, Devices, Recording, ScenarioError};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PourParams {
    /// Tighten by this fraction of the range on every response.
    pub regrasp: f64,
    /// Never close past this.
    pub max_closure: f64,
    /// How long the pour (and the trial) lasts, s.
    pub duration_s: f64,
    pub watch: WatchLimits,
}

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
    let t0 = dev.clock.now_s();
    let mut monitor = FrameMonitor::new(dev.sensors.len(), online, p.watch, t0);
    let mut rec = Recording::default();
    let mut targets = dev.hand.present_positions().map_err(device("hand"))?;
    dev.hand.set_targets(targets).map_err(device("hand"))?;
    let mut events = vec![event(t0, "/command/hand", json!({ "targets": targets }))];
    let (mut first, mut fault): (Option<Reaction>, _) = (None, None);
    while dev.clock.now_s() - t0 < p.duration_s {
        let (first_new, now) = dev.tick(&mut rec)?;
        let armed = now - t0 >= SETTLE_S;
        match monitor.feed(&rec.frames[first_new..], now, armed, stop, &mut events) {
            Verdict::Continue => {}
            Verdict::Abort(f) => {
                // Make safe: the fingers hold; the arm stops below.
                fault = Some(f);
                dev.hold_hand(now, &mut events)?;
                break;
            }
            Verdict::React(r) => {
                first.get_or_insert(r);
                for t in targets.iter_mut().take(3) {
                    *t = (*t + p.regrasp).min(p.max_closure);
                }
                dev.hand.set_targets(targets).map_err(device("hand"))?;
                events.push(event(now, "/command/hand", json!({ "targets": targets })));
                monitor.rearm();
            }
        }
    }
    dev.arm.stop().map_err(device("arm"))?;
    Ok(RunRecord {
        recording: rec,
        armed_s: Some(t0 + SETTLE_S),
        reaction: first,
        fault,
        ended_s: dev.clock.now_s(),
        events,
    })
}
