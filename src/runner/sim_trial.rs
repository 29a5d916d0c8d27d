//! Runs a planned trial on the simulated rig: the rig each protocol kind needs, the
//! runner behind the safety limits, and the trial log with its provenance.

use crate::online::deadline::Deadline;
use crate::runner::monitor::WatchLimits;
use rand::Rng;
use tmo_sim::{HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};

use super::batch::{BatchError, PlannedTrial};
use super::calibrate::run_calibration;
use super::hand_release::run_release;
use super::lift::run_first_time_lift;
use super::params::{
    calibration_params, lift_params, pour_params, rail_params, release_params, retract_speed_mm_s,
    trial_rng,
};
use super::rail_catch::run_rail;
use super::rice_pour::run_pour;
use super::safety::{SafeArm, SafeHand, SafetyLimits};
use super::Online;
use crate::protocol::{KindParams, Mode, Plan};
use crate::runner::devices::Devices;
use crate::runner::devices::SimRigError;
use crate::runner::sim_presets::{self, Preset, PresetOptions};
use crate::slip::slip_model::SlipModel;
use crate::trial::{Trial, TrialMeta, TRIAL_FORMAT_VERSION};

/// The object standing on the table between fingers open `gap` short of contact.
fn on_table_rig(
    base: &SimConfig,
    planned: &PlannedTrial,
    gap: f64,
) -> Result<SimConfig, BatchError> {
    let contact = sim_presets::contact_closure(base, &planned.object)?;
    let mut config = base.clone();
    config.rig = RigSetup::Hand(HandSetup {
        object: planned.object.clone(),
        extra_mass_g: planned.extra_mass_g,
        grasp_deg: planned.grasp_deg,
        initial_closure: (contact - gap).max(0.0),
        start: ObjectStart::OnTable,
        ..Default::default()
    });
    Ok(config)
}

/// The simulated rig's devices behind the safety limits, as the runner always drives them.
fn safe_sim_devices(
    rig: &SimRig,
    limits: &SafetyLimits,
) -> Devices<
    tmo_sim::SimClock,
    SafeHand<tmo_sim::SimHand>,
    SafeArm<tmo_sim::SimArm>,
    tmo_sim::SimMarkerTracker,
    tmo_sim::SimTactileSensor,
> {
    let limits = *limits;
    Devices {
        clock: rig.clock(),
        hand: SafeHand::new(rig.hand(), limits),
        arm: SafeArm::new(rig.arm(), limits),
        markers: rig.marker_tracker(),
        sensors: rig.tactile_sensors(),
        live: None,
        state_period_s: Some(super::state::STATE_PERIOD_S),
        in_flight: None,
    }
}

/// The simulated world a planned trial starts in: what `tmo sim serve` is reset to between
/// trials, and what the sim backend builds.
pub fn world_for(plan: &Plan, planned: &PlannedTrial) -> Result<SimConfig, BatchError> {
    let base = sim_base(plan, planned)?;
    let options = PresetOptions {
        object: Some(planned.object.clone()),
        grasp_deg: planned.grasp_deg,
        ..Default::default()
    };
    Ok(match &plan.params {
        KindParams::HandRelease(_) => {
            hand_release_rig(&base, &options, 1.0, planned.extra_mass_g)?.0
        }
        KindParams::RailCatch(p) => {
            let options = PresetOptions {
                retract_speed_mm_s: retract_speed_mm_s(p, planned),
                grasp_deg: 0.0,
                ..options
            };
            sim_presets::build(Preset::Rail, &options, base)
                .map_err(SimRigError::from)?
                .0
        }
        KindParams::RicePour(p) => {
            let options = PresetOptions {
                pour_rate_g_per_s: p.pour_rate_g_per_s,
                ..options
            };
            // the preset holds the object with 1.2x the friction it needs: a light grasp
            sim_presets::build(Preset::Pour, &options, base)
                .map_err(SimRigError::from)?
                .0
        }
        KindParams::FirstTimeLift(_) | KindParams::CalibrateLift(_) => {
            on_table_rig(&base, planned, base.operator.lift_start_gap)?
        }
    })
    .and_then(|mut config| {
        // again, for the parameters of the rig the preset built (`rail.*`)
        set_sim_parameters(&mut config, plan)?;
        Ok(config)
    })
}

