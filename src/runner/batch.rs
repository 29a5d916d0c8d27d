//! A batch: every trial a plan asks for, one MCAP log each, scored from its log.
//!
//! Trials are numbered in grid order (objects x grasps x models x strategies x
//! repetitions) and each has a seed derived from the batch seed and its number, so a
//! resumed batch runs exactly the trials that are missing and gets the same ones an
//! uninterrupted run would have. A log is written under its name only when complete.
//!
//! In progress (issue 4): only `hand_release` on the `sim` backend.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tmo_hal::sim::{SimConfig, SimRig};

use super::hand_release::{run_release, ReleaseParams};
use super::rail_catch::{run_rail, RailParams};
use super::rice_pour::{run_pour, PourParams};
use super::safety::{SafeArm, SafeHand, SafetyLimits};
use super::Online;
use crate::collect::{hand_release_rig, trial_seed, CollectError};
use crate::online::strategy::Strategy;
use crate::outcome::{score_catch, CatchOutcome, CatchSpec, Verdict};
use crate::protocol::{Kind, KindParams, Mode, Plan};
use crate::scenario::{Devices, ScenarioError};
use crate::sim_presets::{self, Preset, PresetOptions};
use crate::slip::labels::OnsetSpec;
use crate::slip::model::ModelFile;
use crate::trial::{Trial, TrialMeta, TRIAL_FORMAT_VERSION};

/// One trial of the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTrial {
    pub index: usize,
    pub trial_id: String,
    pub object: String,
    pub grasp_deg: f64,
    /// Index into the plan's models (online trials).
    pub model: Option<usize>,
    pub strategy: Option<Strategy>,
    pub repetition: u32,
    pub seed: u64,
}

/// The plan's trials in grid order.
pub fn expand(plan: &Plan) -> Vec<PlannedTrial> {
    let models: Vec<Option<usize>> = if plan.models.is_empty() {
        vec![None]
    } else {
        (0..plan.models.len()).map(Some).collect()
    };
    let strategies: Vec<Option<Strategy>> = if plan.strategies.is_empty() {
        vec![None]
    } else {
        plan.strategies.iter().copied().map(Some).collect()
    };
    let mut out = Vec::new();
    for object in &plan.objects {
        for &grasp_deg in &plan.grasps_deg {
            for &model in &models {
                for &strategy in &strategies {
                    for repetition in 0..plan.repetitions {
                        let index = out.len();
                        out.push(PlannedTrial {
                            index,
                            trial_id: format!("trial-{index:05}"),
                            object: object.clone(),
                            grasp_deg,
                            model,
                            strategy,
                            repetition,
                            seed: trial_seed(plan.seed, index as u64),
                        });
                    }
                }
            }
        }
    }
    out
}

