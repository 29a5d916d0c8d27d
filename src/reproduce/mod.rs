//! `tmo reproduce`: the paper's experiments in order, as steps that call the same library
//! code as `tmo run`, `tmo sweep`, `tmo train` and `tmo evaluate`, and a findings table
//! against the paper's numbers (`docs/paper_findings.toml`).
//!
//! Each step writes into its own directory under the output directory and, when it has
//! finished, a `step.json` naming the SHA-256 of its inputs (its settings and the outputs
//! of the steps it reads) and of its outputs. `--resume` skips a step whose `step.json`
//! matches its inputs as they are now, finishes a batch step that was interrupted (its
//! trials are kept), and reruns a step whose inputs changed. A step is only ever marked
//! done once all its files are in place, so a Ctrl-C or kill -9 loses no finished step.

pub mod findings;
pub mod measure;
pub mod page;
pub mod steps;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use sha2::{Digest, Sha256};

use crate::runner::batch::BatchError;
pub use steps::{Preset, Step};

#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    #[error("{0} already holds a reproduction: pass --resume to finish or update it, or choose another --out")]
    AlreadyThere(PathBuf),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("step {step}: {source}")]
    Batch {
        step: &'static str,
        source: BatchError,
    },
    #[error("step {step}: {message}")]
    Step { step: &'static str, message: String },
    #[error(transparent)]
    Findings(#[from] findings::FindingsError),
}

impl ReproduceError {
    pub(crate) fn step(step: &'static str, e: impl std::fmt::Display) -> Self {
        ReproduceError::Step {
            step,
            message: e.to_string(),
        }
    }
}

pub(crate) fn io(path: &Path) -> impl Fn(std::io::Error) -> ReproduceError + '_ {
    move |source| ReproduceError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Which rig the batch steps drive.
#[derive(Debug, Clone, PartialEq)]
pub enum Backend {
    Sim,
    /// Hardware files of the hand rig and of the single-finger rail rig.
    Real {
        hand: PathBuf,
        rail: PathBuf,
        unattended: bool,
    },
}

/// What the user asked for.
#[derive(Debug, Clone)]
pub struct Options {
    pub out: PathBuf,
    pub preset: Preset,
    pub resume: bool,
    pub backend: Backend,
}

/// `step.json`: a finished step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepRecord {
    pub step: String,
    pub inputs_sha256: String,
    pub outputs_sha256: String,
    pub wall_s: f64,
    pub tmo_version: String,
    pub git_revision: String,
}

/// The two bars of a reproduction: steps, and the running step's own work.
pub struct Progress {
    pub steps: indicatif::ProgressBar,
    pub work: indicatif::ProgressBar,
}

impl Progress {
    /// Bars that draw nothing (tests, or output that is not a terminal).
    pub fn hidden() -> Self {
        Self {
            steps: indicatif::ProgressBar::hidden(),
            work: indicatif::ProgressBar::hidden(),
        }
    }
}

/// How a reproduction ended.
#[derive(Debug)]
pub enum End {
    Finished {
        /// Steps run now and steps already done.
        ran: Vec<&'static str>,
        kept: Vec<&'static str>,
        report: page::Written,
    },
    Interrupted {
        step: &'static str,
    },
}

pub(crate) fn sha256_text(text: &str) -> String {
    crate::trial::sha256_hex(text.as_bytes())
}

/// SHA-256 over a directory's files (relative path and content, in path order), leaving
/// out the step's own bookkeeping.
pub fn digest_dir(dir: &Path) -> Result<String, ReproduceError> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<PathBuf>) -> Result<(), ReproduceError> {
        for entry in std::fs::read_dir(dir).map_err(io(dir))? {
            let path = entry.map_err(io(dir))?.path();
            if path.is_dir() {
                walk(&path, root, out)?;
            } else {
                out.push(path.strip_prefix(root).unwrap_or(&path).to_path_buf());
            }
        }
        Ok(())
    }
    let mut files = Vec::new();
    walk(dir, dir, &mut files)?;
    files.retain(|f| {
        let name = f.to_string_lossy();
        name != "step.json" && name != "step.inputs" && !name.ends_with(".aborted.mcap")
    });
    files.sort();
    let mut h = Sha256::new();
    for f in files {
        let path = dir.join(&f);
        let bytes = std::fs::read(&path).map_err(io(&path))?;
        h.update(f.to_string_lossy().as_bytes());
        h.update([0]);
        h.update(Sha256::digest(&bytes));
    }
    Ok(format!("{:x}", h.finalize()))
}

