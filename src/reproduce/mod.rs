//! `tmo reproduce`: the paper's experiments in order, as steps that call the same library
//! code as `tmo run`, `tmo sweep`, `tmo train` and `tmo evaluate`, and a findings table
//! against the paper's numbers (`docs/paper_findings.toml`).
//!
//! Each step writes into its own directory under the output directory and, when it has
//! finished, a `step.json` naming the SHA-256 of its inputs (its settings and the outputs
//! of the steps it reads) and of its outputs. `--resume` skips a step whose `step.json`
//! matches its inputs as they are now, this build, and its outputs as they are now;
//! finishes a batch step that was interrupted (its trials are kept); and reruns a step
//! whose inputs changed or whose outputs did. A step is only ever marked
//! done once all its files are in place, so a Ctrl-C or kill -9 loses no finished step.

pub mod check;
pub mod evidence;
pub mod findings;
pub mod hand_model;
pub mod measure;
pub mod outside;
pub mod page;
pub mod page_evidence;
pub mod screen;
pub mod sensitivity;
pub mod shards;
pub mod show;
pub mod standing;
pub mod steps;
pub mod sweep_parts;

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
    #[error(transparent)]
    Merge(#[from] shards::MergeError),
    #[error(transparent)]
    SweepParts(#[from] sweep_parts::SweepPartError),
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
    /// Independent replicates of every step (each with its own trial and learner seeds).
    pub replicates: u32,
    /// `Some` to run the sensitivity study too: the parameters to vary (none named: every
    /// physical parameter).
    pub sensitivity: Option<Vec<String>>,
    /// Replicates (and variants) run side by side, each on its own thread; 1 on a real rig.
    /// A replicate's results do not depend on it: every replicate has its own seeds and
    /// directory.
    pub jobs: usize,
    /// Run only this part of the replicate (x variant) plan, for `tmo reproduce merge` to
    /// join with the other parts.
    pub shard: Option<crate::output::shard::Shard>,
    /// Run only the rail sweeps' part `shard` of the plan (with each job's rail collect):
    /// the first stage of a reproduction whose sweeps are spread over more processes than
    /// it has replicates ([`sweep_parts`]).
    pub sweep_only: bool,
    /// The finished `sweep_only` parts to take the rail sweeps' rows from (the second
    /// stage); empty to sweep here.
    pub sweep_from: Vec<PathBuf>,
    /// Keep the sensitivity variants' trial logs; by default a variant's replicate removes
    /// them once it is finished ([`prune_logs`]).
    pub keep_variant_logs: bool,
    /// A user's model in place of the whole hand's global model ([`hand_model`]).
    pub hand_model: Option<hand_model::HandModel>,
    pub resume: bool,
    pub backend: Backend,
}

/// The directory of replicate `r` (1-based) under the output directory.
pub fn replicate_dir(out: &Path, r: u32) -> PathBuf {
    out.join(format!("replicate-{r:02}"))
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
    /// Also say each step as it ends, one line on standard error: where the bars draw
    /// nothing (a log file, CI, a cluster job), a long reproduction still shows it runs.
    pub step_lines: bool,
}

impl Progress {
    /// Bars that draw nothing (tests, or output that is not a terminal).
    pub fn hidden() -> Self {
        Self {
            steps: indicatif::ProgressBar::hidden(),
            work: indicatif::ProgressBar::hidden(),
            step_lines: false,
        }
    }

    /// One line for a step that ended: its name, what became of it, the time so far.
    fn step_ended(&self, name: &str, what: &str) {
        if self.step_lines {
            eprintln!(
                "reproduce: {name}: {what} ({:.0} s)",
                self.steps.elapsed().as_secs_f64()
            );
        }
    }
}

/// How a reproduction ended.
#[derive(Debug)]
pub enum End {
    Finished {
        /// Steps run now and steps already done (`replicate-01/rail_sweep`).
        ran: Vec<String>,
        kept: Vec<String>,
        /// Finished steps run again, and why (their outputs changed since they finished, or
        /// another build of tmo made them).
        remade: Vec<String>,
        report: Box<page::Written>,
    },
    Interrupted {
        /// The step, as `replicate-01/rail_sweep`.
        step: String,
    },
    /// A sweep part finished; `tmo reproduce --sweep-from` takes its rows.
    SweepPart {
        record: Box<sweep_parts::SweepPartRecord>,
    },
    /// A shard finished its part; `tmo reproduce merge` writes the findings.
    Shard {
        ran: Vec<String>,
        kept: Vec<String>,
        remade: Vec<String>,
        record: Box<shards::ShardRecord>,
    },
}

pub(crate) fn sha256_text(text: &str) -> String {
    crate::trial::sha256_hex(text.as_bytes())
}

/// SHA-256 over a directory's files (relative path and content, in path order), leaving
/// out the step's own bookkeeping. Files a [`PRUNED`] manifest lists and that are gone
/// count with the digest they had, so a pruned step keeps the digest it finished with.
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
        name != "step.json"
            && name != "step.inputs"
            && name != PRUNED
            && !name.ends_with(".aborted.mcap")
    });
    let mut digests: std::collections::BTreeMap<PathBuf, Vec<u8>> = read_pruned(dir)?
        .into_iter()
        .map(|(f, hex)| (PathBuf::from(f), hex_bytes(&hex)))
        .collect();
    for f in files {
        let path = dir.join(&f);
        let bytes = std::fs::read(&path).map_err(io(&path))?;
        digests.insert(f, Sha256::digest(&bytes).to_vec());
    }
    let mut h = Sha256::new();
    for (f, digest) in digests {
        h.update(f.to_string_lossy().as_bytes());
        h.update([0]);
        h.update(digest);
    }
    Ok(format!("{:x}", h.finalize()))
}