/// The simulated hand-release rig: the object stands on the table with the fingers just
/// open of contact; returns the configuration, a grasp that holds the object with `safety`
/// times the friction it needs ("closed until stable"), and the contact closure.
pub fn hand_release_rig(
    base: &SimConfig,
    options: &PresetOptions,
    safety: f64,
    extra_mass_g: f64,
) -> Result<(SimConfig, f64, f64), SimRigError> {
    let object = options
        .object
        .clone()
        .unwrap_or_else(|| "crisps_can".into());
    let (mut config, _) = sim_presets::build(Preset::Release, options, base.clone())?;
    let closure = sim_presets::holding_closure(base, &object, extra_mass_g, safety)?;
    let contact = sim_presets::contact_closure(base, &object)?;
    if let tmo_sim::RigSetup::Hand(h) = &mut config.rig {
        h.start = tmo_sim::ObjectStart::OnTable;
        h.extra_mass_g = extra_mass_g;
        h.initial_closure = (contact - 0.02).max(0.0);
    }
    Ok((config, closure, contact))
}

/// The default world with the trial's seed and the protocol's `[sim]` parameters.
fn sim_base(plan: &Plan, planned: &PlannedTrial) -> Result<SimConfig, BatchError> {
    let mut base = SimConfig {
        seed: planned.seed,
        ..SimConfig::default()
    };
    set_sim_parameters(&mut base, plan)?;
    Ok(base)
}

fn set_sim_parameters(config: &mut SimConfig, plan: &Plan) -> Result<(), BatchError> {
    config
        .set_parameters(plan.sim.iter().map(|(k, v)| (k.as_str(), *v)))
        .map_err(|e| {
            BatchError::SimRig(tmo_sim::SimError::Config {
                origin: format!("{} [sim]", plan.source.display()),
                message: e.to_string(),
            })
        })
}

/// Runs one planned trial on the simulator and returns its log.
pub fn run_sim_trial(
    plan: &Plan,
    planned: &PlannedTrial,
    models: &[(SlipModel, String)],
    started_unix_s: u64,
    stop: &std::sync::atomic::AtomicBool,
    live: Option<&crate::live::LiveView>,
) -> Result<Trial, BatchError> {
    let base = sim_base(plan, planned)?;
    let mut rng = trial_rng(planned);
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
    let config = world_for(plan, planned)?;
    let rig = SimRig::new(config.clone())?;
    let mut devices = safe_sim_devices(&rig, &plan.safety);
    // watched live, the simulator is held to wall-clock speed
    devices.live = live.map(|l| l.trial(started_unix_s.saturating_mul(1_000_000_000), true));
    // the protocols' speeds are fractions of the paper's maximum, not of the motor's
    let reference_speed = config.servo.reference_speed_per_s;
    // Held to the contract as a real rig is: on the lock-step clock it cannot be broken
    // (simulated time waits for the computer), but every frame's work is timed.
    let watch = WatchLimits {
        deadline: Some(Deadline::at_rate(
            plan.deadline,
            config.tactip.frame_rate_hz,
        )),
        ..Default::default()
    };
    let record = match &plan.params {
        KindParams::HandRelease(p) => {
            // "Closed until stable": unless the protocol finds the grasp from contact, the
            // simulator knows the grasp that holds each object; the safety factor varies
            // from trial to trial as a hand-set grasp would.
            let [lo, hi] = config.operator.release_grip_safety;
            let safety: f64 = if hi > lo { rng.gen_range(lo..hi) } else { lo };
            let closure =
                sim_presets::holding_closure(&base, &planned.object, planned.extra_mass_g, safety)?;
            let params = release_params(plan, p, &planned.object, closure, reference_speed, watch);
            if params.contact.is_none() {
                put("grip_safety", format!("{safety:.4}"));
                put("closure", format!("{closure:.4}"));
            }
            put(
                "release_speed_per_s",
                format!("{:.5}", params.release_speed_per_s),
            );
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_release(&mut devices, &params, online, stop)?
        }
        KindParams::RailCatch(p) => {
            let params = rail_params(plan, p, planned, watch);
            put(
                "retract_speed_mm_s",
                format!("{:.4}", params.retract_speed_mm_s),
            );
            run_rail(&mut devices, &params, online, stop)?
        }
        KindParams::RicePour(p) => {
            put("pour_rate_g_per_s", format!("{:.3}", p.pour_rate_g_per_s));
            put("total_g", format!("{:.1}", p.total_g));
            run_pour(
                &mut devices,
                &pour_params(plan, p, &planned.object, reference_speed, watch),
                online,
                stop,
            )?
        }
        KindParams::FirstTimeLift(p) => {
            let params = lift_params(plan, p, reference_speed, watch);
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_first_time_lift(&mut devices, &params, online, stop)?
        }
        KindParams::CalibrateLift(p) => {
            let params = calibration_params(plan, p, reference_speed, watch);
            put("extra_mass_g", format!("{:.1}", planned.extra_mass_g));
            run_calibration(&mut devices, &params, stop)?
        }
    };
    // Ground truth for diagnostics only; scoring never reads it.
    let events = rig.probe().events();
    put_truth(&mut put, &events);
    let sensors = rig.tactile_sensors().len() as u8;
    Ok(finish_trial(
        plan,
        planned,
        models,
        record,
        parameters,
        ("sim", sensors, config.tactip.pins),
        started_unix_s,
    ))
}