/// The record of a finished step in `dir`, if there is one.
pub fn read_record(dir: &Path) -> Option<StepRecord> {
    let text = std::fs::read_to_string(dir.join("step.json")).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReproduceError> {
    let tmp = path.with_extension("writing");
    std::fs::write(&tmp, bytes).map_err(io(&tmp))?;
    std::fs::rename(&tmp, path).map_err(io(path))
}

/// Runs every step the preset asks for, then writes the findings report.
pub fn reproduce(
    options: &Options,
    stop: &AtomicBool,
    progress: &Progress,
) -> Result<End, ReproduceError> {
    let out = &options.out;
    let has_steps = Step::ALL.iter().any(|s| out.join(s.dir()).exists());
    if has_steps && !options.resume {
        return Err(ReproduceError::AlreadyThere(out.clone()));
    }
    std::fs::create_dir_all(out).map_err(io(out))?;
    let _lock =
        crate::lock::OutputLock::acquire(out).map_err(|e| ReproduceError::step("reproduce", e))?;
    let ctx = steps::Context {
        out,
        preset: &options.preset,
        backend: &options.backend,
        stop,
        bar: &progress.work,
    };
    progress.steps.set_length(Step::ALL.len() as u64 + 1);
    let (mut ran, mut kept) = (Vec::new(), Vec::new());
    for (k, step) in Step::ALL.iter().copied().enumerate() {
        progress.steps.set_message(format!(
            "step {} of {}: {}",
            k + 1,
            Step::ALL.len() + 1,
            step.title()
        ));
        let dir = out.join(step.dir());
        let inputs = sha256_text(&step.inputs(&ctx)?);
        let done = read_record(&dir).is_some_and(|r| r.inputs_sha256 == inputs);
        if done {
            kept.push(step.name());
            progress.steps.inc(1);
            continue;
        }
        // A step interrupted with the same inputs carries on (a batch keeps its trials);
        // one whose inputs changed starts again.
        let same_inputs =
            std::fs::read_to_string(dir.join("step.inputs")).is_ok_and(|h| h.trim() == inputs);
        if dir.exists() && !same_inputs {
            std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
        }
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        std::fs::write(dir.join("step.inputs"), &inputs).map_err(io(&dir))?;
        progress.work.reset();
        progress.work.set_length(0);
        progress.work.set_message("");
        let started = std::time::Instant::now();
        let finished = step.run(&ctx, &dir)?;
        if !finished || stop.load(Ordering::Relaxed) {
            return Ok(End::Interrupted { step: step.name() });
        }
        let (tmo_version, git_revision) = crate::trial::TrialMeta::code_version();
        let record = StepRecord {
            step: step.name().into(),
            inputs_sha256: inputs,
            outputs_sha256: digest_dir(&dir)?,
            wall_s: started.elapsed().as_secs_f64(),
            tmo_version,
            git_revision,
        };
        write_atomic(
            &dir.join("step.json"),
            serde_json::to_string_pretty(&record)
                .expect("a record serialises")
                .as_bytes(),
        )?;
        ran.push(step.name());
        progress.steps.inc(1);
    }
    progress.steps.set_message(format!(
        "step {0} of {0}: the findings report",
        Step::ALL.len() + 1
    ));
    let report = page::write_findings(out, &options.preset)?;
    progress.steps.inc(1);
    Ok(End::Finished { ran, kept, report })
}