/// A step's manifest of the trial logs removed from it: relative path -> SHA-256 (hex).
pub const PRUNED: &str = "pruned.json";

fn read_pruned(dir: &Path) -> Result<std::collections::BTreeMap<String, String>, ReproduceError> {
    let path = dir.join(PRUNED);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text).map_err(|e| {
            ReproduceError::step(
                "resume",
                format!("{}: not a pruned-log manifest: {e}", path.display()),
            )
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Default::default()),
        Err(e) => Err(io(&path)(e)),
    }
}

/// The bytes of a hex string (a manifest's digests, which this program wrote).
fn hex_bytes(hex: &str) -> Vec<u8> {
    (0..hex.len() / 2)
        .map(|i| u8::from_str_radix(hex.get(2 * i..2 * i + 2).unwrap_or("zz"), 16).unwrap_or(0))
        .collect()
}

/// Removes the trial logs of a finished replicate's steps, each listed with its digest in
/// the step's [`PRUNED`] manifest, so the step keeps its recorded digest. The findings read
/// the steps' outcome tables, models and evaluations, not their logs; the rail collect's
/// logs stay (the pin speeds are read from them). A sensitivity study at the paper's counts
/// keeps some 850 MB of logs a variant replicate otherwise: 350 GB for a full study.
pub fn prune_logs(replicate: &Path) -> Result<u64, ReproduceError> {
    let mut freed = 0;
    for step in Step::ALL.iter().filter(|s| **s != Step::RailCollect) {
        let dir = replicate.join(step.dir());
        if read_record(&dir).is_none() {
            continue;
        }
        let mut logs = Vec::new();
        collect_logs(&dir, &dir, &mut logs)?;
        if logs.is_empty() {
            continue;
        }
        let mut manifest = read_pruned(&dir)?;
        for f in &logs {
            let path = dir.join(f);
            let bytes = std::fs::read(&path).map_err(io(&path))?;
            freed += bytes.len() as u64;
            manifest.insert(
                f.to_string_lossy().into_owned(),
                format!("{:x}", Sha256::digest(&bytes)),
            );
        }
        // the manifest first: a crash between the two leaves files the manifest also
        // lists, which count once
        write_atomic(
            &dir.join(PRUNED),
            serde_json::to_string_pretty(&manifest)
                .expect("a manifest serialises")
                .as_bytes(),
        )?;
        for f in logs {
            let path = dir.join(f);
            std::fs::remove_file(&path).map_err(io(&path))?;
        }
    }
    Ok(freed)
}

