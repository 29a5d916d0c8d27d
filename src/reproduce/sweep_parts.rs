//! A reproduction's rail sweeps spread wider than its replicates. The sweep is some 90 % of
//! a paper replicate, so a plan whose smallest part is a replicate cannot use more nodes
//! than it has replicates. In two stages it can:
//!
//! 1. `tmo reproduce --sweep-only --shard K/N` runs part K of every job's rail sweep: the
//!    chains of cells of all the jobs' sweeps ([`SweepSpec::chains`]), dealt out over the N
//!    parts by their cost ([`deal`]). Each part first runs the rail collect of every job it
//!    sweeps for (deterministic from the job's seeds, about a second), and records that
//!    step's output digest with its rows.
//! 2. `tmo reproduce --sweep-from DIR... [--shard K/N]` runs the jobs' steps as usual, but
//!    its rail sweep step joins the parts' rows ([`SweepParts::rows_for`]) instead of
//!    computing them; `tmo reproduce merge` joins its shards as before.
//!
//! The joined sweep is the single run's: a part runs whole chains, so every cell starts as
//! it does in one run, with the same learner seed; the parts must have swept the very rail
//! trials this job collected (the digests must match), all N parts must be there, each
//! once, and the grid must be covered exactly once.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use super::shards::{check_records, MergeError, PartRecord, ShardPlan};
use super::steps::{self, Context};
use super::{io, Options, ReproduceError, Step};
use crate::output::shard::Shard;
use crate::slip::sweep::{SweepRow, SweepSpec};
use crate::slip::sweep_file::{SweepPart, SweepTarget};

/// The record a finished sweep part leaves in its directory.
pub const RECORD: &str = super::shards::SWEEP_PART_RECORD;

/// Where a job's part of its sweep goes, under the job's directory in the part's.
pub fn part_csv(job_dir: &Path) -> PathBuf {
    job_dir
        .join(format!("{}.part", Step::RailSweep.dir()))
        .join("sweep.csv")
}

/// Deals the chains of `jobs` sweeps, each of the chains whose costs are `costs`, over
/// `count` parts: costliest first, each to the part with the least work so far (the lower
/// part on a tie). Every part's work then exceeds another's by at most one chain's cost.
/// Gives each part's `(job, chain)` pairs in job then chain order.
pub fn deal(jobs: usize, costs: &[f64], count: usize) -> Vec<Vec<(usize, usize)>> {
    let mut units: Vec<(usize, usize)> = (0..jobs)
        .flat_map(|j| (0..costs.len()).map(move |c| (j, c)))
        .collect();
    // a stable sort keeps job then chain order among equal costs
    units.sort_by(|a, b| costs[b.1].total_cmp(&costs[a.1]));
    let count = count.max(1);
    let mut load = vec![0.0f64; count];
    let mut parts: Vec<Vec<(usize, usize)>> = vec![Vec::new(); count];
    for unit in units {
        let lightest = (0..count)
            .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
            .expect("at least one part");
        load[lightest] += costs[unit.1];
        parts[lightest].push(unit);
    }
    for part in &mut parts {
        part.sort_unstable();
    }
    parts
}

/// One job's share of a part.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PartJob {
    /// The job's directory (`replicate-01`), as the plan names it.
    pub dir: String,
    /// Its sweep's chains this part ran, by their position in [`SweepSpec::chains`].
    pub chains: Vec<usize>,
    /// The digest of the training and test sets it swept ([`crate::slip::dataset::Dataset::digest`]; a trial
    /// log also records when it was made, so the logs' own digests differ run to run).
    pub data_sha256: String,
    /// The SHA-256 of its rows' file.
    pub sweep_sha256: String,
}

/// `sweep-part.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepPartRecord {
    /// "K/N".
    pub part: String,
    pub plan: ShardPlan,
    pub jobs: Vec<PartJob>,
    pub wall_s: f64,
}