/// The ground truth the truth verdict reads (empty text for "never").
pub(crate) fn put_truth(put: &mut impl FnMut(&str, String), events: &tmo_sim::TruthEvents) {
    let time = |t: Option<f64>| t.map_or(String::new(), |t| format!("{t:.4}"));
    put(
        "sim_truth_slip_onsets_s",
        events
            .slip_onsets_s
            .iter()
            .map(|t| format!("{t:.4}"))
            .collect::<Vec<_>>()
            .join(","),
    );
    put(
        "sim_truth_measurable_slip_s",
        time(events.measurable_slip_s),
    );
    put("sim_truth_drop_s", time(events.drop_s));
    put(
        "sim_truth_max_fall_mm",
        format!("{:.2}", events.max_fall_mm),
    );
    // each fingertip's own slip along the object while the grasp held (tmo_sim::curl)
    put(
        "sim_truth_contact_first_slip_s",
        events
            .contact_first_slip_s
            .iter()
            .map(|t| time(*t))
            .collect::<Vec<_>>()
            .join(","),
    );
    // every break-free's time (up to tmo_sim's MAX_SLIP_TIMES a fingertip): fingertips
    // apart by `;`, times by `,`
    put(
        "sim_truth_contact_slip_times_s",
        events
            .contact_slip_times_s
            .iter()
            .map(|ts| {
                ts.iter()
                    .map(|t| format!("{t:.4}"))
                    .collect::<Vec<_>>()
                    .join(",")
            })
            .collect::<Vec<_>>()
            .join(";"),
    );
    put(
        "sim_truth_contact_slips",
        events
            .contact_slips
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(","),
    );
}

/// The built-in object library, read once.
fn object_library() -> &'static tmo_sim::ObjectLibrary {
    static LIBRARY: std::sync::OnceLock<tmo_sim::ObjectLibrary> = std::sync::OnceLock::new();
    LIBRARY.get_or_init(tmo_sim::ObjectLibrary::built_in)
}

