//! The batch loop shared by `tmo run` and `tmo reproduce`: every planned trial that has no
//! log yet is run (the simulator builds a rig per trial; a real rig is opened once by the
//! caller and set up between trials), its log written under its name only when complete,
//! and every trial, run now or earlier, scored from its log.
//!
//! Simulated trials run several at once (one per core), real ones one at a time.
//!
//! Ctrl-C (the `stop` flag) ends the running trials safely; their logs are kept beside the
//! batch as aborted and the loop returns [`BatchEnd::Interrupted`], so a resumed batch runs
//! exactly the trials that are missing.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use super::batch::rows::{write_atomic, ScoredRows};
use super::batch::{
    aborted_trial_path, catch_spec, expand, faulted_trial_path, trial_path, BatchError, Manifest,
    PlannedTrial,
};
use crate::protocol::{Kind, KindParams, Plan};
use crate::runner::loop_timing::TimingRow;
use crate::runner::real_trial::{run_real_trial, RealRig};
use crate::runner::score::{self, CalibrationRow, GMinTable, LiftRow, OutcomeRow};
use crate::runner::sim_trial::run_sim_trial;
use crate::runner::staging::Staging;
use crate::slip::slip_model::SlipModel;
use crate::trial::{read_trial, read_trial_for_scoring, sha256_hex, write_trial, Trial};

/// Where and how a batch runs.
pub struct BatchRequest<'a> {
    pub plan: &'a Plan,
    pub out: &'a Path,
    /// Finish a batch whose directory already holds some of its trials.
    pub resume: bool,
    /// With `resume`: also run again the trials whose kept log ended on a fault (a device
    /// error or a safety abort), moving each such log aside as `<id>.faulted.mcap`. Without
    /// it a faulted trial is an outcome like any other and is kept.
    pub rerun_faulted: bool,
    /// Run only this part of the batch's trials (simulated batches spread over processes).
    pub shard: Option<crate::output::shard::Shard>,
    /// Serve each trial live as it runs; simulated trials then run one at a time, at
    /// wall-clock speed.
    pub live: Option<&'a crate::live::LiveView>,
    /// Told each finished trial as a line (`trial-0003: caught`), e.g. for a verbose log.
    pub on_trial: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Told each warning found before the first trial (a model trained at another frame
    /// rate than the rig's).
    pub on_warning: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Told what each model costs a frame, measured before the first trial.
    pub on_note: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Run a model too slow for the rig's frame rate (a warning instead of a refusal): its
    /// trials on a wall clock fault on their deadline.
    pub allow_slow_model: bool,
}

/// The rig a batch drives: the simulator (one world per trial) or an open real rig.
pub enum BatchRig {
    Sim,
    Real { staging: Staging, rig: Box<RealRig> },
}

/// A finished batch: its scored rows and the files written.
pub struct BatchSummary {
    pub manifest: Manifest,
    pub rows: ScoredRows,
    pub ran: usize,
    pub kept: usize,
    /// Of `ran`: faulted trials run again (`rerun_faulted`), their old logs moved aside.
    pub rerun_faulted: usize,
    pub wall_s: f64,
    /// `outcomes.csv`, `outcomes.json`, `g_min.json` for a calibration, `batch.json`.
    pub outputs: Vec<PathBuf>,
    /// A first-time lift without a calibration table: no overgrasp.
    pub without_calibration: bool,
}

pub enum BatchEnd {
    Finished(Box<BatchSummary>),
    /// Stopped by the `stop` flag, or by an operator's terminal that closed.
    Interrupted {
        finished: usize,
        /// The logs of the trials that were running, kept as aborted.
        aborted_logs: Vec<PathBuf>,
        before_trial: String,
        operator_gone: bool,
    },
}

/// A device fault's error, its trial's recording until then written beside the batch as
/// `<id>.faulted-<n>.mcap` (not counted as done: `--resume` runs the trial again).
fn keep_faulted(out: &Path, t: &PlannedTrial, e: BatchError) -> Result<BatchError, BatchError> {
    let BatchError::FaultInFlight { source, trial } = e else {
        return Ok(e);
    };
    let path = faulted_trial_path(out, t);
    write_trial(&path, &trial)?;
    Ok(BatchError::FaultKept { source, path })
}

