//! A reproduction split over processes or cluster jobs: `tmo reproduce --shard K/N` runs
//! part K of the plan (the baseline's replicates, then each sensitivity variant's, dealt
//! out in turn) into its own directory and leaves a record of it; `tmo reproduce merge`
//! checks that the records are the N parts of one plan, each finished and unaltered, and
//! joins them into the directory a single run writes, with its findings report.
//!
//! A replicate's steps depend on each other, so a replicate is the smallest part; its
//! seeds depend only on its number, so where it runs does not change what it computes.

use std::path::{Path, PathBuf};

use super::{io, link_tree, sensitivity, Options, ReproduceError};
use crate::output::shard::Shard;

/// The record a finished shard leaves in its directory.
pub const RECORD: &str = "shard.json";

/// The record a finished sweep part leaves in its directory (kept here, where a merge
/// looks for both kinds of record; `sweep_parts::RECORD` names it too).
pub const SWEEP_PART_RECORD: &str = "sweep-part.json";

/// What every part of one reproduction shares.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShardPlan {
    pub preset: String,
    pub replicates: u32,
    /// The parameters asked for with `--sensitivity-parameters` (empty: all); `None`
    /// without `--sensitivity`.
    pub sensitivity: Option<Vec<String>>,
    /// The variants' directory names, in plan order.
    pub variants: Vec<String>,
    pub tmo_version: String,
    pub git_revision: String,
    /// SHA-256 of the user's model that stands in for the hand's global model
    /// (`--hand-model`), if any: shards of one reproduction judge the same model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hand_model: Option<String>,
}

impl ShardPlan {
    pub fn new(options: &Options, variants: &[sensitivity::Variant]) -> Self {
        let (tmo_version, git_revision) = crate::trial::TrialMeta::code_version();
        Self {
            preset: options.preset.name().into(),
            replicates: options.replicates.max(1),
            sensitivity: options.sensitivity.clone(),
            variants: variants.iter().map(|v| v.dir_name()).collect(),
            tmo_version,
            git_revision,
            hand_model: options.hand_model.as_ref().map(|m| m.sha256.clone()),
        }
    }

    /// What part of the plan differs from `other`'s, if any.
    pub fn differs(&self, other: &ShardPlan) -> Option<&'static str> {
        if self.tmo_version != other.tmo_version || self.git_revision != other.git_revision {
            Some("the builds of tmo")
        } else if self.preset != other.preset || self.replicates != other.replicates {
            Some("the preset or the replicates")
        } else if self.hand_model != other.hand_model {
            Some("the hand's models (--hand-model)")
        } else if self != other {
            Some("the sensitivity studies")
        } else {
            None
        }
    }

    /// Every job of the plan, as directories under the output directory, in plan order.
    pub fn jobs(&self) -> Vec<String> {
        let runs = std::iter::once(String::new())
            .chain(self.variants.iter().map(|v| format!("sensitivity/{v}/")));
        runs.flat_map(|run| (1..=self.replicates).map(move |r| format!("{run}replicate-{r:02}")))
            .collect()
    }
}

/// A job's directory under the output directory: `replicate-01` for the baseline's first
/// replicate, `sensitivity/<variant>/replicate-01` for a variant's.
pub fn job_dir(variant: Option<&str>, replicate: u32) -> String {
    match variant {
        None => format!("replicate-{replicate:02}"),
        Some(v) => format!("sensitivity/{v}/replicate-{replicate:02}"),
    }
}