fn collect_logs(dir: &Path, root: &Path, out: &mut Vec<PathBuf>) -> Result<(), ReproduceError> {
    for entry in std::fs::read_dir(dir).map_err(io(dir))? {
        let path = entry.map_err(io(dir))?.path();
        if path.is_dir() {
            collect_logs(&path, root, out)?;
        } else if path.extension().is_some_and(|x| x == "mcap") {
            out.push(path.strip_prefix(root).unwrap_or(&path).to_path_buf());
        }
    }
    Ok(())
}

/// Whether any step of the replicate in `dir` had its logs pruned.
fn has_pruned(dir: &Path) -> bool {
    Step::ALL
        .iter()
        .any(|s| dir.join(s.dir()).join(PRUNED).exists())
}

/// The record of a finished step in `dir`, if there is one.
pub fn read_record(dir: &Path) -> Option<StepRecord> {
    let text = std::fs::read_to_string(dir.join("step.json")).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReproduceError> {
    crate::output::atomic::write_atomic(path, bytes).map_err(io(path))
}

/// Runs every step the preset asks for in each replicate (and, for a sensitivity study,
/// again in each variant), then writes the findings report; a shard runs its part of
/// that plan and writes its record instead.
pub fn reproduce(
    options: &Options,
    stop: &AtomicBool,
    progress: &Progress,
) -> Result<End, ReproduceError> {
    let started = std::time::Instant::now();
    let out = &options.out;
    let replicates = options.replicates.max(1);
    let has_steps = out.join(shards::RECORD).exists()
        || sweep_parts::holds_part(out)
        || std::fs::read_dir(out).is_ok_and(|mut entries| {
            entries.any(|e| {
                e.is_ok_and(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    name.starts_with("replicate-") || name == "sensitivity"
                })
            })
        })
        || Step::ALL.iter().any(|s| out.join(s.dir()).exists());
    if has_steps && !options.resume {
        return Err(ReproduceError::AlreadyThere(out.clone()));
    }
    if (options.shard.is_some() || options.sweep_only || !options.sweep_from.is_empty())
        && options.backend != Backend::Sim
    {
        return Err(ReproduceError::step(
            "reproduce",
            "--shard, --sweep-only and --sweep-from split a reproduction over processes that each drive their own simulated rig (and run its rail collect again): a real rig runs it whole",
        ));
    }
    let variants = match &options.sensitivity {
        None => Vec::new(),
        Some(only) => {
            if options.backend != Backend::Sim {
                return Err(ReproduceError::step(
                    "sensitivity",
                    "a sensitivity study varies the simulator's parameters: it runs on --backend sim only",
                ));
            }
            sensitivity::study(&tmo_sim::parameters::built_in(), only)
                .map_err(|e| ReproduceError::step("sensitivity", e))?
        }
    };
    // The sweep parts are checked before anything runs: all of them, unaltered, of this plan.
    let shard_plan = shards::ShardPlan::new(options, &variants);
    let sweep_from = if options.sweep_from.is_empty() {
        None
    } else {
        Some(sweep_parts::SweepParts::load(
            &options.sweep_from,
            &shard_plan,
        )?)
    };
    std::fs::create_dir_all(out).map_err(io(out))?;
    let _lock = crate::output::lock::OutputLock::acquire(out)
        .map_err(|e| ReproduceError::step("reproduce", e))?;
    // A shard's record is written last: one left from an earlier run of it no longer
    // stands once the shard runs again.
    let record_path = out.join(shards::RECORD);
    for path in [record_path.clone(), out.join(sweep_parts::RECORD)] {
        if path.exists() {
            std::fs::remove_file(&path).map_err(io(&path))?;
        }
    }

    let none = Default::default();
    let sims: Vec<_> = variants.iter().map(|v| v.sim()).collect();
    let runs: Vec<Run> = std::iter::once(Run {
        dir: out.clone(),
        label: String::new(),
        sim: &none,
        reuse: None,
        seed_offset: 0,
    })
    .chain(variants.iter().zip(&sims).map(|(v, sim)| Run {
        dir: v.dir(out),
        label: format!("{}/", v.dir_name()),
        sim,
        // the variants take the baseline's steps their parameter does not touch
        reuse: Some(out),
        seed_offset: v.seed_offset(replicates),
    }))
    .collect();
    // The plan: the baseline's replicates, then each variant's; a shard takes its part.
    let plan: Vec<(&Run, u32)> = runs
        .iter()
        .flat_map(|run| (1..=replicates).map(move |r| (run, r)))
        .collect();
    if options.sweep_only {
        let jobs: Vec<sweep_parts::PlanJob> = plan
            .iter()
            .map(|(run, r)| sweep_parts::PlanJob {
                dir: shards::job_dir(run.label.strip_suffix('/'), *r),
                sim: run.sim,
                replicate: *r + run.seed_offset,
            })
            .collect();
        let shard = options
            .shard
            .unwrap_or(crate::output::shard::Shard { index: 1, count: 1 });
        return sweep_parts::run_part(options, &shard_plan, &jobs, shard, stop, progress);
    }
    let mine: Vec<(&Run, u32)> = match options.shard {
        Some(shard) => shard.select(plan),
        None => plan,
    };
    let (baseline, variant_jobs): (Vec<_>, Vec<_>) =
        mine.iter().partition(|(run, _)| run.reuse.is_none());
    let report_steps = usize::from(options.shard.is_none());
    let steps_in_all = Step::ALL.len() * mine.len() + report_steps;
    progress.steps.set_length(steps_in_all as u64);
    let tally = std::sync::Mutex::new(Steps::default());
    let sweep_from = sweep_from.as_ref();
    for result in run_all(
        &baseline, options, sweep_from, stop, progress, &tally, false,
    )
    .into_iter()
    .flatten()
    {
        if let Some(step) = result? {
            return Ok(End::Interrupted { step });
        }
    }
    // The variants start once the baseline is finished: they take its steps. A variant
    // whose world the rig cannot run (a grasp past the hand's limits, say) is a result of
    // the study, not a reason to stop it: its error is kept in its directory.
    let results = run_all(
        &variant_jobs,
        options,
        sweep_from,
        stop,
        progress,
        &tally,
        true,
    );
    let mut failed_runs: Vec<(&Path, String)> = Vec::new();
    for ((run, _), result) in variant_jobs.iter().zip(&results) {
        if let Some(Err(e)) = result {
            if !failed_runs.iter().any(|(d, _)| *d == run.dir) {
                failed_runs.push((&run.dir, e.to_string()));
            }
        }
    }
    for run in runs.iter().skip(1) {
        if !variant_jobs.iter().any(|(r, _)| r.dir == run.dir) {
            continue;
        }
        let failed = run.dir.join(sensitivity::FAILED);
        match failed_runs.iter().find(|(d, _)| *d == run.dir) {
            Some((_, why)) => {
                std::fs::create_dir_all(&run.dir).map_err(io(&run.dir))?;
                crate::output::atomic::write_atomic(&failed, why.as_bytes()).map_err(io(&failed))?
            }
            None if failed.exists() => std::fs::remove_file(&failed).map_err(io(&failed))?,
            None => {}
        }
    }
    for result in results.into_iter().flatten() {
        if let Ok(Some(step)) = result {
            return Ok(End::Interrupted { step });
        }
    }
    let tally = tally.into_inner().expect("no worker panicked");
    if let Some(shard) = options.shard {
        let record = shards::ShardRecord {
            shard: shard.to_string(),
            plan: shard_plan,
            sweep_parts: sweep_from.map(|p| p.count()),
            jobs: mine
                .iter()
                .map(|(run, r)| shards::ShardJob {
                    dir: shards::job_dir(run.label.strip_suffix('/'), *r),
                    failed: failed_runs
                        .iter()
                        .find(|(d, _)| *d == run.dir)
                        .map(|(_, why)| why.clone()),
                })
                .collect(),
            wall_s: started.elapsed().as_secs_f64(),
        };
        write_atomic(
            &record_path,
            serde_json::to_string_pretty(&record)
                .expect("a shard record serialises")
                .as_bytes(),
        )?;
        return Ok(End::Shard {
            ran: tally.ran,
            kept: tally.kept,
            remade: tally.remade,
            record: Box::new(record),
        });
    }
    progress.steps.set_message(format!(
        "step {steps_in_all} of {steps_in_all}: the findings report"
    ));
    let study = (!variants.is_empty()).then_some(variants.as_slice());
    let report = Box::new(page::write_findings(
        out,
        &options.preset,
        replicates,
        study,
    )?);
    progress.steps.inc(1);
    Ok(End::Finished {
        ran: tally.ran,
        kept: tally.kept,
        remade: tally.remade,
        report,
    })
}

