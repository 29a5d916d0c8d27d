//! A batch: every trial a plan asks for, one MCAP log each, scored from its log.
//!
//! Trials are numbered in grid order (objects x masses x grasps x models x strategies x
//! repetitions) and each has a seed derived from the batch seed and its number, so a
//! resumed batch runs exactly the trials that are missing and gets the same ones an
//! uninterrupted run would have. A log is written under its name only when complete.

pub mod rows;

use std::path::{Path, PathBuf};

use crate::online::strategy::Strategy;
use crate::outcome::CatchSpec;
use crate::protocol::{Kind, Mode, Plan};
use crate::runner::devices::ScenarioError;
use crate::runner::devices::SimRigError;
use crate::slip::labels::OnsetSpec;

/// `batch.json`: what a batch directory holds and how it was made.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    pub protocol: String,
    pub protocol_sha256: String,
    pub kind: Kind,
    /// Absent in batches written before modes were recorded: those were online.
    #[serde(default)]
    pub mode: Mode,
    pub seed: u64,
    pub repetitions: u32,
    pub backend: String,
    pub trials: Vec<String>,
    /// The part of the batch this directory holds (`K/N`), when it was split with
    /// `tmo run --shard`; `tmo report` joins the parts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<String>,
}

impl Manifest {
    /// What makes `self` a different batch from `kept` (the one a directory holds), if
    /// anything: its protocol, kind, mode, seed, repetitions or grid.
    pub fn differs_from(&self, kept: &Manifest) -> Option<String> {
        let short = |h: &str| h.chars().take(12).collect::<String>();
        if self.protocol_sha256 != kept.protocol_sha256 {
            return Some(format!(
                "the protocol differs (SHA-256 {} there, {} now)",
                short(&kept.protocol_sha256),
                short(&self.protocol_sha256)
            ));
        }
        if (self.kind, self.mode) != (kept.kind, kept.mode) {
            return Some(format!(
                "it was a {} {:?} batch, this is {} {:?}",
                kept.kind, kept.mode, self.kind, self.mode
            ));
        }
        if self.seed != kept.seed {
            return Some(format!("seed {} there, {} now", kept.seed, self.seed));
        }
        if self.repetitions != kept.repetitions {
            return Some(format!(
                "{} repetitions there, {} now",
                kept.repetitions, self.repetitions
            ));
        }
        if self.shard != kept.shard {
            let name = |s: &Option<String>| s.clone().unwrap_or_else(|| "the whole batch".into());
            return Some(format!(
                "it holds {}, this run {}",
                name(&kept.shard),
                name(&self.shard)
            ));
        }
        if self.trials != kept.trials {
            return Some(format!(
                "its grid had {} trials, this one has {}",
                kept.trials.len(),
                self.trials.len()
            ));
        }
        None
    }
}

/// One trial of the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTrial {
    pub index: usize,
    pub trial_id: String,
    pub object: String,
    pub grasp_deg: f64,
    /// Mass added to the object, g (first-time lift and its calibration; else 0).
    pub extra_mass_g: f64,
    /// Index into the plan's models (online trials).
    pub model: Option<usize>,
    pub strategy: Option<Strategy>,
    pub repetition: u32,
    pub seed: u64,
}