fn in_trial(t: &PlannedTrial, e: BatchError) -> BatchError {
    BatchError::InTrial {
        trial_id: t.trial_id.clone(),
        source: Box::new(e),
    }
}

/// Loads each of the plan's models with its SHA-256 (recorded in every trial).
pub fn load_models(plan: &Plan) -> Result<Vec<(SlipModel, String)>, BatchError> {
    plan.models
        .iter()
        .enumerate()
        .map(|(index, path)| {
            let bytes = std::fs::read(path).map_err(|source| {
                if source.kind() == std::io::ErrorKind::NotFound {
                    BatchError::MissingModel(path.clone())
                } else {
                    BatchError::Io {
                        path: path.clone(),
                        source,
                    }
                }
            })?;
            let model = SlipModel::load(path)
                .map_err(|source| BatchError::ProtocolModel { index, source })?;
            Ok((model, sha256_hex(&bytes)))
        })
        .collect()
}

/// The fingertips a rig has and the pins each reports: the simulator's three (one on the
/// rail) of 30 pins, or what the hardware file names.
fn rig_sensors(plan: &Plan, rig: &BatchRig) -> (usize, usize) {
    match rig {
        BatchRig::Sim => {
            let sensors = if plan.kind == crate::protocol::Kind::RailCatch {
                1
            } else {
                3
            };
            (sensors, tmo_hal::TMO_PINS_PER_SENSOR)
        }
        BatchRig::Real { rig, .. } => (rig.hw.cameras.fingertips.len(), rig.hw.cameras.pins),
    }
}

/// The rig's cameras' frame rate, Hz: the simulator's (as the protocol's `[sim]` may set
/// it), or the hardware file's.
pub fn rig_frame_rate_hz(plan: &Plan, rig: &BatchRig) -> f64 {
    match rig {
        BatchRig::Sim => plan
            .sim
            .get("tactip.frame_rate_hz")
            .copied()
            .unwrap_or_else(|| tmo_sim::SimConfig::default().tactip.frame_rate_hz),
        BatchRig::Real { rig, .. } => rig.hw.cameras.frame_rate_hz,
    }
}

/// Times each model's frame on this machine and holds it to the rig's pace: each of the
/// rig's `sensors` fingertips gets an equal share of a frame period. Above the share a
/// model is refused (unless `allow_slow`: then warned of), above half of it warned of.
/// Returns a note of each model's cost and the warnings.
pub fn check_model_costs(
    plan: &Plan,
    models: &[(SlipModel, String)],
    (sensors, pins, rate_hz): (usize, usize, f64),
    allow_slow: bool,
) -> Result<(Vec<String>, Vec<String>), BatchError> {
    let budget_ms = 1e3 / rate_hz / sensors.max(1) as f64;
    let (mut notes, mut warnings) = (Vec::new(), Vec::new());
    for (path, (model, _)) in plan.models.iter().zip(models) {
        let cost = crate::online::classify::frame_cost(model, sensors, pins);
        notes.push(format!(
            "{}: {:.3} ms a frame (p50; p99 {:.3} ms, {} frames on this machine), {:.0} % of its {:.2} ms share of a frame at {rate_hz} fps",
            path.display(),
            cost.p50_ms,
            cost.p99_ms,
            cost.frames,
            100.0 * cost.p99_ms / budget_ms,
            budget_ms
        ));
        if cost.p99_ms > budget_ms {
            let slow = BatchError::SlowModel {
                path: path.clone(),
                p99_ms: cost.p99_ms,
                frames: cost.frames,
                budget_ms,
                rate_hz,
                sensors,
            };
            if !allow_slow {
                return Err(slow);
            }
            warnings.push(format!("--allow-slow-model: {slow}"));
        } else if cost.p99_ms > 0.5 * budget_ms {
            warnings.push(format!(
                "{}: classifying a frame takes {:.2} ms (p99), more than half of the {:.2} ms each fingertip has at {rate_hz} fps: a busy machine may make its trials late",
                path.display(),
                cost.p99_ms,
                budget_ms
            ));
        }
    }
    Ok((notes, warnings))
}

