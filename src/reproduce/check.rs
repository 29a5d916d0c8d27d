//! Whether a reproduction's directory holds what its plan says, step by step: every
//! replicate asked for, every step finished, each made for its own job (its replicate's
//! seeds, the preset's counts, the variant's parameters) and its outputs as they were.
//! `--findings-only` and `merge` check with this before a finding is measured, as
//! `--resume` does before a step is kept: a page must never pool a replicate that is not
//! there, or one replicate twice.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use super::sensitivity::Variant;
use super::steps::{Context, Preset, Step};
use super::{digest_dir, read_record, replicate_dir, sha256_text, Backend, ReproduceError};

/// What is wrong with one job's step.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    #[error("{dir}: no such replicate (the plan asks for {replicates})")]
    Missing { dir: PathBuf, replicates: u32 },
    #[error("{dir}: not finished")]
    Unfinished { dir: PathBuf },
    #[error("{dir}: a copy of replicate {of}'s step (its inputs are that replicate's seeds), not this replicate's own")]
    CopyOf { dir: PathBuf, of: u32 },
    #[error(
        "{dir}: made for other inputs than its job's (another preset, replicate or parameters)"
    )]
    OtherInputs { dir: PathBuf },
    #[error("{dir}: its files changed after the step finished (their SHA-256 is not the one step.json records)")]
    Altered { dir: PathBuf },
    #[error("{dir}: made by tmo {version} ({revision}), not this build")]
    OtherBuild {
        dir: PathBuf,
        version: String,
        revision: String,
    },
}

impl Problem {
    /// A step made by another build is still what its record says (a page may be written
    /// again by a later build); everything else means the page would say what is not so.
    pub fn is_fatal(&self) -> bool {
        !matches!(self, Problem::OtherBuild { .. })
    }
}

/// The job a replicate's directory belongs to: the baseline's, or a sensitivity
/// variant's (its parameters and its seeds' offset).
pub struct Job {
    pub sim: std::collections::BTreeMap<String, f64>,
    pub seed_offset: u32,
}

impl Job {
    pub fn baseline() -> Self {
        Self {
            sim: Default::default(),
            seed_offset: 0,
        }
    }

    pub fn of(variant: &Variant, replicates: u32) -> Self {
        Self {
            sim: variant.sim(),
            seed_offset: variant.seed_offset(replicates),
        }
    }
}

/// Checks every job of the plan in `out`: the baseline's `replicates` and each variant's.
/// Returns what it found, fatal or not, in job and step order.
pub fn check_plan(
    out: &Path,
    preset: &Preset,
    replicates: u32,
    variants: &[Variant],
    backend: &Backend,
) -> Result<Vec<Problem>, ReproduceError> {
    let mut jobs = vec![(out.to_path_buf(), Job::baseline())];
    jobs.extend(
        variants
            .iter()
            .map(|v| (v.dir(out), Job::of(v, replicates))),
    );
    let mut problems = Vec::new();
    for (dir, job) in &jobs {
        for r in 1..=replicates.max(1) {
            problems.extend(check_replicate(
                &replicate_dir(dir, r),
                r,
                job,
                preset,
                replicates,
                backend,
            )?);
        }
    }
    Ok(problems)
}

/// Checks replicate `r` of `job` in `dir` (a plan of `replicates`), step by step.
pub fn check_replicate(
    dir: &Path,
    r: u32,
    job: &Job,
    preset: &Preset,
    replicates: u32,
    backend: &Backend,
) -> Result<Vec<Problem>, ReproduceError> {
    if !dir.is_dir() {
        return Ok(vec![Problem::Missing {
            dir: dir.to_path_buf(),
            replicates: replicates.max(1),
        }]);
    }
    let stop = AtomicBool::new(false);
    let bar = indicatif::ProgressBar::hidden();
    // a user's model is one of the hand models' inputs: the one its step recorded
    let hand_model = super::hand_model::HandModel::recorded(&dir.join(Step::HandModels.dir()));
    let context = |replicate: u32| Context {
        out: dir,
        replicate,
        sim: &job.sim,
        reuse: None,
        preset,
        backend,
        stop: &stop,
        bar: &bar,
        job: "",
        sweep_from: None,
        hand_model: hand_model.as_ref(),
    };
    let (version, revision) = crate::trial::TrialMeta::code_version();
    let mut problems = Vec::new();
    for step in Step::ALL {
        let step_dir = dir.join(step.dir());
        let Some(record) = read_record(&step_dir) else {
            problems.push(Problem::Unfinished { dir: step_dir });
            continue;
        };
        let expected = |replicate: u32| -> Result<String, ReproduceError> {
            Ok(sha256_text(&step.inputs_of_build(
                &context(replicate),
                &record.tmo_version,
                &record.git_revision,
            )?))
        };
        let own = r + job.seed_offset;
        if record.inputs_sha256 != expected(own)? {
            // another replicate's own inputs: a copy (its seeds tell which)
            let mut copy_of = None;
            for other in (1..=2 * replicates.max(1)).filter(|k| *k != own) {
                if record.inputs_sha256 == expected(other)? {
                    copy_of = Some(other);
                    break;
                }
            }
            problems.push(match copy_of {
                Some(of) => Problem::CopyOf { dir: step_dir, of },
                None => Problem::OtherInputs { dir: step_dir },
            });
            continue;
        }
        if digest_dir(&step_dir)? != record.outputs_sha256 {
            problems.push(Problem::Altered { dir: step_dir });
            continue;
        }
        if record.tmo_version != version || record.git_revision != revision {
            problems.push(Problem::OtherBuild {
                dir: step_dir,
                version: record.tmo_version.clone(),
                revision: record.git_revision.clone(),
            });
        }
    }
    Ok(problems)
}

/// The other preset under which every step of the plan in `out` is its job's own, when
/// `asked`'s check found steps made for other inputs: a page asked of a paper run without
/// `--preset paper` (whose default is quick) is refused, and this says which flag fits.
pub fn preset_that_fits(
    out: &Path,
    asked: &Preset,
    replicates: u32,
    variants: &[Variant],
    backend: &Backend,
) -> Result<Option<Preset>, ReproduceError> {
    for other in Preset::ALL {
        if other == *asked {
            continue;
        }
        let problems = check_plan(out, &other, replicates, variants, backend)?;
        if !problems.iter().any(Problem::is_fatal) {
            return Ok(Some(other));
        }
    }
    Ok(None)
}

/// The replicates beyond `replicates` that `out` holds (`replicate-03` when two were
/// asked for): the page leaves them out, and says so.
pub fn beyond(out: &Path, replicates: u32) -> Vec<u32> {
    (replicates.max(1) + 1..=99)
        .take_while(|r| replicate_dir(out, *r).is_dir())
        .collect()
}