/// One set of replicates: the baseline, or a sensitivity variant.
struct Run<'a> {
    dir: PathBuf,
    /// How its steps are named in messages (`physics.x@low/`; empty for the baseline).
    label: String,
    sim: &'a std::collections::BTreeMap<String, f64>,
    /// The baseline's directory, whose replicates' steps may be reused.
    reuse: Option<&'a Path>,
    /// Its replicate r is seeded as replicate `r + seed_offset` (the noise reference's
    /// other seeds; 0 otherwise).
    seed_offset: u32,
}

#[derive(Default)]
struct Steps {
    ran: Vec<String>,
    kept: Vec<String>,
    remade: Vec<String>,
}

/// Runs the jobs (a replicate of a run each), `options.jobs` at a time, and gives each
/// one's end in their order (`None` for one never started: an error stops the runs
/// unless `keep_going`, and an interruption stops them). With several jobs the
/// first job's work shows on the work bar; the others run with hidden bars.
fn run_all(
    jobs: &[&(&Run, u32)],
    options: &Options,
    sweep_from: Option<&sweep_parts::SweepParts>,
    stop: &AtomicBool,
    progress: &Progress,
    tally: &std::sync::Mutex<Steps>,
    keep_going: bool,
) -> Vec<Option<JobEnd>> {
    let workers = if options.backend == Backend::Sim {
        options.jobs.clamp(1, jobs.len().max(1))
    } else {
        1
    };
    on_workers(jobs, workers, &progress.work, stop, |&&(run, r), bar| {
        let result = run_replicate(run, r, options, sweep_from, stop, progress, bar, tally);
        let halt = match &result {
            Ok(interrupted) => interrupted.is_some(),
            Err(_) => !keep_going,
        };
        (result, halt)
    })
}

