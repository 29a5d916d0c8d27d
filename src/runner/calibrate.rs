//! The calibration that finds g_min for the first-time lift (paper Sec. VI-B: "determined
//! for each object mass by systematically increasing the grasping strength until the
//! object could be lifted"): close to contact as the first-time lift does (g_cont), then
//! try closures `g_cont + k step`, k = 0, 1, ...: grip, lift, hold, judge from the marker
//! track, lower, open. The first closure whose lift the object follows is g_min.
//!
//! Each attempt is logged on `/phase`: `attempt` (with `attempt` and `closure`),
//! `lifting`, `hold_end` and `judged` (with `lifted` and the rise); `calibrated` (with
//! `g_min`) ends a successful sweep. The judgement is the same function scoring uses
//! ([`crate::outcome::lift::rise`]), so scoring the log gives the same g_min.

use std::sync::atomic::AtomicBool;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::lift::{move_time_s, LiftRun};
use super::monitor::WatchLimits;
use super::RunRecord;
use crate::outcome::lift::{rise, LiftSpec, LiftWindow, Rise};
use crate::runner::devices::{Devices, ScenarioError};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationParams {
    pub deformation_px: f64,
    pub approach_speed_per_s: f64,
    pub max_closure: f64,
    /// Closure added per attempt, fraction of the range.
    pub step: f64,
    pub lift_mm: f64,
    pub lift_speed_mm_s: f64,
    pub hold_s: f64,
    /// An attempt lifts the object if the hand went up it by at most this, mm.
    pub max_slide_mm: f64,
    pub watch: WatchLimits,
}

/// Did the object follow the hand?
pub fn lifted(r: &Rise, max_slide_mm: f64) -> bool {
    r.hand_mm > 0.0 && r.slid_mm() <= max_slide_mm
}

pub fn run_calibration<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &CalibrationParams,
    stop: &AtomicBool,
) -> Result<RunRecord, ScenarioError>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    let mut run = LiftRun::new(dev, None, p.watch)?;
    let contact = match run.close_to_contact(
        p.deformation_px,
        p.approach_speed_per_s,
        p.max_closure,
        stop,
    )? {
        Ok(q) => q,
        Err(f) => return run.finish(None, None, Some(f)),
    };
    let open = run.start[0];
    let spec = LiftSpec::default();
    let mut attempt = 0u32;
    loop {
        let closure = contact + attempt as f64 * p.step;
        if closure > p.max_closure + 1e-12 {
            return run.finish(None, None, None);
        }
        let now = run.dev.clock.now_s();
        run.phase(
            now,
            "attempt",
            json!({ "attempt": attempt, "closure": closure }),
        );
        run.grip(closure)?;
        // The fingers travel from open at most the whole range at the servo's pace; wait for
        // them and for the skin to settle.
        if let Some(f) = run.idle_until(now + 0.6, stop)? {
            return run.finish(None, None, Some(f));
        }
        let lift_start = run.dev.clock.now_s();
        run.phase(lift_start, "lifting", json!({}));
        run.raise(p.lift_mm, p.lift_speed_mm_s)?;
        let hold_end = lift_start + move_time_s(p.lift_mm, p.lift_speed_mm_s) + p.hold_s;
        if let Some(f) = run.idle_until(hold_end, stop)? {
            return run.finish(None, None, Some(f));
        }
        let now = run.dev.clock.now_s();
        run.phase(now, "hold_end", json!({ "closure": closure }));
        let window = LiftWindow {
            lift_start_s: lift_start,
            hold_end_s: now,
        };
        let r = rise(&run.trial.rec.markers, &window, &spec);
        let ok = r.is_some_and(|r| lifted(&r, p.max_slide_mm));
        run.phase(now, "judged", json!({ "lifted": ok, "rise": r }));
        run.raise(-p.lift_mm, p.lift_speed_mm_s)?;
        let down = now + move_time_s(p.lift_mm, p.lift_speed_mm_s);
        if let Some(f) = run.idle_until(down, stop)? {
            return run.finish(None, None, Some(f));
        }
        let now = run.dev.clock.now_s();
        run.grip(open)?;
        if ok {
            run.phase(
                now,
                "calibrated",
                json!({ "g_cont": contact, "g_min": closure }),
            );
            let fault = run.idle_until(now + 0.5, stop)?;
            return run.finish(None, None, fault);
        }
        if let Some(f) = run.idle_until(now + 0.6, stop)? {
            return run.finish(None, None, Some(f));
        }
        attempt += 1;
    }
}
