//! What a planned trial asks of its runner, the same on every backend: each kind's run
//! parameters from the protocol, and the trial's random draws from its seed (so a trial on
//! the served simulator meets the world the sim backend would build for it).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::approach::ContactGrasp;
use super::batch::PlannedTrial;
use super::calibrate::CalibrationParams;
use super::hand_release::ReleaseParams;
use super::lift::LiftParams;
use super::monitor::WatchLimits;
use super::rail_catch::RailParams;
use super::rice_pour::PourParams;
use crate::protocol::{
    Calibration, FirstTimeLift, HandRelease, PerObject, Plan, RailCatch, RicePour,
};

/// The random parts of a trial a hand-set rig would vary, drawn from its seed (the same on
/// every backend, so a served-simulator trial meets the sim backend's world).
pub(crate) fn trial_rng(planned: &PlannedTrial) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(planned.seed);
    rng.set_stream(7);
    rng
}

/// The rail's retract speed for a trial, drawn from the protocol's range.
pub(crate) fn retract_speed_mm_s(p: &RailCatch, planned: &PlannedTrial) -> f64 {
    let [lo, hi] = p.retract_speed_mm_s;
    if hi > lo {
        trial_rng(planned).gen_range(lo..hi)
    } else {
        lo
    }
}

/// The grasp from contact a protocol asks for `object`, if it gives one.
fn contact_grasp(
    plan: &Plan,
    past_contact: Option<&PerObject>,
    object: &str,
    deformation_px: f64,
    approach_speed_per_s: f64,
) -> Option<ContactGrasp> {
    past_contact
        .and_then(|g| g.get(object))
        .map(|past_contact| ContactGrasp {
            deformation_px,
            approach_speed_per_s,
            past_contact,
            max_closure: plan.safety.max_grip,
        })
}

/// The hand-release parameters every backend shares; `closure` is the starting grasp when
/// the protocol does not find it from contact.
pub(crate) fn release_params(
    plan: &Plan,
    p: &HandRelease,
    object: &str,
    closure: f64,
    reference_speed_per_s: f64,
    watch: WatchLimits,
) -> ReleaseParams {
    ReleaseParams {
        closure,
        contact: contact_grasp(
            plan,
            p.grasp_past_contact.as_ref(),
            object,
            p.contact_deformation_px,
            p.approach_speed_of_max * reference_speed_per_s,
        ),
        close_speed_per_s: 0.05,
        lift_mm: p.lift_mm,
        lift_speed_mm_s: p.lift_speed_mm_s,
        hold_s: p.hold_s,
        release_speed_per_s: p.release_speed_of_max * reference_speed_per_s,
        regrasp: p.regrasp,
        observe_s: 1.5,
        max_duration_s: p.max_duration_s,
        watch,
    }
}

/// How far the rail's arm retracts at most, mm: past where the finger's press (7.5 mm of
/// fingertip travel) is gone, so every object slips before the end.
const RAIL_RETRACT_MM: f64 = 10.0;

pub(crate) fn rail_params(
    plan: &Plan,
    p: &RailCatch,
    planned: &PlannedTrial,
    watch: WatchLimits,
) -> RailParams {
    let speed = retract_speed_mm_s(p, planned);
    RailParams {
        retract_speed_mm_s: speed,
        retract_mm: RAIL_RETRACT_MM,
        forward_mm: p.forward_mm,
        forward_speed_mm_s: crate::protocol::RAIL_FORWARD_SPEED_MM_S,
        torque_limit: p.initial_torque,
        torque_step: p.torque_step,
        max_torque: plan.safety.max_torque,
        observe_s: 1.5,
        // The whole retraction and the watch after it, within the protocol's limit: how far
        // the arm must go before the object slips depends on the object and the press (a
        // limit of 3 mm of retraction, set for the old 120 g rail object, left a quarter of
        // the trials with the 50 g one ending before any slip).
        max_duration_s: (RAIL_RETRACT_MM / speed + 1.5).min(p.max_duration_s),
        watch,
    }
}

pub(crate) fn pour_params(
    plan: &Plan,
    p: &RicePour,
    object: &str,
    reference_speed_per_s: f64,
    watch: WatchLimits,
) -> PourParams {
    PourParams {
        contact: contact_grasp(
            plan,
            p.grasp_past_contact.as_ref(),
            object,
            p.contact_deformation_px,
            p.approach_speed_of_max * reference_speed_per_s,
        ),
        regrasp: p.regrasp,
        max_closure: plan.safety.max_grip,
        // the pour starts 0.5 s in; watch 1 s after it ends
        duration_s: (0.5 + p.total_g / p.pour_rate_g_per_s + 1.0).min(p.max_duration_s),
        watch,
    }
}

pub(crate) fn lift_params(
    plan: &Plan,
    p: &FirstTimeLift,
    reference_speed_per_s: f64,
    watch: WatchLimits,
) -> LiftParams {
    LiftParams {
        deformation_px: p.deformation_px,
        approach_speed_per_s: p.approach_speed_of_max * reference_speed_per_s,
        max_closure: plan.safety.max_grip,
        lift_mm: p.lift_height_mm,
        lift_speed_mm_s: p.lift_speed_mm_s,
        close_step: p.close_step,
        pause_s: p.pause_s,
        hold_s: p.hold_s,
        watch,
    }
}

pub(crate) fn calibration_params(
    plan: &Plan,
    p: &Calibration,
    reference_speed_per_s: f64,
    watch: WatchLimits,
) -> CalibrationParams {
    CalibrationParams {
        deformation_px: p.deformation_px,
        approach_speed_per_s: p.approach_speed_of_max * reference_speed_per_s,
        max_closure: plan.safety.max_grip,
        step: p.step,
        lift_mm: p.lift_height_mm,
        lift_speed_mm_s: p.lift_speed_mm_s,
        hold_s: p.hold_s,
        max_slide_mm: p.max_slide_mm,
        watch,
    }
}