/// Runs `work` on each of `items`, `workers` at a time on threads, and gives each one's
/// result in their order (`None` for one never started: a worker starts no more once
/// `work` says to halt, or once `stop` is set). The first worker's work shows on `bar`,
/// the others' on hidden bars.
pub(crate) fn on_workers<T: Sync, R: Send>(
    items: &[T],
    workers: usize,
    bar: &indicatif::ProgressBar,
    stop: &AtomicBool,
    work: impl Fn(&T, &indicatif::ProgressBar) -> (R, bool) + Sync,
) -> Vec<Option<R>> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let work = &work;
    let ended: Vec<(usize, R)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers.max(1))
            .map(|w| {
                let next = &next;
                scope.spawn(move || {
                    let bar = if w == 0 {
                        bar.clone()
                    } else {
                        indicatif::ProgressBar::hidden()
                    };
                    let mut ended = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(i) else { break };
                        let (result, halt) = work(item, &bar);
                        ended.push((i, result));
                        if halt || stop.load(Ordering::Relaxed) {
                            break;
                        }
                    }
                    ended
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("a reproduce worker panicked"))
            .collect()
    });
    let mut all: Vec<Option<R>> = (0..items.len()).map(|_| None).collect();
    for (i, r) in ended {
        all[i] = Some(r);
    }
    all
}