/// The trial log of a finished run: what every backend records about it.
pub(crate) fn finish_trial(
    plan: &Plan,
    planned: &PlannedTrial,
    models: &[(SlipModel, String)],
    record: super::RunRecord,
    mut parameters: std::collections::BTreeMap<String, String>,
    (backend, sensors, pins): (&str, u8, usize),
    started_unix_s: u64,
) -> Trial {
    let mut put = |k: &str, v: String| {
        parameters.insert(k.to_string(), v);
    };
    put("repetition", planned.repetition.to_string());
    if let Some(s) = planned.strategy {
        put("strategy", s.to_string());
    }
    if let Some(m) = planned.model {
        put("model", plan.models[m].display().to_string());
        let names = crate::slip::slip_model::unique_names(
            plan.models
                .iter()
                .map(std::path::PathBuf::as_path)
                .zip(models.iter().map(|(model, _)| model)),
        );
        put(super::score::MODEL_NAME_PARAMETER, names[m].clone());
        put("scope", format!("{:?}", models[m].0.scope()).to_lowercase());
    }
    if let Some(a) = record.armed_s {
        put("armed_s", format!("{a:.4}"));
    }
    // The object's length travels with the trial, so that labels read it from the log on
    // any backend rather than from the simulator's library.
    if let Ok(o) = object_library().get(&planned.object) {
        put(
            crate::trial::OBJECT_LENGTH_PARAMETER,
            format!("{}", o.length_mm),
        );
    }
    if let Some(f) = record.fault {
        put("fault", serde_json::to_string(&f).unwrap_or_default());
    }
    if let Some(r) = record.reaction {
        put("reaction_s", format!("{:.4}", r.time_s));
        put("reaction_sensor", r.sensor.to_string());
        put("reaction_seq", r.seq.to_string());
    }
    let (tmo_version, git_revision) = TrialMeta::code_version();
    Trial {
        meta: TrialMeta {
            format_version: TRIAL_FORMAT_VERSION,
            trial_id: planned.trial_id.clone(),
            kind: match plan.mode {
                Mode::Online => plan.kind.to_string(),
                Mode::Collect => format!("{}_collect", plan.kind),
            },
            backend: backend.into(),
            seed: planned.seed,
            object: planned.object.clone(),
            grasp_deg: planned.grasp_deg,
            sensors,
            pins,
            tmo_version,
            git_revision,
            protocol: Some(plan.source.display().to_string()),
            protocol_sha256: Some(plan.source_sha256.clone()),
            model_sha256: planned.model.map(|m| models[m].1.clone()),
            started_unix_s,
            parameters,
        },
        frames: record.recording.frames,
        arrivals_s: record.recording.arrivals_s,
        markers: record.recording.markers,
        events: record.events,
        sources: vec![crate::trial::SourceFile::new(
            "protocol",
            &plan.source,
            &plan.source_text,
        )],
    }
}

/// The trials of a collection, run in memory (in parallel, each as its batch would run it):
/// for benches and tests that need collect-mode data without a batch directory.
pub fn collect_in_memory(
    preset: &crate::protocol::collect::CollectPreset,
) -> Result<Vec<Trial>, InMemoryError> {
    use rayon::prelude::*;
    let text = preset.protocol();
    let plan = crate::protocol::from_text(std::path::Path::new("collect-preset.toml"), &text, 3)?;
    let stop = std::sync::atomic::AtomicBool::new(false);
    super::batch::expand(&plan)
        .par_iter()
        .map(|t| run_sim_trial(&plan, t, &[], 0, &stop, None))
        .collect::<Result<_, _>>()
        .map_err(InMemoryError::from)
}

/// Why a collection run in memory failed: its preset is no valid protocol (an unknown
/// object, say), or a trial failed.
#[derive(Debug, thiserror::Error)]
pub enum InMemoryError {
    #[error(transparent)]
    Protocol(#[from] crate::protocol::ProtocolError),
    #[error(transparent)]
    Batch(#[from] BatchError),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world(protocol: &str) -> SimConfig {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, protocol).unwrap();
        let plan = crate::protocol::load(&path, 3).unwrap();
        let planned = &crate::runner::batch::expand(&plan)[0];
        world_for(&plan, planned).unwrap()
    }

    #[test]
    fn a_protocols_simulator_parameters_reach_the_world_of_its_rig() {
        let sim = "\n[sim]\n\"rail.rail_mu\" = 0.1\n\"physics.finger_stiffness_n_per_mm\" = 1.2\n";
        let rail = world(&format!("kind = \"rail_catch\"\nmode = \"collect\"\n{sim}"));
        assert_eq!(rail.physics.finger_stiffness_n_per_mm, 1.2);
        assert!(matches!(rail.rig, RigSetup::Rail(ref r) if r.rail_mu == 0.1));
        let hand = world(&format!(
            "kind = \"hand_release\"\nmode = \"collect\"\n{sim}"
        ));
        assert_eq!(hand.physics.finger_stiffness_n_per_mm, 1.2);
        assert!(matches!(hand.rig, RigSetup::Hand(_)));
        // and none set: the defaults
        let plain = world("kind = \"hand_release\"\nmode = \"collect\"\n");
        assert_eq!(
            plain.physics.finger_stiffness_n_per_mm,
            SimConfig::default().physics.finger_stiffness_n_per_mm
        );
    }
}
