//! What `tmo report` reads: batch directories (`batch.json` + `outcomes.json`, as `tmo run`
//! writes them), sweep results (`sweep.csv`, or a directory holding one), evaluation
//! files (`tmo evaluate --out`), directories of collected trials (for the offline figures)
//! and model files (a threshold model's threshold is drawn on the speed histogram).

use std::path::{Path, PathBuf};

use crate::protocol::{Kind, Mode};
use crate::runner::batch::Manifest;
use crate::runner::score::{CalibrationRow, LiftRow, OutcomeRow};
use crate::slip::evaluation::{Evaluation, EVALUATION_FORMAT};
use crate::slip::model::{ModelFile, MODEL_FORMAT};
use crate::slip::sweep::SweepRow;

pub use super::checks::InputError;
pub use crate::runner::batch::rows::BatchRows;

#[derive(Debug, Clone, PartialEq)]
pub struct Batch {
    pub dir: PathBuf,
    pub manifest: Manifest,
    pub rows: BatchRows,
    /// Each online trial's loop timing (`timing.csv`; empty for batches without one).
    pub timing: Vec<crate::runner::loop_timing::TimingRow>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub path: PathBuf,
    pub rows: Vec<SweepRow>,
}

#[derive(Debug, Default, Clone, PartialEq)]
pub struct Inputs {
    pub batches: Vec<Batch>,
    pub sweeps: Vec<Sweep>,
    pub evaluations: Vec<(PathBuf, Evaluation)>,
    /// Directories of collected trials (their logs are read only for figures).
    pub trial_dirs: Vec<PathBuf>,
    pub models: Vec<(PathBuf, ModelFile)>,
}

impl Inputs {
    /// Every batch of `kind` in `mode`, in the order given.
    pub fn batches_of(&self, kind: Kind, mode: Mode) -> impl Iterator<Item = &Batch> {
        self.batches
            .iter()
            .filter(move |b| b.manifest.kind == kind && b.manifest.mode == mode)
    }

    /// The catch rows of every online batch of `kind`.
    pub fn catch_rows(&self, kind: Kind) -> Vec<&OutcomeRow> {
        self.batches_of(kind, Mode::Online)
            .flat_map(|b| match &b.rows {
                BatchRows::Catch(r) => r.iter().collect(),
                _ => Vec::new(),
            })
            .collect()
    }

    pub fn lift_rows(&self) -> Vec<&LiftRow> {
        self.batches
            .iter()
            .flat_map(|b| match &b.rows {
                BatchRows::Lift(r) => r.iter().collect(),
                _ => Vec::new(),
            })
            .collect()
    }

    pub fn calibration_rows(&self) -> Vec<&CalibrationRow> {
        self.batches
            .iter()
            .flat_map(|b| match &b.rows {
                BatchRows::Calibration(r) => r.iter().collect(),
                _ => Vec::new(),
            })
            .collect()
    }
}