/// One job a shard ran.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShardJob {
    /// Its directory under the shard's (and the merged) output directory.
    pub dir: String,
    /// Why its variant could not be run to the end, if it could not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// `shard.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShardRecord {
    /// "K/N".
    pub shard: String,
    pub plan: ShardPlan,
    pub jobs: Vec<ShardJob>,
    pub wall_s: f64,
    /// How many `--sweep-only` parts its rail sweeps were joined from (`--sweep-from`);
    /// `None` where it swept them itself. The joined sweeps are the ones it would have run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep_parts: Option<usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("no shard directories given")]
    NoShards,
    #[error("{dir}: no finished shard here (no {RECORD}): run `tmo reproduce --shard K/N --out {dir}`, or finish it with --resume")]
    NotAShard { dir: PathBuf },
    #[error("{dir} is a part of a sweep stage (`tmo reproduce --sweep-only`): give it to `tmo reproduce --sweep-from`, and merge the shards that ran with it")]
    SweepPartGiven { dir: PathBuf },
    #[error("{dir}: no finished sweep part here (no {file}): run `tmo reproduce --sweep-only --shard K/N --out {dir}`, or finish it with --resume", file = SWEEP_PART_RECORD)]
    NotASweepPart { dir: PathBuf },
    #[error("{path}: not a shard record ({message})")]
    BadRecord { path: PathBuf, message: String },
    #[error("{a} and {b} are both shard {shard}")]
    Doubled {
        a: PathBuf,
        b: PathBuf,
        shard: String,
    },
    #[error("{dir} is shard {shard}, another shard is of {count}")]
    OtherCount {
        dir: PathBuf,
        shard: String,
        count: usize,
    },
    #[error("{dir} is a shard of another reproduction than {first} ({what} differ)")]
    Mixed {
        dir: PathBuf,
        first: PathBuf,
        what: &'static str,
    },
    #[error("shard(s) {0} not given")]
    Missing(String),
    #[error("{dir}: shard {shard} should hold {expected:?}, its record lists {found:?}")]
    WrongJobs {
        dir: PathBuf,
        shard: String,
        expected: Vec<String>,
        found: Vec<String>,
    },
    #[error("{0}: {1}")]
    Plan(String, String),
    #[error("{0}: finish or remake that shard with `tmo reproduce --shard K/N --out SHARD --resume` (the merge itself has no --resume)")]
    Job(String),
}

/// The variant (`None`: the baseline) and replicate a job's directory names.
fn job_of<'a>(
    dir: &str,
    variants: &'a [sensitivity::Variant],
) -> Option<(Option<&'a sensitivity::Variant>, u32)> {
    let (run, replicate) = dir.rsplit_once('/').unwrap_or(("", dir));
    let r: u32 = replicate.strip_prefix("replicate-")?.parse().ok()?;
    match run.strip_prefix("sensitivity/") {
        None if run.is_empty() => Some((None, r)),
        None => None,
        Some(name) => variants
            .iter()
            .find(|v| v.dir_name() == name)
            .map(|v| (Some(v), r)),
    }
}

/// A record each finished part of a plan leaves in its directory.
pub(crate) trait PartRecord: serde::de::DeserializeOwned {
    /// Its file name.
    const FILE: &'static str;
    /// "K/N".
    fn shard(&self) -> &str;
    fn plan(&self) -> &ShardPlan;
    /// The error for a directory that holds no such record.
    fn missing(dir: &Path) -> MergeError;
}

impl PartRecord for ShardRecord {
    const FILE: &'static str = RECORD;
    fn shard(&self) -> &str {
        &self.shard
    }
    fn plan(&self) -> &ShardPlan {
        &self.plan
    }
    fn missing(dir: &Path) -> MergeError {
        if dir.join(SWEEP_PART_RECORD).exists() {
            return MergeError::SweepPartGiven {
                dir: dir.to_path_buf(),
            };
        }
        MergeError::NotAShard {
            dir: dir.to_path_buf(),
        }
    }
}

fn read<R: PartRecord>(dir: &Path) -> Result<R, MergeError> {
    let path = dir.join(R::FILE);
    let text = std::fs::read_to_string(&path).map_err(|_| R::missing(dir))?;
    serde_json::from_str(&text).map_err(|e| MergeError::BadRecord {
        path,
        message: e.to_string(),
    })
}