/// Warnings for models trained at a frame rate more than 15 % from the rig's (velocities
/// are per frame, so they read the rig's slips at another speed per frame), as `tmo
/// evaluate` and `tmo replay` warn for recorded trials.
pub fn model_rate_warnings(
    plan: &Plan,
    models: &[(SlipModel, String)],
    rate_hz: f64,
) -> Vec<String> {
    let rig = crate::slip::features::FeatureSpec {
        frame_rate_hz: Some(rate_hz as f32),
        ..crate::slip::features::FeatureSpec::new(tmo_hal::TMO_PINS_PER_SENSOR)
    };
    plan.models
        .iter()
        .zip(models)
        .filter_map(|(path, (model, _))| {
            let why = model.features().rate_differs(&rig)?;
            Some(format!(
                "{}: {} (the rig's cameras run at {rate_hz} fps)",
                path.display(),
                why.replace("the trials' frame rate", "the rig's frame rate"),
            ))
        })
        .collect()
}

/// Refuses, before the first trial, a model that could never classify this rig's frames.
pub fn check_models_fit_rig(
    plan: &Plan,
    models: &[(SlipModel, String)],
    (sensors, pins, rate_hz): (usize, usize, f64),
) -> Result<(), BatchError> {
    for (path, (model, _)) in plan.models.iter().zip(models) {
        // every fingertip of the rig (the simulator's and the real hand's TacTips) tracks
        // pins in image pixels: a model made for other units would read nonsense
        let units = model.features().units;
        if units != crate::slip::features::Units::Px {
            return Err(BatchError::ModelDoesNotFitRig {
                path: path.clone(),
                message: format!(
                    "the model reads features in {}, but this rig's fingertips report pins in px; export a model for this rig's frames",
                    units.name()
                ),
            });
        }
        // a window no trial can fill would never give a class: every trial a miss
        if let Some(duration_s) = plan.params.max_duration_s() {
            let frames = (duration_s * rate_hz).floor() as usize;
            model
                .fits_frames(frames)
                .map_err(|message| BatchError::ModelDoesNotFitRig {
                    path: path.clone(),
                    message: format!(
                        "{message}; this protocol's trials last at most {duration_s} s ({frames} frames at {rate_hz} fps)"
                    ),
                })?;
        }
        model
            .fits(sensors, pins)
            .map_err(|message| BatchError::ModelDoesNotFitRig {
                path: path.clone(),
                message: format!("{message} (this rig has {sensors} fingertips)"),
            })?;
    }
    Ok(())
}

/// Runs (or finishes) the batch `req` asks for and scores it; `bar` shows trial progress
/// (its length is set here; pass a hidden bar for none).
pub fn run_batch(
    req: &BatchRequest,
    rig: &mut BatchRig,
    stop: &AtomicBool,
    bar: &indicatif::ProgressBar,
) -> Result<BatchEnd, BatchError> {
    let prepared = prepare(req, rig)?;
    // One writer per batch directory, for as long as the batch runs.
    let _lock = crate::output::lock::OutputLock::acquire(req.out)?;
    let manifest = claim_directory(req, rig, &prepared.trials)?;
    bar.set_length(prepared.trials.len() as u64);
    let started = std::time::Instant::now();
    let mut tally = Tally::default();
    for chunk in prepared.trials.chunks(window(req, rig)) {
        tally.rerun += set_faulted_aside(req, chunk)?;
        if let Some(end) = run_missing(req, rig, &prepared, chunk, stop, bar, &mut tally)? {
            return Ok(end);
        }
        score_chunk(req, &prepared, chunk, bar, &mut tally)?;
    }
    write_results(req, &prepared, manifest, tally, started)
}

/// What a batch needs before its first trial: its trials, models and calibration.
struct Prepared {
    trials: Vec<PlannedTrial>,
    models: Vec<(SlipModel, String)>,
    g_min: Option<GMinTable>,
    spec: crate::outcome::CatchSpec,
}

/// The batch's trials so far: scored rows, and how many ran, were kept, were run again.
#[derive(Default)]
struct Tally {
    rows: ScoredRows,
    ran: usize,
    kept: usize,
    rerun: usize,
}