/// How one replicate of one run ended: `Ok(Some(step))` where it was interrupted.
type JobEnd = Result<Option<String>, ReproduceError>;

/// Runs replicate `r` of `run`; the step it was interrupted in, if it was.
#[allow(clippy::too_many_arguments)]
fn run_replicate(
    run: &Run,
    r: u32,
    options: &Options,
    sweep_from: Option<&sweep_parts::SweepParts>,
    stop: &AtomicBool,
    progress: &Progress,
    bar: &indicatif::ProgressBar,
    tally: &std::sync::Mutex<Steps>,
) -> Result<Option<String>, ReproduceError> {
    let replicates = options.replicates.max(1);
    let dir = replicate_dir(&run.dir, r);
    let reuse = run.reuse.map(|base| replicate_dir(base, r));
    let job = shards::job_dir(run.label.strip_suffix('/'), r);
    let ctx = steps::Context {
        out: &dir,
        replicate: r + run.seed_offset,
        sim: run.sim,
        reuse: reuse.as_deref(),
        preset: &options.preset,
        backend: &options.backend,
        stop,
        bar,
        job: &job,
        sweep_from: sweep_from.map(|p| p as &dyn steps::SweptElsewhere),
        hand_model: options.hand_model.as_ref(),
    };
    // A pruned replicate with a step to run again starts again from its pruned steps: a
    // later step may read their logs.
    if has_pruned(&dir) && !finished_as_is(&ctx)? {
        for step in Step::ALL {
            let step_dir = dir.join(step.dir());
            if step_dir.join(PRUNED).exists() {
                std::fs::remove_dir_all(&step_dir).map_err(io(&step_dir))?;
            }
        }
    }
    for (k, step) in Step::ALL.iter().copied().enumerate() {
        let name = format!("{}replicate-{r:02}/{}", run.label, step.name());
        progress.steps.set_message(format!(
            "{}replicate {r} of {replicates}, step {} of {}: {}",
            run.label,
            k + 1,
            Step::ALL.len(),
            step.title()
        ));
        // A baseline step this run has made or checked is trusted by its record; one it
        // has not (a directory put there by hand) is read again before it is taken.
        let baseline_name = format!("replicate-{r:02}/{}", step.name());
        let reuse_checked = run.reuse.is_some() && {
            let t = tally.lock().expect("no worker panicked");
            t.ran.contains(&baseline_name) || t.kept.contains(&baseline_name)
        };
        let end = run_step(&ctx, step, bar, reuse_checked)?;
        progress.step_ended(
            &name,
            match &end {
                StepEnd::Ran => "ran",
                StepEnd::Remade(_) => "ran again",
                StepEnd::Kept => "already done",
                StepEnd::Interrupted => "interrupted",
            },
        );
        let mut t = tally.lock().expect("no worker panicked");
        match end {
            StepEnd::Ran => t.ran.push(name),
            StepEnd::Remade(why) => {
                t.remade.push(format!("{name}: {why}"));
                t.ran.push(name);
            }
            StepEnd::Kept => t.kept.push(name),
            StepEnd::Interrupted => return Ok(Some(name)),
        }
        drop(t);
        progress.steps.inc(1);
    }
    if run.reuse.is_some() && !options.keep_variant_logs {
        prune_logs(&dir)?;
    }
    Ok(None)
}