/// What `merge` did.
#[derive(Debug)]
pub struct Merged {
    pub shards: usize,
    pub jobs: usize,
    /// The longest shard's own time: the reproduction's wall time when the shards ran side
    /// by side.
    pub longest_shard_s: f64,
    pub report: super::page::Written,
}

/// Joins the finished shards in `dirs` into `out` (which must hold no reproduction yet)
/// and writes the findings report there.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Merged, ReproduceError> {
    // The output apart from every input (else the merge links into what it reads, a tree
    // without end), and this merge its only writer before anything of it is looked at: two
    // merges into one --out (a requeued cluster job) must not both find it empty.
    crate::output::target::check_dir(out).map_err(|e| ReproduceError::step("merge", e))?;
    crate::output::target::check_apart(out, dirs).map_err(|e| ReproduceError::step("merge", e))?;
    let _lock = crate::output::lock::OutputLock::acquire(out)
        .map_err(|e| ReproduceError::step("merge", e))?;
    let parts = check_parts(dirs)?;
    let plan = parts[0].1.plan.clone();
    let preset = match super::Preset::from_name(&plan.preset) {
        Some(preset) => preset,
        None => {
            return Err(MergeError::Plan(
                "preset".into(),
                format!("unknown preset `{}`", plan.preset),
            )
            .into())
        }
    };
    let variants = match &plan.sensitivity {
        None => Vec::new(),
        Some(only) => sensitivity::study(&tmo_sim::parameters::built_in(), only)
            .map_err(|e| MergeError::Plan("sensitivity".into(), e))?,
    };
    if variants.iter().map(|v| v.dir_name()).collect::<Vec<_>>() != plan.variants {
        return Err(MergeError::Plan(
            "sensitivity".into(),
            "this build of tmo varies other parameters than the shards did: merge with the build that ran them".into(),
        )
        .into());
    }
    // The shards were made by this build: their records are checked as it states inputs.
    let (version, revision) = crate::trial::TrialMeta::code_version();
    if plan.tmo_version != version || plan.git_revision != revision {
        return Err(MergeError::Plan(
            "build".into(),
            format!(
                "the shards were run by tmo {} ({}), this is {version} ({revision}): merge with the build that ran them",
                plan.tmo_version, plan.git_revision
            ),
        )
        .into());
    }
    // Every job finished, each step made for its own job (its replicate's seeds, the
    // plan's preset, its variant's parameters, this build), its files as recorded: the
    // check --findings-only and --resume make (super::check).
    for (dir, record) in &parts {
        for job in record.jobs.iter().filter(|j| j.failed.is_none()) {
            let (variant, r) = job_of(&job.dir, &variants).ok_or_else(|| {
                MergeError::Plan(
                    "jobs".into(),
                    format!("`{}` is no job of the plan", job.dir),
                )
            })?;
            let of = match variant {
                Some(v) => super::check::Job::of(v, plan.replicates),
                None => super::check::Job::baseline(),
            };
            let problems = super::check::check_replicate(
                &dir.join(&job.dir),
                r,
                &of,
                &preset,
                plan.replicates,
                &super::Backend::Sim,
            )?;
            if let Some(p) = problems.first() {
                return Err(MergeError::Job(p.to_string()).into());
            }
        }
    }
    let taken = std::fs::read_dir(out).is_ok_and(|mut e| e.next().is_some());
    if taken {
        return Err(ReproduceError::AlreadyThere(out.to_path_buf()));
    }
    std::fs::create_dir_all(out).map_err(io(out))?;
    for (dir, record) in &parts {
        for job in &record.jobs {
            let from = dir.join(&job.dir);
            let to = out.join(&job.dir);
            if let Some(why) = &job.failed {
                // a failed job's files are not checked, so none is merged: its marker only
                let run = to.parent().expect("a job sits in its run's directory");
                std::fs::create_dir_all(run).map_err(io(run))?;
                let path = run.join(sensitivity::FAILED);
                crate::output::atomic::write_atomic(&path, why.as_bytes()).map_err(io(&path))?;
            } else if from.is_dir() {
                link_tree(&from, &to)?;
            }
        }
    }
    let study = (!variants.is_empty()).then_some(variants.as_slice());
    let report = super::page::write_findings(out, &preset, plan.replicates, study)?;
    Ok(Merged {
        shards: parts.len(),
        jobs: parts.iter().map(|(_, r)| r.jobs.len()).sum(),
        longest_shard_s: parts.iter().map(|(_, r)| r.wall_s).fold(0.0, f64::max),
        report,
    })
}

