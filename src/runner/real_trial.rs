//! Runs a planned trial on the real rig (or on `tmo sim serve`, which speaks its protocols):
//! the same runners as the simulator, over the real backends behind the safety limits.
//!
//! Between trials the rig is set up for the next one ([`super::staging`]); the hand
//! release finds its grasp from contact (`hand_release.grasp_past_contact`), as there is
//! no simulator to say which closure holds the object.

use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::marker_camera::MarkerCamera;
use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::real::ur::UrArm;
use tmo_hal::{Arm, Hand};

use super::batch::{BatchError, PlannedTrial};
use super::calibrate::run_calibration;
use super::hand_release::run_release;
use super::lift::run_first_time_lift;
use super::monitor::WatchLimits;
use super::params::{calibration_params, lift_params, pour_params, rail_params, release_params};
use super::rail_catch::run_rail;
use super::rice_pour::run_pour;
use super::safety::{SafeArm, SafeHand};
use super::sim_trial::finish_trial;
use super::Online;
use crate::protocol::{KindParams, Mode, Plan, SafetyLimits};
use crate::runner::devices::{device, Devices};
use crate::runner::hardware::HardwareFile;
use crate::slip::slip_model::SlipModel;
use crate::trial::Trial;

pub type RealDevices =
    Devices<RealClock, SafeHand<ModelOHand>, SafeArm<UrArm>, MarkerCamera, JevoisSensor>;

/// A camera silent this many times the file's limit is taken as gone (a batch error); a
/// shorter silence is the runner's watchdog's business (that trial aborts, the batch goes on).
const DISCONNECTED_FACTOR: f64 = 4.0;

fn watch(hw: &HardwareFile, plan: &Plan) -> WatchLimits {
    WatchLimits {
        silent_limit_s: hw.cameras.silent_limit_s,
        deadline: Some(crate::online::deadline::Deadline::at_rate(
            plan.deadline,
            hw.cameras.frame_rate_hz,
        )),
        ..Default::default()
    }
}

/// Checks a plan can run on the rig before any device is opened, and tightens its safety
/// limits to the rig's where the rig's are stricter. A protocol asking for a motion
/// or force past the rig's limits is refused, as is a hand release or rice pour without a
/// grasp from contact.
pub fn check_real_plan(hw: &HardwareFile, plan: &mut Plan) -> Result<(), BatchError> {
    let grasp = match &plan.params {
        KindParams::HandRelease(p) => Some(("hand_release", p.grasp_past_contact.as_ref())),
        KindParams::RicePour(p) => Some(("rice_pour", p.grasp_past_contact.as_ref())),
        _ => None,
    };
    if let Some((section, grasp)) = grasp {
        if let Some(o) = plan
            .objects
            .iter()
            .find(|o| grasp.and_then(|g| g.get(o)).is_none())
        {
            return Err(BatchError::NoGraspOnHardware(section, o.clone()));
        }
    }
    for (field, value, limit, limit_field) in plan.params.demands(&hw.safety) {
        if value > limit {
            return Err(BatchError::BeyondHardware {
                field,
                value,
                limit,
                limit_field,
            });
        }
    }
    plan.safety = plan.safety.tightest(&hw.safety);
    Ok(())
}

/// The open rig: its file and its devices.
pub struct RealRig {
    pub hw: HardwareFile,
    pub devices: RealDevices,
}

/// Opens every device the hardware file names, behind `limits`.
pub fn open_real(hw: HardwareFile, limits: SafetyLimits) -> Result<RealRig, BatchError> {
    let clock = RealClock::new();
    let cams = &hw.cameras;
    let gone_s = (cams.silent_limit_s * DISCONNECTED_FACTOR).max(1.0);
    let sensors = cams
        .fingertips
        .iter()
        .enumerate()
        .map(|(k, c)| {
            // The runner's watchdog ends the trial at `silent_limit_s`; only a camera silent
            // far longer is gone (a batch error).
            JevoisSensor::open(&c.port, c.baud, k as u8, cams.pins, gone_s, clock.clone())
                .map_err(device("fingertip camera"))
        })
        .collect::<Result<_, _>>()?;
    let m = &hw.marker_camera;
    let markers = MarkerCamera::open(
        &m.port,
        m.baud,
        &m.object_marker,
        &m.hand_marker,
        gone_s,
        clock.clone(),
    )
    .map_err(device("marker camera"))?;
    let hand = ModelOHand::open(ModelOConfig {
        port: hw.hand.port.clone(),
        baud: hw.hand.baud,
        ids: hw.hand.ids,
        min: hw.hand.min,
        max: hw.hand.max,
        current_limit_ma: hw.hand.current_limit_ma,
    })
    .map_err(device("hand"))?;
    let arm = UrArm::connect(
        &hw.arm.host,
        hw.arm.rtde_port,
        hw.arm.script_port,
        f64::from(hw.arm.frequency_hz),
    )
    .map_err(device("arm"))?;
    let devices = Devices {
        clock,
        hand: SafeHand::new(hand, limits),
        arm: SafeArm::new(arm, limits),
        markers,
        sensors,
        live: None,
        state_period_s: Some(super::state::STATE_PERIOD_S),
        in_flight: None,
    };
    Ok(RealRig { hw, devices })
}