/// Whether every step of `ctx`'s replicate is finished with the inputs it has now.
fn finished_as_is(ctx: &steps::Context) -> Result<bool, ReproduceError> {
    for step in Step::ALL {
        let inputs = sha256_text(&step.inputs(ctx)?);
        if check_finished(&ctx.out.join(step.dir()), &inputs, true)?.is_err() {
            return Ok(false);
        }
    }
    Ok(true)
}

/// `to` as a copy of the finished step `from`, its files hard-linked where the file system
/// allows (a finished step's files are never written again) and copied where not.
/// `to` made a new name of `from`'s file, or a new copy of it where links cannot be made
/// (another file system). Never written through an existing `to`: that may be `from`
/// itself under another name (a hard link a concurrent merge made), and copying onto it
/// would truncate the input.
fn link_or_copy(from: &Path, to: &Path) -> Result<(), ReproduceError> {
    match std::fs::hard_link(from, to) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(io(to)(e)),
        Err(_) => {
            let mut src = std::fs::File::open(from).map_err(io(from))?;
            let mut dst = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(to)
                .map_err(io(to))?;
            std::io::copy(&mut src, &mut dst).map_err(io(to))?;
            Ok(())
        }
    }
}

fn link_tree(from: &Path, to: &Path) -> Result<(), ReproduceError> {
    std::fs::create_dir_all(to).map_err(io(to))?;
    for entry in std::fs::read_dir(from).map_err(io(from))? {
        let path = entry.map_err(io(from))?.path();
        let target = to.join(path.file_name().expect("a directory entry has a name"));
        if path.is_dir() {
            link_tree(&path, &target)?;
        } else {
            link_or_copy(&path, &target)?;
        }
    }
    Ok(())
}

enum StepEnd {
    Ran,
    /// A finished step run again, and why.
    Remade(String),
    Kept,
    Interrupted,
}

/// Whether the finished step in `dir` can be kept for `inputs`: `Ok(())` if its record
/// says these inputs, this build of tmo, and outputs that are still the ones it recorded;
/// otherwise why not (`None`: no finished step with these inputs at all). `rehash` false
/// trusts the recorded digest: for a step this run has itself just made or checked.
fn check_finished(
    dir: &Path,
    inputs: &str,
    rehash: bool,
) -> Result<Result<(), Option<String>>, ReproduceError> {
    let Some(record) = read_record(dir).filter(|r| r.inputs_sha256 == inputs) else {
        return Ok(Err(None));
    };
    let (version, revision) = crate::trial::TrialMeta::code_version();
    if record.tmo_version != version || record.git_revision != revision {
        return Ok(Err(Some(format!(
            "made by tmo {} ({}), not this build ({version}, {revision})",
            record.tmo_version, record.git_revision
        ))));
    }
    // Its outputs are read again: a file edited, replaced or damaged since the step
    // finished would otherwise be kept, and every later step would build on it.
    if rehash && digest_dir(dir)? != record.outputs_sha256 {
        return Ok(Err(Some(
            "its outputs changed since it finished (their SHA-256 is not the one step.json \
             recorded)"
                .into(),
        )));
    }
    Ok(Ok(()))
}