/// The shards' records, in shard order, once they are checked to be every part of one
/// plan exactly once.
fn check_parts(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, ShardRecord)>, MergeError> {
    let parts = check_records::<ShardRecord>(dirs)?;
    let all = parts[0].2.plan.jobs();
    for (dir, shard, record) in &parts {
        let expected = shard.select(all.clone());
        let found: Vec<String> = record.jobs.iter().map(|j| j.dir.clone()).collect();
        if expected != found {
            return Err(MergeError::WrongJobs {
                dir: dir.clone(),
                shard: record.shard.clone(),
                expected,
                found,
            });
        }
    }
    Ok(parts.into_iter().map(|(d, _, r)| (d, r)).collect())
}

/// The records in `dirs`, in part order, once they are checked to be the parts of one
/// plan, each exactly once and none missing.
pub(crate) fn check_records<R: PartRecord>(
    dirs: &[PathBuf],
) -> Result<Vec<(PathBuf, Shard, R)>, MergeError> {
    let mut parts: Vec<(PathBuf, Shard, R)> = Vec::new();
    for dir in dirs {
        let record: R = read(dir)?;
        let shard: Shard =
            record
                .shard()
                .parse()
                .map_err(
                    |e: crate::output::shard::ShardError| MergeError::BadRecord {
                        path: dir.join(R::FILE),
                        message: e.to_string(),
                    },
                )?;
        if let Some((other, _, _)) = parts.iter().find(|(_, s, _)| s.index == shard.index) {
            return Err(MergeError::Doubled {
                a: dir.clone(),
                b: other.clone(),
                shard: record.shard().into(),
            });
        }
        if let Some((first, s, first_record)) = parts.first() {
            if s.count != shard.count {
                return Err(MergeError::OtherCount {
                    dir: dir.clone(),
                    shard: record.shard().into(),
                    count: s.count,
                });
            }
            if let Some(what) = first_record.plan().differs(record.plan()) {
                return Err(MergeError::Mixed {
                    dir: dir.clone(),
                    first: first.clone(),
                    what,
                });
            }
        }
        parts.push((dir.clone(), shard, record));
    }
    let count = parts.first().ok_or(MergeError::NoShards)?.1.count;
    let missing: Vec<String> = (1..=count)
        .filter(|k| !parts.iter().any(|(_, s, _)| s.index == *k))
        .map(|k| format!("{k}/{count}"))
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::Missing(crate::quote::list(
            &missing,
            crate::quote::LISTED,
        )));
    }
    parts.sort_by_key(|(_, s, _)| s.index);
    Ok(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(shard: &str, plan: &ShardPlan) -> ShardRecord {
        let s: Shard = shard.parse().unwrap();
        ShardRecord {
            shard: shard.into(),
            plan: plan.clone(),
            jobs: s
                .select(plan.jobs())
                .into_iter()
                .map(|dir| ShardJob { dir, failed: None })
                .collect(),
            wall_s: 1.0,
            sweep_parts: None,
        }
    }

    fn plan() -> ShardPlan {
        ShardPlan {
            preset: "quick".into(),
            replicates: 2,
            sensitivity: Some(vec!["rail.rail_mu".into()]),
            variants: vec![
                "reseeded".into(),
                "rail.rail_mu@low".into(),
                "rail.rail_mu@high".into(),
            ],
            tmo_version: "0".into(),
            git_revision: "abc".into(),
            hand_model: None,
        }
    }

    fn write(root: &Path, name: &str, r: &ShardRecord) -> PathBuf {
        let d = root.join(name);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join(RECORD), serde_json::to_string(r).unwrap()).unwrap();
        d
    }

    #[test]
    fn the_plan_lists_the_baseline_then_each_variant_replicate_by_replicate() {
        assert_eq!(
            plan().jobs(),
            [
                "replicate-01",
                "replicate-02",
                "sensitivity/reseeded/replicate-01",
                "sensitivity/reseeded/replicate-02",
                "sensitivity/rail.rail_mu@low/replicate-01",
                "sensitivity/rail.rail_mu@low/replicate-02",
                "sensitivity/rail.rail_mu@high/replicate-01",
                "sensitivity/rail.rail_mu@high/replicate-02",
            ]
        );
    }

    #[test]
    fn parts_are_refused_when_missing_doubled_mixed_or_of_another_count() {
        let root = tempfile::tempdir().unwrap();
        let p = plan();
        let one = write(root.path(), "a", &record("1/3", &p));
        let two = write(root.path(), "b", &record("2/3", &p));
        let three = write(root.path(), "c", &record("3/3", &p));
        let parts = check_parts(&[three.clone(), one.clone(), two.clone()]).unwrap();
        let order: Vec<&str> = parts.iter().map(|(_, r)| r.shard.as_str()).collect();
        assert_eq!(order, ["1/3", "2/3", "3/3"]);

        let e = check_parts(&[one.clone(), two.clone()]).unwrap_err();
        assert!(matches!(&e, MergeError::Missing(m) if m == "3/3"), "{e}");
        let e = check_parts(&[one.clone(), one.clone(), three.clone()]).unwrap_err();
        assert!(matches!(e, MergeError::Doubled { .. }), "{e}");
        let other = write(root.path(), "d", &record("2/4", &p));
        let e = check_parts(&[one.clone(), other]).unwrap_err();
        assert!(matches!(e, MergeError::OtherCount { .. }), "{e}");
        let mut q = p.clone();
        q.git_revision = "def".into();
        let mixed = write(root.path(), "e", &record("2/3", &q));
        let e = check_parts(&[one.clone(), mixed, three.clone()]).unwrap_err();
        assert!(
            matches!(e, MergeError::Mixed { what, .. } if what.contains("builds")),
            "{e}"
        );
        let mut q = p.clone();
        q.replicates = 3;
        let mixed = write(root.path(), "f", &record("2/3", &q));
        let e = check_parts(&[one.clone(), mixed, three.clone()]).unwrap_err();
        assert!(matches!(e, MergeError::Mixed { .. }), "{e}");
        // shards that judged different models of the user's
        let mut q = p.clone();
        q.hand_model = Some("0f".repeat(32));
        let mixed = write(root.path(), "f2", &record("2/3", &q));
        let e = check_parts(&[one.clone(), mixed, three.clone()]).unwrap_err();
        assert!(
            matches!(e, MergeError::Mixed { what, .. } if what.contains("--hand-model")),
            "{e}"
        );
        // a record listing another part's jobs
        let mut wrong = record("2/3", &p);
        wrong.jobs.pop();
        let wrong = write(root.path(), "g", &wrong);
        let e = check_parts(&[one, wrong, three]).unwrap_err();
        assert!(matches!(e, MergeError::WrongJobs { .. }), "{e}");
        let e = check_parts(&[root.path().join("nowhere")]).unwrap_err();
        assert!(matches!(e, MergeError::NotAShard { .. }), "{e}");
        assert!(matches!(check_parts(&[]), Err(MergeError::NoShards)));
    }
}