#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    #[error("{0} protocols cannot run yet (see issue 4)")]
    Unsupported(Kind),
    #[error(transparent)]
    Sim(#[from] CollectError),
    #[error(transparent)]
    SimRig(#[from] tmo_hal::sim::SimError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

/// How outcomes are scored for a plan.
pub fn catch_spec(plan: &Plan) -> CatchSpec {
    CatchSpec {
        onset: OnsetSpec {
            drop_threshold_mm: plan.outcome.onset_threshold_mm,
            ..Default::default()
        },
        drop_limit_mm: plan.outcome.drop_limit_mm,
        ..Default::default()
    }
}

/// The simulated rig's devices behind the safety limits, as the runner always drives them.
fn safe_sim_devices(
    rig: &SimRig,
) -> Devices<
    tmo_hal::sim::SimClock,
    SafeHand<tmo_hal::sim::SimHand>,
    SafeArm<tmo_hal::sim::SimArm>,
    tmo_hal::sim::SimMarkerTracker,
    tmo_hal::sim::SimTactileSensor,
> {
    let limits = SafetyLimits::default();
    Devices {
        clock: rig.clock(),
        hand: SafeHand::new(rig.hand(), limits),
        arm: SafeArm::new(rig.arm(), limits),
        markers: rig.marker_tracker(),
        sensors: rig.tactile_sensors(),
    }
}

/// Runs one planned trial on the simulator and returns its log.
pub fn run_sim_trial(
    plan: &Plan,
    planned: &PlannedTrial,
    models: &[(ModelFile, String)],
    started_unix_s: u64,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<Trial, BatchError> {
    let base = SimConfig {
        seed: planned.seed,
        ..SimConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(planned.seed);
    rng.set_stream(7);
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
    let (config, rig, record) = match &plan.params {
        KindParams::HandRelease(p) => {
            let options = PresetOptions {
                object: Some(planned.object.clone()),
                grasp_deg: planned.grasp_deg,
                ..Default::default()
            };
            // "Closed until stable": the simulator knows the grasp that holds each object;
            // the safety factor varies from trial to trial as a hand-set grasp would.
            let safety: f64 = rng.gen_range(1.2..1.8);
            let (config, closure, _) = hand_release_rig(&base, &options, safety)?;
            let rig = SimRig::new(config.clone())?;
            let mut devices = safe_sim_devices(&rig);
            let release_speed_per_s = p.release_speed_of_max * config.servo.max_speed_per_s;
            let params = ReleaseParams {
                closure,
                close_speed_per_s: 0.05,
                lift_mm: p.lift_mm,
                lift_speed_mm_s: 40.0,
                hold_s: p.hold_s,
                release_speed_per_s,
                regrasp: p.regrasp,
                observe_s: 1.5,
                max_duration_s: p.max_duration_s,
                watch: Default::default(),
            };
            put("grip_safety", format!("{safety:.4}"));
            put("closure", format!("{closure:.4}"));
            put("release_speed_per_s", format!("{release_speed_per_s:.5}"));
            let record = run_release(&mut devices, &params, online, stop)?;
            (config, rig, record)
        }
        KindParams::RailCatch(p) => {
            let [lo, hi] = p.retract_speed_mm_s;
            let speed = if hi > lo { rng.gen_range(lo..hi) } else { lo };
            let options = PresetOptions {
                object: Some(planned.object.clone()),
                retract_speed_mm_s: speed,
                ..Default::default()
            };
            let (config, _) = sim_presets::build(Preset::Rail, &options, base.clone())
                .map_err(CollectError::from)?;
            let rig = SimRig::new(config.clone())?;
            let mut devices = safe_sim_devices(&rig);
            let params = RailParams {
                retract_speed_mm_s: speed,
                retract_mm: 10.0,
                forward_mm: p.forward_mm,
                forward_speed_mm_s: 20.0,
                torque_limit: 0.8,
                torque_step: p.torque_step,
                observe_s: 1.5,
                // slip comes after about 1.2 mm of retraction
                max_duration_s: (3.0 / speed + 1.5).min(p.max_duration_s),
                watch: Default::default(),
            };
            put("retract_speed_mm_s", format!("{speed:.4}"));
            let record = run_rail(&mut devices, &params, online, stop)?;
            (config, rig, record)
        }
        KindParams::RicePour(p) => {
            let options = PresetOptions {
                object: Some(planned.object.clone()),
                grasp_deg: planned.grasp_deg,
                pour_rate_g_per_s: p.pour_rate_g_per_s,
                ..Default::default()
            };
            // the preset holds the object with 1.2x the friction it needs: a light grasp
            let (config, _) = sim_presets::build(Preset::Pour, &options, base.clone())
                .map_err(CollectError::from)?;
            let rig = SimRig::new(config.clone())?;
            let mut devices = safe_sim_devices(&rig);
            let params = PourParams {
                regrasp: p.regrasp,
                max_closure: SafetyLimits::default().max_grip,
                // the pour starts 0.5 s in; watch 1 s after it ends
                duration_s: (0.5 + p.total_g / p.pour_rate_g_per_s + 1.0).min(p.max_duration_s),
                watch: Default::default(),
            };
            put("pour_rate_g_per_s", format!("{:.3}", p.pour_rate_g_per_s));
            put("total_g", format!("{:.1}", p.total_g));
            let record = run_pour(&mut devices, &params, online, stop)?;
            (config, rig, record)
        }
        _ => return Err(BatchError::Unsupported(plan.kind)),
    };
    put("repetition", planned.repetition.to_string());
    if let Some(s) = planned.strategy {
        put("strategy", s.to_string());
    }
    if let Some(m) = planned.model {
        put("model", plan.models[m].display().to_string());
        put("scope", format!("{:?}", models[m].0.scope).to_lowercase());
    }
    if let Some(a) = record.armed_s {
        put("armed_s", format!("{a:.4}"));
    }
    if let Some(f) = record.fault {
        put("fault", serde_json::to_string(&f).unwrap_or_default());
    }
    if let Some(r) = record.reaction {
        put("reaction_s", format!("{:.4}", r.time_s));
        put("reaction_sensor", r.sensor.to_string());
        put("reaction_seq", r.seq.to_string());
    }
    // Ground truth for diagnostics only; scoring never reads it.
    let events = rig.probe().events();
    put(
        "sim_truth_slip_onsets_s",
        events
            .slip_onsets_s
            .iter()
            .map(|t| format!("{t:.4}"))
            .collect::<Vec<_>>()
            .join(","),
    );
    let (tmo_version, git_revision) = TrialMeta::code_version();
    Ok(Trial {
        meta: TrialMeta {
            format_version: TRIAL_FORMAT_VERSION,
            trial_id: planned.trial_id.clone(),
            kind: match plan.mode {
                Mode::Online => plan.kind.to_string(),
                Mode::Collect => format!("{}_collect", plan.kind),
            },
            backend: "sim".into(),
            seed: planned.seed,
            object: planned.object.clone(),
            grasp_deg: planned.grasp_deg,
            sensors: rig.tactile_sensors().len() as u8,
            pins: config.tactip.pins,
            tmo_version,
            git_revision,
            protocol: Some(plan.source.display().to_string()),
            protocol_sha256: Some(plan.source_sha256.clone()),
            model_sha256: planned.model.map(|m| models[m].1.clone()),
            started_unix_s,
            parameters,
        },
        frames: record.recording.frames,
        markers: record.recording.markers,
        events: record.events,
    })
}

/// One line of a batch's outcome table, computed from a trial log alone.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OutcomeRow {
    pub trial_id: String,
    pub object: String,
    pub grasp_deg: f64,
    pub scope: String,
    pub strategy: String,
    pub verdict: Verdict,
    pub onset_s: Option<f64>,
    pub reaction_s: Option<f64>,
    pub latency_s: Option<f64>,
    pub dropped: bool,
    pub slip_distance_mm: Option<f64>,
    /// Why the trial was aborted, if it was (JSON).
    pub fault: Option<String>,
    /// Reactions of the hand (the detector's events in the log).
    pub responses: usize,
}

pub fn score_trial(trial: &Trial, spec: &CatchSpec) -> OutcomeRow {
    let param = |k: &str| trial.meta.parameters.get(k).cloned();
    let reaction_s = param("reaction_s").and_then(|v| v.parse().ok());
    let o: CatchOutcome = score_catch(&trial.markers, reaction_s, spec);
    OutcomeRow {
        trial_id: trial.meta.trial_id.clone(),
        object: trial.meta.object.clone(),
        grasp_deg: trial.meta.grasp_deg,
        scope: param("scope").unwrap_or_else(|| "-".into()),
        strategy: param("strategy").unwrap_or_else(|| "-".into()),
        verdict: o.verdict,
        onset_s: o.onset_s,
        reaction_s,
        latency_s: o.latency_s,
        dropped: o.dropped,
        slip_distance_mm: o.slip_distance_mm,
        fault: param("fault"),
        responses: trial
            .events
            .iter()
            .filter(|e| e.topic == "/detector")
            .count(),
    }
}

/// Where trial `t` of a batch in `dir` is logged.
pub fn trial_path(dir: &Path, t: &PlannedTrial) -> PathBuf {
    dir.join(format!("{}.mcap", t.trial_id))
}

/// Where an interrupted trial's log is kept: beside the batch, not counted as done, so
/// `--resume` runs the trial again.
pub fn aborted_trial_path(dir: &Path, t: &PlannedTrial) -> PathBuf {
    dir.join(format!("{}.aborted.mcap", t.trial_id))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_expands_in_order_with_stable_seeds() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.json"), "{}").unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(
            &path,
            "kind = \"hand_release\"\nobjects = [\"banana\", \"crisps_can\"]\ngrasps_deg = [0, 180]\nmodels = [\"m.json\"]\nstrategies = [\"1x1\", \"2x2\"]\nrepetitions = 3\nseed = 9\n",
        )
        .unwrap();
        let plan = crate::protocol::load(&path, 3).unwrap();
        let trials = expand(&plan);
        assert_eq!(trials.len(), plan.trial_count());
        assert_eq!(trials.len(), 2 * 2 * 2 * 3);
        assert_eq!(trials[0].object, "banana");
        assert_eq!(trials[3].strategy.unwrap().to_string(), "2Fr2Sen");
        assert_eq!(trials[6].grasp_deg, 180.0);
        assert_eq!(trials[23].trial_id, "trial-00023");
        assert_eq!(trials[5].seed, trial_seed(9, 5));
        assert_eq!(expand(&plan), trials);
    }
}