impl PartRecord for SweepPartRecord {
    const FILE: &'static str = RECORD;
    fn shard(&self) -> &str {
        &self.part
    }
    fn plan(&self) -> &ShardPlan {
        &self.plan
    }
    fn missing(dir: &Path) -> MergeError {
        MergeError::NotASweepPart {
            dir: dir.to_path_buf(),
        }
    }
}

/// A job of the plan: its directory, the simulator parameters it runs with, its replicate.
pub(crate) struct PlanJob<'a> {
    pub dir: String,
    pub sim: &'a std::collections::BTreeMap<String, f64>,
    pub replicate: u32,
}

/// Runs part `shard` of the plan's sweeps into `options.out` and writes its record.
pub(crate) fn run_part(
    options: &Options,
    plan: &ShardPlan,
    jobs: &[PlanJob],
    shard: Shard,
    stop: &AtomicBool,
    progress: &super::Progress,
) -> Result<super::End, ReproduceError> {
    let started = std::time::Instant::now();
    let c = options.preset.counts();
    // The grid and its chains are the same in every job; only the seed differs.
    let grid = steps::sweep_spec_for(&options.preset, 1);
    let costs: Vec<f64> = grid.chains().iter().map(|ch| grid.chain_cost(ch)).collect();
    let mine = deal(jobs.len(), &costs, shard.count).swap_remove(shard.index - 1);
    let mut by_job: Vec<(usize, Vec<usize>)> = Vec::new();
    for (j, chain) in mine {
        match by_job.last_mut() {
            Some((last, chains)) if *last == j => chains.push(chain),
            _ => by_job.push((j, vec![chain])),
        }
    }
    progress.steps.set_length(by_job.len() as u64);
    let workers = options.jobs.clamp(1, by_job.len().max(1));
    let ended = super::on_workers(
        &by_job,
        workers,
        &progress.work,
        stop,
        |(j, chains), bar| {
            let job = &jobs[*j];
            progress.steps.set_message(format!(
                "sweep part {shard}: {} ({} chains)",
                job.dir,
                chains.len()
            ));
            let result = run_job_part(options, &c, job, chains, stop, bar);
            progress.steps.inc(1);
            let halt = !matches!(result, Ok(Some(_)));
            (result, halt)
        },
    );
    let mut done: Vec<Option<PartJob>> = Vec::with_capacity(by_job.len());
    for (i, result) in ended.into_iter().enumerate() {
        match result.transpose()? {
            Some(Some(job)) => done.push(Some(job)),
            Some(None) => {
                return Ok(super::End::Interrupted {
                    step: format!("{}/{}", jobs[by_job[i].0].dir, Step::RailSweep.name()),
                })
            }
            None => done.push(None),
        }
    }
    let Some(done) = done.into_iter().collect::<Option<Vec<_>>>() else {
        // a worker stopped before it started every job: only a stop does that
        return Ok(super::End::Interrupted {
            step: "sweep part".into(),
        });
    };
    let record = SweepPartRecord {
        part: shard.to_string(),
        plan: plan.clone(),
        jobs: done,
        wall_s: started.elapsed().as_secs_f64(),
    };
    let path = options.out.join(RECORD);
    crate::output::atomic::write_atomic(
        &path,
        serde_json::to_string_pretty(&record)
            .expect("a part record serialises")
            .as_bytes(),
    )
    .map_err(io(&path))?;
    Ok(super::End::SweepPart {
        record: Box::new(record),
    })
}

