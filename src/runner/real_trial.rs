//! Runs a planned trial on the real rig (or on `tmo sim serve`, which speaks its protocols):
//! the same runners as the simulator, over the real backends behind the safety limits.
//!
//! In progress (issue 7): the first-time lift and its calibration, which end as they began
//! (object lowered to the table, hand open), so a batch runs trial after trial unattended.
//! The other kinds need the object put back between trials, by an operator on hardware.

use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::marker_camera::MarkerCamera;
use tmo_hal::real::model_o::{ModelOConfig, ModelOHand};
use tmo_hal::real::ur::UrArm;

use super::batch::{BatchError, PlannedTrial};
use super::calibrate::{run_calibration, CalibrationParams};
use super::lift::{run_first_time_lift, LiftParams};
use super::monitor::WatchLimits;
use super::safety::{SafeArm, SafeHand};
use super::sim_trial::finish_trial;
use super::Online;
use crate::hardware::HardwareFile;
use crate::protocol::{KindParams, Mode, Plan};
use crate::scenario::{device, Devices};
use crate::slip::model::ModelFile;
use crate::trial::Trial;

pub type RealDevices =
    Devices<RealClock, SafeHand<ModelOHand>, SafeArm<UrArm>, MarkerCamera, JevoisSensor>;

/// A camera silent this many times the file's limit is taken as gone (a batch error); a
/// shorter silence is the runner's watchdog's business (that trial aborts, the batch goes on).
const DISCONNECTED_FACTOR: f64 = 4.0;

fn watch(hw: &HardwareFile) -> WatchLimits {
    WatchLimits {
        silent_limit_s: hw.cameras.silent_limit_s,
        ..Default::default()
    }
}

/// Opens every device the hardware file names, behind `plan`'s safety limits.
pub fn open_real(hw: &HardwareFile, plan: &Plan) -> Result<RealDevices, BatchError> {
    let clock = RealClock::new();
    let cams = &hw.cameras;
    let gone_s = (cams.silent_limit_s * DISCONNECTED_FACTOR).max(1.0);
    let sensors = cams
        .fingertips
        .iter()
        .enumerate()
        .map(|(k, c)| {
            JevoisSensor::open(
                &c.port,
                c.baud,
                k as u8,
                cams.pins,
                cams.silent_limit_s,
                clock,
            )
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
        clock,
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
    Ok(Devices {
        clock,
        hand: SafeHand::new(hand, plan.safety),
        arm: SafeArm::new(arm, plan.safety),
        markers,
        sensors,
    })
}

/// Can `kind` run unattended on the real backend (yet)?
pub fn runs_unattended(kind: crate::protocol::Kind) -> bool {
    matches!(
        kind,
        crate::protocol::Kind::FirstTimeLift | crate::protocol::Kind::CalibrateLift
    )
}

/// Runs one planned trial on open real devices.
pub fn run_real_trial(
    plan: &Plan,
    planned: &PlannedTrial,
    models: &[(ModelFile, String)],
    hw: &HardwareFile,
    devices: &mut RealDevices,
    started_unix_s: u64,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<Trial, BatchError> {
    let online = match (plan.mode, planned.model, planned.strategy) {
        (Mode::Online, Some(m), Some(strategy)) => Some(Online {
            model: &models[m].0,
            strategy,
        }),
        _ => None,
    };
    let mut parameters = std::collections::BTreeMap::new();
    parameters.insert(
        "extra_mass_g".into(),
        format!("{:.1}", planned.extra_mass_g),
    );
    let max_speed = hw.hand.max_speed_per_s;
    let record = match &plan.params {
        KindParams::FirstTimeLift(p) => {
            let params = LiftParams {
                deformation_px: p.deformation_px,
                approach_speed_per_s: p.approach_speed_of_max * max_speed,
                max_closure: plan.safety.max_grip,
                lift_mm: p.lift_height_mm,
                lift_speed_mm_s: p.lift_speed_mm_s,
                close_step: p.close_step,
                pause_s: p.pause_s,
                hold_s: p.hold_s,
                watch: watch(hw),
            };
            run_first_time_lift(devices, &params, online, stop)?
        }
        KindParams::CalibrateLift(p) => {
            let params = CalibrationParams {
                deformation_px: p.deformation_px,
                approach_speed_per_s: p.approach_speed_of_max * max_speed,
                max_closure: plan.safety.max_grip,
                step: p.step,
                lift_mm: p.lift_height_mm,
                lift_speed_mm_s: p.lift_speed_mm_s,
                hold_s: p.hold_s,
                max_slide_mm: p.max_slide_mm,
                watch: watch(hw),
            };
            run_calibration(devices, &params, stop)?
        }
        _ => return Err(BatchError::NeedsOperator(plan.kind)),
    };
    Ok(finish_trial(
        plan,
        planned,
        models,
        record,
        parameters,
        ("real", devices.sensors.len() as u8, hw.cameras.pins),
        started_unix_s,
    ))
}
