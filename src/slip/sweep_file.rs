//! A sweep's results file. Finished cells are appended to `<out>.partial` as they complete,
//! so an interrupted sweep loses at most the cells in flight and a resumed one runs only the
//! rest; the CSV is sorted and written under its name only when every cell is done.
//! `<out>.identity` records what the cells were computed from (settings and training and
//! test trials, as the caller describes them): a resume with anything else is refused, so
//! cells of two different sweeps never share a file.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Mutex;

use super::dataset::Dataset;
use super::sweep::{run_chains_until, sort_rows, Cell, Shard, SweepError, SweepRow, SweepSpec};

#[derive(Debug, thiserror::Error)]
pub enum SweepFileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Csv { path: PathBuf, message: String },
    #[error(transparent)]
    Lock(#[from] crate::output::lock::LockError),
    #[error(transparent)]
    Target(#[from] crate::output::target::TargetError),
    #[error("{0} holds cells of an interrupted sweep: pass --resume to finish it, or delete it")]
    PartialThere(PathBuf),
    #[error("{path} holds cells of a different sweep: it was made with `{was}`, this one asks `{now}`; choose another --out, or delete it")]
    Different {
        path: PathBuf,
        was: String,
        now: String,
    },
    #[error("{path}: cell {cell} is also in {other}: the shards overlap")]
    ShardOverlap {
        path: PathBuf,
        other: PathBuf,
        cell: String,
    },
    #[error("the shards hold {got} of the grid's {expected} cells; missing: {missing}")]
    ShardsIncomplete {
        got: usize,
        expected: usize,
        missing: String,
    },
    #[error("{path}: cell {cell} is not in the grid the shards were run with")]
    ShardForeignCell { path: PathBuf, cell: String },
    #[error("sweep stopped; finished cells are in {partial} (run again with --resume): {source}")]
    Sweep {
        partial: PathBuf,
        source: SweepError,
    },
}

impl SweepFileError {
    /// Did the sweep stop because it was asked to (not because a cell failed)?
    pub fn stopped(&self) -> bool {
        matches!(
            self,
            SweepFileError::Sweep {
                source: SweepError::Stopped,
                ..
            }
        )
    }
}

/// Where the finished cells of a sweep writing `out` are kept until it is done.
pub fn partial_path(out: &Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

fn csv_error(path: &Path) -> impl Fn(csv::Error) -> SweepFileError + '_ {
    move |e| SweepFileError::Csv {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// The rows of a sweep CSV.
pub fn read_rows(path: &Path) -> Result<Vec<SweepRow>, SweepFileError> {
    let mut reader = csv::Reader::from_path(path).map_err(csv_error(path))?;
    reader
        .deserialize()
        .enumerate()
        .map(|(i, r)| {
            r.map_err(|e| SweepFileError::Csv {
                path: path.to_path_buf(),
                message: format!("row {}: {e}", i + 2),
            })
        })
        .collect()
}

/// Cuts a torn last line (a cell whose write was cut short, e.g. by a full disk or a kill)
/// off a partial file, so that its cell runs again instead of every `--resume` failing on
/// it. Complete lines are kept as they are; returns whether a line was cut.
fn drop_torn_last_line(path: &Path) -> Result<bool, SweepFileError> {
    let io = |source| SweepFileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bytes = std::fs::read(path).map_err(io)?;
    if bytes.is_empty() || bytes.ends_with(b"\n") {
        return Ok(false);
    }
    let keep = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(io)?;
    file.set_len(keep as u64).map_err(io)?;
    Ok(true)
}

/// Writes `rows` to `path` through a temporary file.
pub fn write_rows(path: &Path, rows: &[SweepRow]) -> Result<(), SweepFileError> {
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| SweepFileError::Io { path: p, source }
    };
    crate::output::target::check_file(path)?;
    let tmp = partial_path(&path.with_extension("writing"));
    {
        let file = crate::output::atomic::create_fresh(&tmp).map_err(io(&tmp))?;
        let mut w = csv::Writer::from_writer(file);
        for r in rows {
            w.serialize(r).map_err(csv_error(&tmp))?;
        }
        w.flush().map_err(|source| SweepFileError::Io {
            path: tmp.clone(),
            source,
        })?;
    }
    std::fs::rename(&tmp, path).map_err(|source| SweepFileError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Leaves `out` as [`run_to_file`] leaves a finished sweep of `identity` with `rows` (the
/// rows of a sweep run elsewhere and joined with [`merge`]).
pub fn write_finished(out: &Path, identity: &str, rows: &[SweepRow]) -> Result<(), SweepFileError> {
    let path = identity_path(out);
    crate::output::atomic::write_atomic(&path, identity.as_bytes())
        .map_err(|source| SweepFileError::Io { path, source })?;
    write_rows(out, rows)
}

/// A finished sweep: every row in grid order, and how many were there before.
pub struct SweepResult {
    pub rows: Vec<SweepRow>,
    pub already_done: usize,
    pub ran: usize,
    /// The partial file ended in a torn line (a write cut short), which was dropped: that
    /// cell ran again.
    pub cut_torn_line: bool,
}

/// Where a sweep's cells go, and how.
pub struct SweepTarget<'a> {
    pub out: &'a Path,
    /// Keep the cells already in `out` or its partial file (when their identity matches).
    pub resume: bool,
    /// What the cells are computed from besides their grid point, one `key value` a line.
    pub identity: String,
    /// Start no more cells once set.
    pub stop: Option<&'a AtomicBool>,
    /// Which of the grid's chains to run ([`merge`] joins the parts).
    pub part: SweepPart,
}

/// The part of a sweep's grid one process runs. Parts are whole chains of cells
/// ([`SweepSpec::chains`]), so that each cell starts as it does in a single run.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum SweepPart {
    #[default]
    Whole,
    /// Every `count`-th chain, as `--shard K/N` deals them.
    Shard(Shard),
    /// These chains, by their position in [`SweepSpec::chains`] (a plan that deals chains
    /// of several sweeps together, as `tmo reproduce --sweep-only` does).
    Chains(Vec<usize>),
}

impl SweepPart {
    /// This part's chains of `spec`'s grid.
    pub fn select(&self, spec: &SweepSpec) -> Vec<Vec<Cell>> {
        let chains = spec.chains();
        match self {
            SweepPart::Whole => chains,
            SweepPart::Shard(shard) => shard.select(chains),
            SweepPart::Chains(which) => chains
                .into_iter()
                .enumerate()
                .filter(|(i, _)| which.contains(i))
                .map(|(_, c)| c)
                .collect(),
        }
    }
}

fn identity_path(out: &Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".identity");
    PathBuf::from(name)
}

/// Refuses a resume of cells computed from something else; records the identity.
fn check_identity(target: &SweepTarget, has_cells: bool) -> Result<(), SweepFileError> {
    let path = identity_path(target.out);
    if has_cells {
        if let Ok(was) = std::fs::read_to_string(&path) {
            if was != target.identity {
                let (w, n) = was
                    .lines()
                    .zip(target.identity.lines())
                    .find(|(a, b)| a != b)
                    .unwrap_or((was.as_str(), target.identity.as_str()));
                return Err(SweepFileError::Different {
                    path: target.out.to_path_buf(),
                    was: w.to_string(),
                    now: n.to_string(),
                });
            }
        }
    }
    crate::output::atomic::write_atomic(&path, target.identity.as_bytes())
        .map_err(|source| SweepFileError::Io { path, source })
}

/// Runs the cells of `spec` not yet in the target (or its partial file, with `resume`),
/// keeping each as it finishes; `on_start` learns which cells will run and how many were
/// done, `on_done` sees each new row.
pub fn run_to_file(
    train: &Dataset,
    test: &Dataset,
    spec: &SweepSpec,
    target: &SweepTarget,
    on_start: impl FnOnce(&[Cell], usize),
    on_done: impl Fn(&SweepRow) + Sync,
) -> Result<SweepResult, SweepFileError> {
    let (out, resume, stop) = (target.out, target.resume, target.stop);
    let _lock = crate::output::lock::OutputLock::acquire(out)?;
    crate::output::target::check_file(out)?;
    crate::output::target::check_file(&partial_path(out))?;
    let partial = partial_path(out);
    let mut cut_torn_line = false;
    let done: Vec<SweepRow> = if resume {
        let mut rows = Vec::new();
        cut_torn_line = partial.exists() && drop_torn_last_line(&partial)?;
        for p in [out, partial.as_path()] {
            // a partial file cut back to nothing (or to its header) has no cells
            if p.exists() && std::fs::metadata(p).is_ok_and(|m| m.len() > 0) {
                rows.extend(read_rows(p)?);
            }
        }
        rows
    } else {
        if partial.exists() {
            return Err(SweepFileError::PartialThere(partial));
        }
        Vec::new()
    };
    let finished: HashMap<_, _> = done
        .iter()
        .map(|r| (r.key(), r.hyperparameters()))
        .collect();
    // A shard runs whole chains, so that its cells start as a single run starts them.
    let chains = target.part.select(spec);
    let cells: Vec<_> = chains
        .iter()
        .flatten()
        .filter(|c| !finished.contains_key(&c.key()))
        .copied()
        .collect();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| SweepFileError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    check_identity(target, !done.is_empty())?;
    on_start(&cells, finished.len());
    let append_header = std::fs::metadata(&partial).map_or(true, |m| m.len() == 0);
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&partial)
        .map_err(|source| SweepFileError::Io {
            path: partial.clone(),
            source,
        })?;
    let writer = Mutex::new(
        csv::WriterBuilder::new()
            .has_headers(append_header)
            .from_writer(file),
    );
    let write_error = Mutex::new(None);
    let result = run_chains_until(train, test, spec, &chains, &finished, stop, |row| {
        let mut w = writer.lock().expect("writer lock");
        if let Err(e) = w
            .serialize(row)
            .and_then(|_| w.flush().map_err(csv::Error::from))
        {
            write_error.lock().expect("lock").get_or_insert(e);
        }
        on_done(row);
    });
    drop(writer);
    if let Some(e) = write_error.into_inner().expect("lock") {
        return Err(csv_error(&partial)(e));
    }
    let new_rows = result.map_err(|source| SweepFileError::Sweep {
        partial: partial.clone(),
        source,
    })?;
    let ran = new_rows.len();
    let mut rows = done;
    rows.extend(new_rows);
    let order: Vec<String> = spec.classifiers.iter().map(|k| k.name().into()).collect();
    sort_rows(&mut rows, &order);
    rows.dedup_by(|a, b| a.key() == b.key());
    write_rows(out, &rows)?;
    let _ = std::fs::remove_file(&partial);
    Ok(SweepResult {
        cut_torn_line,
        already_done: finished.len(),
        ran,
        rows,
    })
}

/// Joins the rows of a sweep's shards (`parts`: each shard's CSV and rows) into the rows a
/// single run of `spec` writes: every cell of the grid exactly once, in the CSV's order.
pub fn merge(
    spec: &SweepSpec,
    parts: Vec<(PathBuf, Vec<SweepRow>)>,
) -> Result<Vec<SweepRow>, SweepFileError> {
    let grid: HashSet<_> = spec.cells().iter().map(|c| c.key()).collect();
    let mut seen: HashMap<_, PathBuf> = HashMap::new();
    let mut rows = Vec::new();
    let name = |k: &(String, usize, String)| format!("{} n_slip {} d {}", k.0, k.1, k.2);
    for (path, part) in parts {
        for row in part {
            let key = row.key();
            if !grid.contains(&key) {
                return Err(SweepFileError::ShardForeignCell {
                    path,
                    cell: name(&key),
                });
            }
            if let Some(other) = seen.get(&key) {
                return Err(SweepFileError::ShardOverlap {
                    path,
                    other: other.clone(),
                    cell: name(&key),
                });
            }
            seen.insert(key, path.clone());
            rows.push(row);
        }
    }
    if rows.len() < grid.len() {
        let mut missing: Vec<_> = spec
            .cells()
            .iter()
            .map(|c| c.key())
            .filter(|k| !seen.contains_key(k))
            .collect();
        missing.sort();
        let shown: Vec<String> = missing.iter().take(3).map(name).collect();
        return Err(SweepFileError::ShardsIncomplete {
            got: rows.len(),
            expected: grid.len(),
            missing: format!(
                "{}{}",
                shown.join(", "),
                if missing.len() > 3 { ", ..." } else { "" }
            ),
        });
    }
    let order: Vec<String> = spec.classifiers.iter().map(|k| k.name().into()).collect();
    sort_rows(&mut rows, &order);
    Ok(rows)
}