/// Seed of trial `index` of a batch seeded with `batch_seed` (documented so a single trial
/// can be re-run alone).
pub fn trial_seed(batch_seed: u64, index: u64) -> u64 {
    batch_seed.wrapping_mul(1_000_003).wrapping_add(index)
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
    let masses = plan.masses_g();
    for (object, &extra_mass_g) in plan
        .objects
        .iter()
        .flat_map(|o| masses.iter().map(move |m| (o, m)))
    {
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
                            extra_mass_g,
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
    #[error(
        "{0} on the real backend needs the rig set up between trials, by an operator at a terminal (stdin is not one), or pass --unattended if the rig resets itself"
    )]
    NeedsOperator(Kind),
    #[error(
        "{0}.grasp_past_contact: expected a value for {1} on the real backend (the closure past contact that holds it; a rig has no simulator to say which grasp does)"
    )]
    NoGraspOnHardware(&'static str, String),
    #[error(transparent)]
    Staging(#[from] tmo_sim::serve::control::ControlError),
    #[error("{field} = {value} asks for more than the hardware file's {limit_field} ({limit})")]
    BeyondHardware {
        field: &'static str,
        value: f64,
        limit: f64,
        limit_field: &'static str,
    },
    #[error(transparent)]
    Sim(#[from] SimRigError),
    #[error(transparent)]
    SimRig(#[from] tmo_sim::SimError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Csv { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    ModelDoesNotFitRig { path: PathBuf, message: String },
    #[error("{path}: classifying a frame takes {p99_ms:.2} ms on this machine (p99 of {frames} frames at load), but at {rate_hz} fps with {sensors} fingertip(s) the online loop has {budget_ms:.2} ms a frame for each: its trials would fall behind their cameras and fault on their deadline. Use a faster model (docs/performance.md), or pass --allow-slow-model to run it anyway (on the simulator its outcomes do not depend on this machine's speed; on the real rig its trials fault as `deadline`)")]
    SlowModel {
        path: PathBuf,
        p99_ms: f64,
        frames: usize,
        budget_ms: f64,
        rate_hz: f64,
        sensors: usize,
    },
    #[error("model file {0} not found: train one from collected trials with `tmo train TRIALS --out {0}` (docs/commands.md, \"The pipeline, step by step\"), or run `tmo reproduce --preset quick`, which collects, trains and runs every protocol")]
    MissingModel(PathBuf),
    #[error("the batch has {trials} trials (objects x masses x grasps x models x strategies x repetitions); at most {MAX_TRIALS} can run in one batch")]
    TooManyTrials { trials: u128 },
    #[error(
        "{dir} holds another batch ({what}): run it with what made it, or choose another --out"
    )]
    DifferentBatch { dir: PathBuf, what: String },
    #[error(
        "{path} is not this batch's {trial_id}: {what}; move it away and run again with --resume"
    )]
    ForeignLog {
        path: PathBuf,
        trial_id: String,
        what: String,
    },
    #[error("{dir} already holds {trials} trial(s) of a batch: pass --resume to finish it, or choose another --out")]
    AlreadyThere { dir: PathBuf, trials: usize },
    /// A device fault mid-trial, with what the trial had recorded until then.
    #[error("{source}")]
    FaultInFlight {
        source: Box<BatchError>,
        trial: Box<crate::trial::Trial>,
    },
    /// A device fault mid-trial whose recording so far was kept at `path`.
    #[error("{source} (what the trial recorded until then is kept as {path})")]
    FaultKept {
        source: Box<BatchError>,
        path: PathBuf,
    },
    #[error("trial {trial_id}: {source}")]
    InTrial {
        trial_id: String,
        source: Box<BatchError>,
    },
    #[error(transparent)]
    Log(#[from] crate::trial::TrialError),
    #[error(transparent)]
    Lock(#[from] crate::output::lock::LockError),
    #[error(transparent)]
    Model(#[from] crate::slip::model::ModelFileError),
    /// A protocol's model that cannot be loaded: `models.<index>` names it in the protocol.
    #[error("models.{index}: {source}")]
    ProtocolModel {
        index: usize,
        source: crate::slip::model::ModelFileError,
    },
    #[error("first_time_lift.calibration: {0}")]
    Calibration(#[from] crate::runner::score::GMinError),
}

impl BatchError {
    /// Whether the batch stopped part way on something outside it (a failed write, a full
    /// disk, a device lost mid-trial): its finished trials are kept, and `--resume` goes on
    /// once the cause is mended.
    pub fn is_resumable(&self) -> bool {
        match self {
            BatchError::InTrial { source, .. } => source.is_resumable(),
            BatchError::Log(crate::trial::TrialError::Write { .. })
            | BatchError::Io { .. }
            | BatchError::FaultKept { .. }
            | BatchError::FaultInFlight { .. }
            | BatchError::Scenario(ScenarioError::Device { .. }) => true,
            _ => false,
        }
    }
}

/// Most trials one batch may hold: far beyond any experiment (the paper's largest is 600
/// trials), and small enough that the grid's list fits in memory.
pub const MAX_TRIALS: u128 = 1_000_000;

/// The plan's trial count, refused before anything is allocated when beyond [`MAX_TRIALS`].
pub fn check_size(plan: &Plan) -> Result<usize, BatchError> {
    let trials = [
        plan.objects.len(),
        plan.masses_g().len(),
        plan.grasps_deg.len(),
        plan.models.len().max(1),
        plan.strategies.len().max(1),
        plan.repetitions as usize,
    ]
    .iter()
    .fold(1u128, |n, &k| n.saturating_mul(k as u128));
    if trials > MAX_TRIALS {
        return Err(BatchError::TooManyTrials { trials });
    }
    Ok(trials as usize)
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

/// Where trial `t` of a batch in `dir` is logged.
pub fn trial_path(dir: &Path, t: &PlannedTrial) -> PathBuf {
    dir.join(format!("{}.mcap", t.trial_id))
}

/// Where an interrupted trial's log is kept: beside the batch, not counted as done, so
/// `--resume` runs the trial again.
pub fn aborted_trial_path(dir: &Path, t: &PlannedTrial) -> PathBuf {
    dir.join(format!("{}.aborted.mcap", t.trial_id))
}

/// Where a faulted trial's log goes when `--rerun-faulted` runs the trial again: the first
/// free `<id>.faulted-<n>.mcap`, so that no earlier attempt is overwritten.
pub fn faulted_trial_path(dir: &Path, t: &PlannedTrial) -> PathBuf {
    (1..)
        .map(|n| dir.join(format!("{}.faulted-{n}.mcap", t.trial_id)))
        .find(|p| !p.exists())
        .expect("some attempt number is free")
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