/// Runs `job`'s rail collect and the given chains of its sweep; `None` when stopped.
fn run_job_part(
    options: &Options,
    c: &steps::Counts,
    job: &PlanJob,
    chains: &[usize],
    stop: &AtomicBool,
    bar: &indicatif::ProgressBar,
) -> Result<Option<PartJob>, ReproduceError> {
    let dir = options.out.join(&job.dir);
    let ctx = Context {
        out: &dir,
        replicate: job.replicate,
        sim: job.sim,
        reuse: None,
        preset: &options.preset,
        backend: &options.backend,
        stop,
        bar,
        job: &job.dir,
        sweep_from: None,
        // the rail's steps, which no hand model touches
        hand_model: None,
    };
    if matches!(
        super::run_step(&ctx, Step::RailCollect, bar, false)?,
        super::StepEnd::Interrupted
    ) {
        return Ok(None);
    }
    let spec = steps::sweep_spec(&ctx);
    let (train, test) = steps::sweep_data(&ctx, c)?;
    let data = steps::sweep_data_digest(&train, &test);
    let out = part_csv(&dir);
    let target = SweepTarget {
        out: &out,
        resume: true,
        // a part resumed over another rail collect or other chains starts again
        identity: format!(
            "{}data {data}\nchains {chains:?}\n",
            steps::sweep_identity(&ctx, &spec)
        ),
        stop: Some(stop),
        part: SweepPart::Chains(chains.to_vec()),
    };
    bar.reset();
    let result = crate::slip::sweep_file::run_to_file(
        &train,
        &test,
        &spec,
        &target,
        |cells, _| bar.set_length(cells.len() as u64),
        |_| bar.inc(1),
    );
    match result {
        Ok(_) => {}
        Err(e) if e.stopped() => return Ok(None),
        Err(e) => return Err(ReproduceError::step("rail_sweep", e)),
    }
    let bytes = std::fs::read(&out).map_err(super::io(&out))?;
    Ok(Some(PartJob {
        dir: job.dir.clone(),
        chains: chains.to_vec(),
        data_sha256: data,
        sweep_sha256: crate::trial::sha256_hex(&bytes),
    }))
}

/// The finished parts of a plan's sweeps, checked to be all of them, once each.
#[derive(Debug)]
pub struct SweepParts {
    parts: Vec<(PathBuf, SweepPartRecord)>,
}

#[derive(Debug, thiserror::Error)]
pub enum SweepPartError {
    #[error(transparent)]
    Parts(#[from] MergeError),
    #[error("{dir} swept for another reproduction than this one ({what} differ)")]
    OtherPlan { dir: PathBuf, what: &'static str },
    #[error(
        "{dir}: part {part} should sweep {expected:?} (job, chain), its record lists {found:?}"
    )]
    WrongChains {
        dir: PathBuf,
        part: String,
        expected: Vec<(usize, usize)>,
        found: Vec<(usize, usize)>,
    },
    #[error("{dir}: its sweep of {job} was run on other rail trials than this job's rail collect (the training and test sets differ): run the parts again with this build")]
    OtherTrials { dir: PathBuf, job: String },
    #[error("{path}: it changed after the part finished (its SHA-256 is not the one {RECORD} records): run that part again")]
    Altered { path: PathBuf },
    #[error("{0}")]
    Rows(String),
}

impl steps::SweptElsewhere for SweepParts {
    fn rows_for(
        &self,
        ctx: &Context,
        spec: &SweepSpec,
        data: &str,
    ) -> Result<Vec<SweepRow>, ReproduceError> {
        SweepParts::rows_for(self, ctx, spec, data)
    }
}

impl SweepParts {
    /// Reads and checks the parts in `dirs` against the plan this run is part of.
    pub fn load(dirs: &[PathBuf], plan: &ShardPlan) -> Result<Self, SweepPartError> {
        let parts = check_records::<SweepPartRecord>(dirs)?;
        let first = &parts[0];
        if let Some(what) = plan.differs(&first.2.plan) {
            return Err(SweepPartError::OtherPlan {
                dir: first.0.clone(),
                what,
            });
        }
        // each part holds the chains the deal gives it
        let jobs = plan.jobs();
        let grid = steps::sweep_spec_for(&preset_of(plan)?, 1);
        let costs: Vec<f64> = grid.chains().iter().map(|ch| grid.chain_cost(ch)).collect();
        let dealt = deal(jobs.len(), &costs, first.1.count);
        for (dir, shard, record) in &parts {
            let found: Vec<(usize, usize)> = record
                .jobs
                .iter()
                .flat_map(|j| {
                    let k = jobs.iter().position(|d| *d == j.dir).unwrap_or(usize::MAX);
                    j.chains.iter().map(move |c| (k, *c))
                })
                .collect();
            let expected = &dealt[shard.index - 1];
            if found != *expected {
                return Err(SweepPartError::WrongChains {
                    dir: dir.clone(),
                    part: record.part.clone(),
                    expected: expected.clone(),
                    found,
                });
            }
            for job in &record.jobs {
                check_rows_file(dir, job)?;
            }
        }
        Ok(Self {
            parts: parts.into_iter().map(|(d, _, r)| (d, r)).collect(),
        })
    }