/// Checks the plan against the rig and loads what its trials need.
fn prepare(req: &BatchRequest, rig: &BatchRig) -> Result<Prepared, BatchError> {
    let plan = req.plan;
    super::batch::check_size(plan)?;
    let g_min = match &plan.params {
        KindParams::FirstTimeLift(p) => {
            p.calibration.as_deref().map(GMinTable::load).transpose()?
        }
        _ => None,
    };
    let models = load_models(plan)?;
    let (sensors, pins) = rig_sensors(plan, rig);
    let rate_hz = rig_frame_rate_hz(plan, rig);
    check_models_fit_rig(plan, &models, (sensors, pins, rate_hz))?;
    let (notes, mut warnings) = check_model_costs(
        plan,
        &models,
        (sensors, pins, rate_hz),
        req.allow_slow_model,
    )?;
    warnings.extend(model_rate_warnings(plan, &models, rate_hz));
    if let Some(note) = req.on_note {
        notes.iter().for_each(|n| note(n));
    }
    if let Some(warn) = req.on_warning {
        warnings.iter().for_each(|w| warn(w));
    }
    let trials = match req.shard {
        Some(shard) => shard.select(expand(plan)),
        None => expand(plan),
    };
    Ok(Prepared {
        trials,
        models,
        g_min,
        spec: catch_spec(plan),
    })
}