/// Runs one planned trial on open real devices; `plan` has passed [`check_real_plan`].
pub fn run_real_trial(
    plan: &Plan,
    planned: &PlannedTrial,
    models: &[(SlipModel, String)],
    rig: &mut RealRig,
    started_unix_s: u64,
    stop: &std::sync::atomic::AtomicBool,
    live: Option<&crate::live::LiveView>,
) -> Result<Trial, BatchError> {
    let online = match (plan.mode, planned.model, planned.strategy) {
        (Mode::Online, Some(m), Some(strategy)) => Some(Online {
            model: &models[m].0,
            strategy,
        }),
        _ => None,
    };
    let mut parameters = std::collections::BTreeMap::new();
    let mut put = |k: &str, v: String| {
        parameters.insert(k.to_string(), v);
    };
    let RealRig { hw, devices } = rig;
    devices.live = live.map(|l| l.trial(started_unix_s.saturating_mul(1_000_000_000), false));
    let in_flight = super::devices::InFlight::default();
    devices.in_flight = Some(in_flight.clone());
    let reference_speed = hw.hand.max_speed_per_s;
    let watch = watch(hw, plan);
    let result = match &plan.params {
        KindParams::HandRelease(p) => {
            // the grasp comes from contact: check_real_plan made sure the protocol gives one
            let params = release_params(plan, p, &planned.object, 0.0, reference_speed, watch);
            put(
                "release_speed_per_s",
                format!("{:.5}", params.release_speed_per_s),
            );
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_release(devices, &params, online, stop)
        }
        KindParams::RailCatch(p) => {
            let params = rail_params(plan, p, planned, watch);
            put(
                "retract_speed_mm_s",
                format!("{:.4}", params.retract_speed_mm_s),
            );
            run_rail(devices, &params, online, stop)
        }
        KindParams::RicePour(p) => {
            put("pour_rate_g_per_s", format!("{:.3}", p.pour_rate_g_per_s));
            put("total_g", format!("{:.1}", p.total_g));
            run_pour(
                devices,
                &pour_params(plan, p, &planned.object, reference_speed, watch),
                online,
                stop,
            )
        }
        KindParams::FirstTimeLift(p) => {
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_first_time_lift(
                devices,
                &lift_params(plan, p, reference_speed, watch),
                online,
                stop,
            )
        }
        KindParams::CalibrateLift(p) => {
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_calibration(
                devices,
                &calibration_params(plan, p, reference_speed, watch),
                stop,
            )
        }
    };
    // Stop on any fault: a device error ends the batch, but a controller runs its last
    // script on without its client, so the arm is told to stop (the UR backend reconnects
    // to do so if the connection was what failed) and the fingers hold. Best effort: the
    // device that failed may not answer.
    let to_trial = |record, parameters| {
        let mut trial = finish_trial(
            plan,
            planned,
            models,
            record,
            parameters,
            ("real", devices.sensors.len() as u8, hw.cameras.pins),
            started_unix_s,
        );
        trial.sources.extend(hw.source.clone());
        trial
    };
    let record = match result {
        Ok(r) => r,
        Err(e) => {
            let _ = devices.arm.stop();
            if let Ok(held) = devices.hand.present_positions() {
                let _ = devices.hand.set_targets(held);
            }
            // What the trial recorded up to the fault goes with the error, to be kept as
            // a faulted log beside the batch (the trial itself runs again on --resume).
            let partial = in_flight.lock().ok().and_then(|mut slot| slot.take());
            let Some(mut record) = partial else {
                return Err(e.into());
            };
            record.events.push(super::event(
                record.ended_s,
                "/fault",
                serde_json::json!({ "fault": "device", "message": e.to_string() }),
            ));
            parameters.insert("fault".into(), format!("device: {e}"));
            let trial = to_trial(record, parameters);
            return Err(BatchError::FaultInFlight {
                source: Box::new(e.into()),
                trial: Box::new(trial),
            });
        }
    };
    Ok(to_trial(record, parameters))
}