fn read(path: &Path) -> Result<String, InputError> {
    std::fs::read_to_string(path).map_err(|e| InputError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

fn json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, InputError> {
    serde_json::from_str(&read(path)?).map_err(|e| InputError::Format {
        path: path.to_path_buf(),
        message: format!("line {}, column {}: {e}", e.line(), e.column()),
    })
}

fn load_batch(dir: &Path) -> Result<Batch, InputError> {
    let manifest: Manifest = json(&dir.join("batch.json"))?;
    let outcomes = dir.join("outcomes.json");
    if !outcomes.is_file() {
        return Err(InputError::Format {
            path: dir.to_path_buf(),
            message: "no outcomes.json: the batch has not finished (run `tmo run --resume`)".into(),
        });
    }
    kind_as_its_protocol_says(dir, &manifest)?;
    let trials = |ids: Vec<&str>| {
        super::checks::rows_are_the_trials(&outcomes, &manifest.trials, ids.into_iter())
    };
    let rows = match manifest.kind {
        Kind::FirstTimeLift => {
            let rows: Vec<LiftRow> = json(&outcomes)?;
            trials(rows.iter().map(|r| r.trial_id.as_str()).collect())?;
            super::checks::lifts(&outcomes, &rows)?;
            BatchRows::Lift(rows)
        }
        Kind::CalibrateLift => {
            let rows: Vec<CalibrationRow> = json(&outcomes)?;
            trials(rows.iter().map(|r| r.trial_id.as_str()).collect())?;
            super::checks::calibrations(&outcomes, &rows)?;
            BatchRows::Calibration(rows)
        }
        kind => {
            let rows: Vec<OutcomeRow> = json(&outcomes)?;
            trials(rows.iter().map(|r| r.trial_id.as_str()).collect())?;
            super::checks::catches(&outcomes, kind, &rows)?;
            BatchRows::Catch(rows)
        }
    };
    let timing_path = dir.join(crate::runner::loop_timing::TIMING_CSV);
    let timing = crate::runner::loop_timing::read_csv(&timing_path).map_err(|message| {
        InputError::Format {
            path: timing_path,
            message,
        }
    })?;
    Ok(Batch {
        dir: dir.to_path_buf(),
        manifest,
        rows,
        timing,
    })
}

/// A batch's kind and mode against the protocol it ran, where that protocol can still be
/// read (the batch directory's `protocol.toml`, or the file `batch.json` names) with the
/// SHA-256 `batch.json` records: an edited kind would tabulate one experiment's rows as
/// another's.
fn kind_as_its_protocol_says(dir: &Path, manifest: &Manifest) -> Result<(), InputError> {
    let copy = dir.join("protocol.toml");
    let path = if copy.is_file() {
        copy
    } else {
        PathBuf::from(&manifest.protocol)
    };
    if !path.is_file() {
        return Ok(());
    }
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(());
    };
    if crate::trial::sha256_hex(text.as_bytes()) != manifest.protocol_sha256 {
        return Ok(());
    }
    let Ok(protocol) = crate::protocol::ProtocolFile::parse(&path, &text) else {
        return Ok(());
    };
    if (protocol.kind, protocol.mode) != (manifest.kind, manifest.mode) {
        return Err(InputError::Format {
            path: dir.join("batch.json"),
            message: format!(
                "kind {} ({:?}), but the protocol it ran ({}) is {} ({:?})",
                manifest.kind,
                manifest.mode,
                path.display(),
                protocol.kind,
                protocol.mode
            ),
        });
    }
    Ok(())
}

fn load_sweep(path: &Path) -> Result<Sweep, InputError> {
    let text = read(path)?;
    let rows = csv::Reader::from_reader(text.as_bytes())
        .deserialize()
        .enumerate()
        .map(|(i, r)| {
            r.map_err(|e| InputError::Format {
                path: path.to_path_buf(),
                message: format!("row {}: expected a `tmo sweep` row: {e}", i + 1),
            })
        })
        .collect::<Result<Vec<SweepRow>, _>>()?;
    super::checks::sweep(path, &rows)?;
    Ok(Sweep {
        path: path.to_path_buf(),
        rows,
    })
}

fn has_trial_logs(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .flatten()
            .any(|e| e.path().extension().is_some_and(|x| x == "mcap"))
    })
}

/// Reads every input; the first that cannot be read is the error.
pub fn load(paths: &[PathBuf]) -> Result<Inputs, InputError> {
    let mut inputs = Inputs::default();
    for p in paths {
        if p.is_dir() {
            if p.join("batch.json").is_file() {
                let batch = load_batch(p)?;
                // A collect batch's logs are training data: the offline figures read them.
                if batch.manifest.mode == Mode::Collect && has_trial_logs(p) {
                    inputs.trial_dirs.push(p.clone());
                }
                inputs.batches.push(batch);
            } else if p.join("sweep.csv").is_file() {
                inputs.sweeps.push(load_sweep(&p.join("sweep.csv"))?);
            } else if has_trial_logs(p) {
                inputs.trial_dirs.push(p.clone());
            } else {
                return Err(InputError::Unknown(p.clone()));
            }
        } else if p.extension().is_some_and(|e| e == "csv") {
            inputs.sweeps.push(load_sweep(p)?);
        } else if p.extension().is_some_and(|e| e == "json") {
            let value: serde_json::Value = json(p)?;
            match value.get("format").and_then(|f| f.as_str()) {
                Some(EVALUATION_FORMAT) => {
                    let e: Evaluation = json(p)?;
                    super::checks::evaluation(p, &e)?;
                    inputs.evaluations.push((p.clone(), e));
                }
                Some(MODEL_FORMAT) => {
                    let model = ModelFile::load(p).map_err(|e| InputError::Format {
                        path: p.clone(),
                        message: e.to_string(),
                    })?;
                    inputs.models.push((p.clone(), model));
                }
                _ => return Err(InputError::Unknown(p.clone())),
            }
        } else if !p.exists() {
            return Err(InputError::Read {
                path: p.clone(),
                message: "no such file or directory".into(),
            });
        } else {
            return Err(InputError::Unknown(p.clone()));
        }
    }
    inputs.batches = join_shards(std::mem::take(&mut inputs.batches))?;
    refuse_repeated_batches(&inputs.batches)?;
    Ok(inputs)
}