/// Makes the output directory this batch's: refuses one holding its trials without
/// `--resume`, or another batch's, and writes the manifest.
fn claim_directory(
    req: &BatchRequest,
    rig: &BatchRig,
    trials: &[PlannedTrial],
) -> Result<Manifest, BatchError> {
    let (plan, out) = (req.plan, req.out);
    let existing = trials
        .iter()
        .filter(|t| trial_path(out, t).exists())
        .count();
    if existing > 0 && !req.resume {
        return Err(BatchError::AlreadyThere {
            dir: out.to_path_buf(),
            trials: existing,
        });
    }
    std::fs::create_dir_all(out).map_err(|source| BatchError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let manifest = Manifest {
        protocol: plan.source.display().to_string(),
        protocol_sha256: plan.source_sha256.clone(),
        kind: plan.kind,
        mode: plan.mode,
        seed: plan.seed,
        repetitions: plan.repetitions,
        backend: match rig {
            BatchRig::Real { .. } => "real".into(),
            BatchRig::Sim => "sim".into(),
        },
        trials: trials.iter().map(|t| t.trial_id.clone()).collect(),
        shard: req.shard.map(|s| s.to_string()),
    };
    // A resume finishes the batch the directory holds, never another one.
    let kept_manifest = std::fs::read_to_string(out.join("batch.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<Manifest>(&text).ok());
    if let Some(what) = kept_manifest.and_then(|kept| manifest.differs_from(&kept)) {
        return Err(BatchError::DifferentBatch {
            dir: out.to_path_buf(),
            what,
        });
    }
    write_atomic(
        &out.join("batch.json"),
        serde_json::to_string_pretty(&manifest)
            .expect("a manifest serialises")
            .as_bytes(),
    )?;
    Ok(manifest)
}

/// How many trials run at once. Simulated trials are independent (each builds its own world
/// from its own seed), so a window of them runs at once on all cores, and they are scored in
/// order: the outcomes are those of a sequential run. Four trials a core, so that one long
/// trial does not hold the other cores up (measured, 160 hand releases on 2 cores: 1.73x the
/// sequential speed; one trial a core gave 1.50x). A real rig runs one trial at a time, and
/// so does a live view.
fn window(req: &BatchRequest, rig: &BatchRig) -> usize {
    match rig {
        BatchRig::Sim if req.live.is_none() => 4 * rayon::current_num_threads().max(1),
        _ => 1,
    }
}

/// With `--rerun-faulted`, moves the chunk's faulted logs aside so they run again; how many.
fn set_faulted_aside(req: &BatchRequest, chunk: &[PlannedTrial]) -> Result<usize, BatchError> {
    let mut moved = 0;
    for t in chunk {
        let path = trial_path(req.out, t);
        if req.rerun_faulted
            && path.exists()
            && read_trial(&path)?.meta.parameters.contains_key("fault")
        {
            let aside = faulted_trial_path(req.out, t);
            std::fs::rename(&path, &aside).map_err(|source| BatchError::Io {
                path: aside.clone(),
                source,
            })?;
            moved += 1;
        }
    }
    Ok(moved)
}

/// Runs the chunk's trials that have no log yet; `Some` where the batch ends here
/// (interrupted, or the operator gone).
fn run_missing(
    req: &BatchRequest,
    rig: &mut BatchRig,
    prepared: &Prepared,
    chunk: &[PlannedTrial],
    stop: &AtomicBool,
    bar: &indicatif::ProgressBar,
    tally: &mut Tally,
) -> Result<Option<BatchEnd>, BatchError> {
    let (plan, out, models) = (req.plan, req.out, &prepared.models);
    let missing: Vec<&PlannedTrial> = chunk
        .iter()
        .filter(|t| !trial_path(out, t).exists())
        .collect();
    tally.kept += chunk.len() - missing.len();
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    // Each trial's log is written as soon as it ends (under its name, or as aborted when
    // Ctrl-C came first), so a kill loses only the trials still running. Each result
    // says whether the trial was cut short; `None`: it never started (Ctrl-C came before).
    let keep = |t: &PlannedTrial, trial: &Trial| -> Result<bool, BatchError> {
        if stop.load(Ordering::Relaxed) {
            write_trial(&aborted_trial_path(out, t), trial)?;
            Ok(true)
        } else {
            write_trial(&trial_path(out, t), trial)?;
            Ok(false)
        }
    };
    let results: Vec<Result<Option<bool>, BatchError>> = match rig {
        BatchRig::Real { staging, rig } => {
            let mut results = Vec::new();
            for t in &missing {
                let ready = bar.suspend(|| staging.stage(plan, t, stop))?;
                let stopped = stop.load(Ordering::Relaxed);
                if !ready || stopped {
                    return Ok(Some(BatchEnd::Interrupted {
                        finished: tally.ran + tally.kept,
                        aborted_logs: Vec::new(),
                        before_trial: t.trial_id.clone(),
                        operator_gone: !ready && !stopped,
                    }));
                }
                let result = run_real_trial(plan, t, models, rig, unix, stop, req.live)
                    .or_else(|e| Err(keep_faulted(out, t, e)?))
                    .map_err(|e| in_trial(t, e))
                    .and_then(|trial| keep(t, &trial).map(Some));
                let cut = matches!(result, Ok(Some(true)));
                results.push(result);
                if cut {
                    break;
                }
            }
            results
        }
        BatchRig::Sim => missing
            .par_iter()
            .with_max_len(1)
            .map(|t| {
                if stop.load(Ordering::Relaxed) {
                    return Ok(None);
                }
                run_sim_trial(plan, t, models, unix, stop, req.live)
                    .map_err(|e| in_trial(t, e))
                    .and_then(|trial| keep(t, &trial).map(Some))
            })
            .collect(),
    };
    let mut aborted_logs = Vec::new();
    let mut first_missing = None;
    for (t, result) in missing.iter().zip(results) {
        match result? {
            Some(true) => aborted_logs.push(aborted_trial_path(out, t)),
            Some(false) => {
                tally.ran += 1;
                continue;
            }
            None => {}
        }
        first_missing.get_or_insert(t.trial_id.clone());
    }
    Ok(first_missing.map(|before_trial| BatchEnd::Interrupted {
        finished: tally.ran + tally.kept,
        aborted_logs,
        before_trial,
        operator_gone: false,
    }))
}

/// Reads and scores the chunk's logs (a tenth of the cost of running them: in parallel
/// too), in order, telling each trial's outcome.
fn score_chunk(
    req: &BatchRequest,
    prepared: &Prepared,
    chunk: &[PlannedTrial],
    bar: &indicatif::ProgressBar,
    tally: &mut Tally,
) -> Result<(), BatchError> {
    let plan = req.plan;
    let scored: Vec<Result<(Scored, Option<TimingRow>), BatchError>> = chunk
        .par_iter()
        .map(|t| {
            let path = trial_path(req.out, t);
            score_kept(plan, t, &path, &prepared.spec, prepared.g_min.as_ref())
        })
        .collect();
    for (t, result) in chunk.iter().zip(scored) {
        let (scored, timing) = result?;
        tally.rows.timing.extend(timing);
        let message = match scored {
            Scored::Lift(row) => {
                let m = if row.success { "lifted" } else { "not lifted" };
                tally.rows.lift.push(row);
                m.to_string()
            }
            Scored::Calibration(row) => {
                let m = row
                    .g_min
                    .map_or("no g_min".into(), |g| format!("g_min {g:.3}"));
                tally.rows.calibration.push(row);
                m
            }
            Scored::Catch(row) => {
                let m = match plan.mode {
                    // a collect trial never reacts: its verdict says nothing
                    crate::protocol::Mode::Collect => "collected".to_string(),
                    crate::protocol::Mode::Online => row.verdict.label().to_string(),
                };
                tally.rows.catch.push(row);
                m
            }
        };
        let line = format!("{}: {message}", t.trial_id);
        if let Some(tell) = req.on_trial {
            tell(&line);
        }
        bar.set_message(line);
        bar.inc(1);
    }
    Ok(())
}

/// Writes the scored rows (and a calibration's g_min table) and sums the batch up.
fn write_results(
    req: &BatchRequest,
    prepared: &Prepared,
    manifest: Manifest,
    tally: Tally,
    started: std::time::Instant,
) -> Result<BatchEnd, BatchError> {
    let (plan, out) = (req.plan, req.out);
    let csv_path = out.join("outcomes.csv");
    let json_path = out.join("outcomes.json");
    tally.rows.write(&csv_path, &json_path)?;
    let mut outputs = vec![csv_path, json_path];
    if !tally.rows.timing.is_empty() {
        let path = out.join(crate::runner::loop_timing::TIMING_CSV);
        let bytes = crate::runner::loop_timing::to_csv(&tally.rows.timing).map_err(|message| {
            BatchError::Csv {
                path: path.clone(),
                message,
            }
        })?;
        write_atomic(&path, &bytes)?;
        outputs.push(path);
    }
    if plan.kind == Kind::CalibrateLift {
        let table = GMinTable::from_rows(&tally.rows.calibration);
        let path = out.join("g_min.json");
        write_atomic(
            &path,
            serde_json::to_string_pretty(&table)
                .expect("a table serialises")
                .as_bytes(),
        )?;
        outputs.push(path);
    }
    outputs.push(out.join("batch.json"));
    Ok(BatchEnd::Finished(Box::new(BatchSummary {
        manifest,
        rows: tally.rows,
        ran: tally.ran,
        kept: tally.kept,
        rerun_faulted: tally.rerun,
        wall_s: started.elapsed().as_secs_f64(),
        outputs,
        without_calibration: plan.kind == Kind::FirstTimeLift && prepared.g_min.is_none(),
    })))
}

/// A trial's outcome, of the kind its protocol scores.
enum Scored {
    Lift(LiftRow),
    Calibration(CalibrationRow),
    Catch(OutcomeRow),
}

/// Reads a trial's log, checks that it is this trial's, and scores it. Outcomes are always
/// scored from the log as written, so a resumed batch and an uninterrupted one agree to the
/// last bit.
fn score_kept(
    plan: &Plan,
    t: &PlannedTrial,
    path: &Path,
    spec: &crate::outcome::CatchSpec,
    g_min: Option<&GMinTable>,
) -> Result<(Scored, Option<TimingRow>), BatchError> {
    let trial = read_trial_for_scoring(path)?;
    let m = &trial.meta;
    let foreign = if m.trial_id != t.trial_id {
        Some(format!("it is {}", m.trial_id))
    } else if m.seed != t.seed {
        Some(format!("its seed is {}, the trial's {}", m.seed, t.seed))
    } else if m.protocol_sha256.as_deref() != Some(plan.source_sha256.as_str()) {
        Some("another protocol made it".to_string())
    } else if trial.markers.is_empty()
        && trial.events.is_empty()
        && !m.parameters.contains_key("fault")
    {
        // Every trial logs its commands and the marker track until it ends, unless a fault
        // ended it first (the scoring read skips the frames): a log with neither is a
        // damaged one, and scoring it would invent a "held, no slip".
        Some("it holds no messages (no marker track, no events), and no fault says why".to_string())
    } else {
        None
    };
    if let Some(what) = foreign {
        return Err(BatchError::ForeignLog {
            path: path.to_path_buf(),
            trial_id: t.trial_id.clone(),
            what,
        });
    }
    let onset_mm = plan.outcome.onset_threshold_mm;
    let timing = crate::runner::loop_timing::timing_row(&trial);
    let scored = match &plan.params {
        KindParams::FirstTimeLift(_) => {
            Scored::Lift(score::score_first_time_lift(&trial, onset_mm, g_min))
        }
        KindParams::CalibrateLift(p) => {
            Scored::Calibration(score::score_calibration(&trial, onset_mm, p.max_slide_mm))
        }
        _ => Scored::Catch(score::score_trial(&trial, spec)),
    };
    Ok((scored, timing))
}