/// Runs one step of one replicate unless it is already done with the same inputs.
fn run_step(
    ctx: &steps::Context,
    step: Step,
    bar: &indicatif::ProgressBar,
    reuse_checked: bool,
) -> Result<StepEnd, ReproduceError> {
    let dir = ctx.out.join(step.dir());
    let inputs = sha256_text(&step.inputs(ctx)?);
    let remade = match check_finished(&dir, &inputs, true)? {
        Ok(()) => return Ok(StepEnd::Kept),
        Err(why) => why,
    };
    if let Some(from) = ctx.reuse.map(|r| r.join(step.dir())) {
        // A baseline step this run made or checked has fresh digests: hashing its files
        // again for every variant would read the same gigabytes some eighty times at the
        // paper's scale.
        if check_finished(&from, &inputs, !reuse_checked)?.is_ok() {
            if dir.exists() {
                std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
            }
            link_tree(&from, &dir)?;
            return Ok(StepEnd::Kept);
        }
    }
    // A step interrupted with the same inputs carries on (a batch keeps its trials); one
    // whose inputs changed, or a finished one that cannot be kept, starts again.
    let same_inputs =
        std::fs::read_to_string(dir.join("step.inputs")).is_ok_and(|h| h.trim() == inputs);
    if dir.exists() && (!same_inputs || remade.is_some()) {
        std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
    }
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    crate::output::atomic::write_atomic(&dir.join("step.inputs"), inputs.as_bytes())
        .map_err(io(&dir))?;
    bar.reset();
    bar.set_length(0);
    bar.set_message("");
    let started = std::time::Instant::now();
    let finished = step.run(ctx, &dir)?;
    if !finished || ctx.stop.load(Ordering::Relaxed) {
        return Ok(StepEnd::Interrupted);
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
    Ok(remade.map_or(StepEnd::Ran, StepEnd::Remade))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pruned_step_keeps_its_digest_and_a_changed_manifest_does_not() {
        let root = tempfile::tempdir().unwrap();
        let replicate = root.path();
        let step = replicate.join(Step::HandOnline.dir());
        std::fs::create_dir_all(step.join("sub")).unwrap();
        std::fs::write(step.join("outcomes.json"), b"[]").unwrap();
        std::fs::write(step.join("t-000.mcap"), b"log zero").unwrap();
        std::fs::write(step.join("sub/t-001.mcap"), b"log one").unwrap();
        let before = digest_dir(&step).unwrap();
        std::fs::write(
            step.join("step.json"),
            serde_json::to_string(&StepRecord {
                step: "hand_online".into(),
                inputs_sha256: "x".into(),
                outputs_sha256: before.clone(),
                wall_s: 0.0,
                tmo_version: "0".into(),
                git_revision: "0".into(),
            })
            .unwrap(),
        )
        .unwrap();
        // the rail collect keeps its logs, and a step with no record is left alone
        let collect = replicate.join(Step::RailCollect.dir());
        std::fs::create_dir_all(&collect).unwrap();
        std::fs::write(collect.join("step.json"), "{}").unwrap();
        std::fs::write(collect.join("r.mcap"), b"rail").unwrap();
        let unfinished = replicate.join(Step::Objects.dir());
        std::fs::create_dir_all(&unfinished).unwrap();
        std::fs::write(unfinished.join("o.mcap"), b"object").unwrap();

        let freed = prune_logs(replicate).unwrap();
        assert_eq!(freed, 15);
        assert!(!step.join("t-000.mcap").exists() && !step.join("sub/t-001.mcap").exists());
        assert!(collect.join("r.mcap").exists() && unfinished.join("o.mcap").exists());
        assert_eq!(digest_dir(&step).unwrap(), before);
        assert!(has_pruned(replicate));
        // pruning again changes nothing; a log the manifest lists that is still there (a
        // crash between the manifest and the removal) counts once
        assert_eq!(prune_logs(replicate).unwrap(), 0);
        std::fs::write(step.join("t-000.mcap"), b"log zero").unwrap();
        assert_eq!(digest_dir(&step).unwrap(), before);
        std::fs::remove_file(step.join("t-000.mcap")).unwrap();
        // a manifest edited after the fact no longer gives the recorded digest
        let manifest = std::fs::read_to_string(step.join(PRUNED)).unwrap();
        std::fs::write(step.join(PRUNED), manifest.replacen("t-000", "t-009", 1)).unwrap();
        assert_ne!(digest_dir(&step).unwrap(), before);
    }
}