/// Refuses a batch given twice: the same directory twice, a copy of it, or a batch beside
/// its own `--shard` parts. Batches of one protocol and seed are the same trials, so any
/// trial id they share would be counted twice.
fn refuse_repeated_batches(batches: &[Batch]) -> Result<(), InputError> {
    for (j, b) in batches.iter().enumerate() {
        for a in &batches[..j] {
            let (m, n) = (&a.manifest, &b.manifest);
            if (&m.protocol_sha256, m.seed, m.kind, m.mode)
                != (&n.protocol_sha256, n.seed, n.kind, n.mode)
            {
                continue;
            }
            if let Some(t) = n.trials.iter().find(|t| m.trials.contains(t)) {
                return Err(InputError::Format {
                    path: b.dir.clone(),
                    message: format!(
                        "trial `{t}` of the same batch (protocol, seed) as {} is given again: a batch counts once (give it, or all of its --shard parts, once)",
                        a.dir.display()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Joins the parts of batches split with `tmo run --shard K/N` into one batch each (rows in
/// trial order, as one run writes them), in the place of the first part given. Every part
/// must be there once, and the parts must be of one batch: same protocol, kind, mode, seed,
/// repetitions and backend.
fn join_shards(batches: Vec<Batch>) -> Result<Vec<Batch>, InputError> {
    let mut out: Vec<Batch> = Vec::new();
    // for each batch in `out` that joins parts: their count and the parts (index, dir) seen
    type Parts = (usize, Vec<(usize, PathBuf)>);
    let mut parts: Vec<Option<Parts>> = Vec::new();
    for b in batches {
        let Some(text) = b.manifest.shard.clone() else {
            out.push(b);
            parts.push(None);
            continue;
        };
        let shard: crate::output::shard::Shard = text.parse().map_err(|e| InputError::Format {
            path: b.dir.join("batch.json"),
            message: format!("shard: {e}"),
        })?;
        let same = |a: &Manifest, c: &Manifest| {
            (
                &a.protocol_sha256,
                a.kind,
                a.mode,
                a.seed,
                a.repetitions,
                &a.backend,
            ) == (
                &c.protocol_sha256,
                c.kind,
                c.mode,
                c.seed,
                c.repetitions,
                &c.backend,
            )
        };
        let found = out.iter().zip(&parts).position(|(o, p)| {
            p.as_ref().is_some_and(|(n, _)| *n == shard.count) && same(&o.manifest, &b.manifest)
        });
        let Some(i) = found else {
            parts.push(Some((shard.count, vec![(shard.index, b.dir.clone())])));
            let mut first = b;
            first.manifest.shard = None;
            out.push(first);
            continue;
        };
        let (_, seen) = parts[i].as_mut().expect("a joined batch");
        if let Some((_, other)) = seen.iter().find(|(k, _)| *k == shard.index) {
            return Err(InputError::Format {
                path: b.dir.clone(),
                message: format!("shard {shard} again (also {})", other.display()),
            });
        }
        seen.push((shard.index, b.dir.clone()));
        let joined = &mut out[i];
        joined.manifest.trials.extend(b.manifest.trials);
        joined.manifest.trials.sort();
        match (&mut joined.rows, b.rows) {
            (BatchRows::Catch(a), BatchRows::Catch(r)) => {
                a.extend(r);
                a.sort_by(|x, y| x.trial_id.cmp(&y.trial_id));
            }
            (BatchRows::Lift(a), BatchRows::Lift(r)) => {
                a.extend(r);
                a.sort_by(|x, y| x.trial_id.cmp(&y.trial_id));
            }
            (BatchRows::Calibration(a), BatchRows::Calibration(r)) => {
                a.extend(r);
                a.sort_by(|x, y| x.trial_id.cmp(&y.trial_id));
            }
            _ => unreachable!("parts of one kind hold rows of one kind"),
        }
        joined.timing.extend(b.timing);
        joined.timing.sort_by(|x, y| x.trial_id.cmp(&y.trial_id));
    }
    for (b, p) in out.iter().zip(&parts) {
        if let Some((count, seen)) = p {
            let missing: Vec<String> = (1..=*count)
                .filter(|k| !seen.iter().any(|(s, _)| s == k))
                .map(|k| format!("{k}/{count}"))
                .collect();
            if !missing.is_empty() {
                return Err(InputError::Format {
                    path: b.dir.clone(),
                    message: format!(
                        "a part of a batch split with --shard; shard(s) {} not given",
                        crate::quote::list(&missing, crate::quote::LISTED)
                    ),
                });
            }
        }
    }
    Ok(out)
}