    pub fn count(&self) -> usize {
        self.parts.len()
    }

    /// The rows of `ctx`'s job's sweep, joined from every part that swept some of it, in
    /// the order a single run writes them.
    pub fn rows_for(
        &self,
        ctx: &Context,
        spec: &SweepSpec,
        data: &str,
    ) -> Result<Vec<SweepRow>, ReproduceError> {
        let step = "rail_sweep";
        let mut rows = Vec::new();
        for (dir, record) in &self.parts {
            let Some(job) = record.jobs.iter().find(|j| j.dir == ctx.job) else {
                continue;
            };
            if job.data_sha256 != data {
                return Err(ReproduceError::step(
                    step,
                    SweepPartError::OtherTrials {
                        dir: dir.clone(),
                        job: job.dir.clone(),
                    },
                ));
            }
            let path = check_rows_file(dir, job).map_err(|e| ReproduceError::step(step, e))?;
            rows.push((path.clone(), steps::read_sweep(&path)?));
        }
        crate::slip::sweep_file::merge(spec, rows)
            .map_err(|e| ReproduceError::step(step, SweepPartError::Rows(e.to_string())))
    }
}

/// The path of `job`'s rows in the part in `dir`, once they are checked to be the rows the
/// part recorded.
fn check_rows_file(dir: &Path, job: &PartJob) -> Result<PathBuf, SweepPartError> {
    let path = part_csv(&dir.join(&job.dir));
    let bytes = std::fs::read(&path)
        .map_err(|e| SweepPartError::Rows(format!("{}: {e}", path.display())))?;
    if crate::trial::sha256_hex(&bytes) != job.sweep_sha256 {
        return Err(SweepPartError::Altered { path });
    }
    Ok(path)
}

fn preset_of(plan: &ShardPlan) -> Result<super::Preset, SweepPartError> {
    match super::Preset::from_name(&plan.preset) {
        Some(preset) => Ok(preset),
        None => Err(SweepPartError::Parts(MergeError::Plan(
            "preset".into(),
            format!("unknown preset `{}`", plan.preset),
        ))),
    }
}

/// Whether `dir` holds a finished or started sweep part.
pub(crate) fn holds_part(dir: &Path) -> bool {
    dir.join(RECORD).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deal_gives_every_chain_once_and_balances_the_parts() {
        let costs = [9.0, 5.0, 4.0, 1.0, 1.0, 1.0];
        let parts = deal(3, &costs, 4);
        let mut all: Vec<(usize, usize)> = parts.iter().flatten().copied().collect();
        all.sort_unstable();
        let every: Vec<(usize, usize)> = (0..3)
            .flat_map(|j| (0..costs.len()).map(move |c| (j, c)))
            .collect();
        assert_eq!(all, every);
        let work: Vec<f64> = parts
            .iter()
            .map(|p| p.iter().map(|(_, c)| costs[*c]).sum())
            .collect();
        let (most, least) = (
            work.iter().copied().fold(0.0, f64::max),
            work.iter().copied().fold(f64::MAX, f64::min),
        );
        assert!(most - least <= 9.0, "{work:?}");
        // the three costliest chains go to three different parts
        let holding = |u: (usize, usize)| parts.iter().position(|p| p.contains(&u)).unwrap();
        let firsts = [holding((0, 0)), holding((1, 0)), holding((2, 0))];
        assert!(firsts[0] != firsts[1] && firsts[1] != firsts[2] && firsts[0] != firsts[2]);
        // the same deal every time, and one part takes everything
        assert_eq!(deal(3, &costs, 4), parts);
        assert_eq!(deal(3, &costs, 1)[0], every);
    }
}
