//! `tmo run PROTOCOL.toml`: a batch of trials, their logs and their outcome table.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use tmo::protocol::KindParams;
use tmo::protocol::{self, Kind};
use tmo::runner::batch;
use tmo::runner::real_trial::{check_real_plan, open_real, run_real_trial};
use tmo::runner::score::{self, CalibrationRow, GMinTable, LiftRow, OutcomeRow};
use tmo::runner::sim_trial::run_sim_trial;
use tmo::runner::staging::Staging;
use tmo::slip::model::ModelFile;
use tmo::trial::{read_trial, sha256_hex, write_trial};

use tmo::report::inputs::{Batch, BatchRows, Inputs};

/// Exit code of a batch stopped by Ctrl-C (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: i32 = 130;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    #[value(alias = "mock")]
    Sim,
    Replay,
    Real,
}

#[derive(clap::Args)]
pub struct RunArgs {
    protocol: PathBuf,
    #[arg(long, value_enum, default_value = "sim")]
    backend: Backend,
    /// Batch directory (default results/<protocol name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Overrides the protocol's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Overrides the protocol's repetitions.
    #[arg(long)]
    repeat: Option<u32>,
    /// Finish a batch: run only the trials whose logs are missing.
    #[arg(long)]
    resume: bool,
    /// With `--backend real`: the hardware file.
    #[arg(long)]
    hardware: Option<PathBuf>,
    /// With `--backend real`: no operator step between trials (the rig resets itself).
    #[arg(long)]
    unattended: bool,
    /// With `--backend replay`: the recorded trials (logs or batch directories) to replay
    /// through the protocol's models and strategies.
    #[arg(long, num_args = 1..)]
    from: Vec<PathBuf>,
}

fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("writing");
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// Runs the batch; the exit code (0, or 3 when a replay skipped damaged logs).
pub fn run(args: RunArgs) -> Result<u8> {
    anyhow::ensure!(
        args.backend != Backend::Real || args.hardware.is_some(),
        "--backend real needs --hardware FILE (see hardware/tmo.toml; `tmo sim serve` writes one for the simulator)"
    );
    let mut plan = protocol::load(&args.protocol, 3)?;
    // On the real backend everything that can be refused is, before a device is opened.
    let real_rig = match &args.hardware {
        Some(path) if args.backend == Backend::Real => {
            let hw = tmo::hardware::load(path)?;
            check_real_plan(&hw, &mut plan)
                .with_context(|| format!("{} on {}", args.protocol.display(), path.display()))?;
            let staging = Staging::for_batch(&hw, plan.kind, args.unattended)
                .with_context(|| args.protocol.display().to_string())?;
            Some((path.clone(), hw, staging))
        }
        _ => None,
    };
    if args.backend == Backend::Replay {
        anyhow::ensure!(
            !args.from.is_empty(),
            "--backend replay needs --from TRIALS (recorded logs or batch directories)"
        );
        anyhow::ensure!(
            !plan.models.is_empty(),
            "{}: replay needs an online protocol with models",
            args.protocol.display()
        );
        let skipped = super::replay::replay_with(
            &args.from,
            &plan.models,
            &plan.strategies,
            args.out.as_deref(),
        )?;
        return Ok(if skipped {
            super::replay::EXIT_SKIPPED
        } else {
            0
        });
    }
    if let Some(seed) = args.seed {
        plan.seed = seed;
    }
    if let Some(n) = args.repeat {
        anyhow::ensure!(n >= 1, "--repeat must be at least 1");
        plan.repetitions = n;
    }
    let g_min = match &plan.params {
        KindParams::FirstTimeLift(p) => p
            .calibration
            .as_deref()
            .map(GMinTable::load)
            .transpose()
            .with_context(|| {
            format!("{}: first_time_lift.calibration", args.protocol.display())
        })?,
        _ => None,
    };
    let mut models = Vec::new();
    for path in &plan.models {
        let bytes =
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        models.push((ModelFile::load(path)?, sha256_hex(&bytes)));
    }
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("results").join(
            args.protocol
                .file_stem()
                .map_or("batch".into(), |s| s.to_string_lossy().into_owned()),
        )
    });
    let trials = batch::expand(&plan);
    let existing = trials
        .iter()
        .filter(|t| batch::trial_path(&out, t).exists())
        .count();
    anyhow::ensure!(
        existing == 0 || args.resume,
        "{} already holds {existing} trial(s) of a batch: pass --resume to finish it, or choose another --out",
        out.display()
    );
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let manifest = batch::Manifest {
        protocol: plan.source.display().to_string(),
        protocol_sha256: plan.source_sha256.clone(),
        kind: plan.kind,
        mode: plan.mode,
        seed: plan.seed,
        repetitions: plan.repetitions,
        backend: match args.backend {
            Backend::Real => "real".into(),
            _ => "sim".into(),
        },
        trials: trials.iter().map(|t| t.trial_id.clone()).collect(),
    };
    write_atomic(
        &out.join("batch.json"),
        serde_json::to_string_pretty(&manifest)?.as_bytes(),
    )?;

    // Ctrl-C: the running trial makes the rig safe and ends; its log is kept as aborted.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;

    let spec = batch::catch_spec(&plan);
    let onset_mm = plan.outcome.onset_threshold_mm;
    let bar = indicatif::ProgressBar::new(trials.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "run [{bar:30}] {pos}/{len} trials, {elapsed} (eta {eta}) {msg}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    // The real rig is opened once for the batch; the simulator builds a rig per trial.
    let mut real = match real_rig {
        Some((path, hw, staging)) => {
            let rig = open_real(hw, plan.safety)
                .with_context(|| format!("opening the devices of {}", path.display()))?;
            Some((staging, rig))
        }
        None => None,
    };
    let started = std::time::Instant::now();
    let mut rows = Rows::default();
    let (mut ran, mut kept) = (0, 0);
    for t in &trials {
        let path = batch::trial_path(&out, t);
        // Outcomes are always scored from the log as written, so a resumed batch and an
        // uninterrupted one agree to the last bit.
        if path.exists() {
            kept += 1;
        } else {
            let unix = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            if let Some((staging, _)) = real.as_mut() {
                let ready = bar
                    .suspend(|| staging.stage(&plan, t, &stop))
                    .with_context(|| format!("setting up trial {}", t.trial_id))?;
                let stopped = stop.load(std::sync::atomic::Ordering::Relaxed);
                anyhow::ensure!(
                    ready || stopped,
                    "the operator's terminal closed before {}: {} finished trial(s) are in {}; run again with --resume to finish",
                    t.trial_id,
                    ran + kept,
                    out.display()
                );
                if stopped {
                    bar.finish_and_clear();
                    eprintln!(
                        "interrupted before {}: {} finished trial(s) are in {}; run again with --resume to finish",
                        t.trial_id,
                        ran + kept,
                        out.display()
                    );
                    std::process::exit(EXIT_INTERRUPTED);
                }
            }
            let trial = match real.as_mut() {
                Some((_, rig)) => run_real_trial(&plan, t, &models, rig, unix, &stop),
                None => run_sim_trial(&plan, t, &models, unix, &stop),
            }
            .with_context(|| format!("trial {}", t.trial_id))?;
            if stop.load(std::sync::atomic::Ordering::Relaxed) {
                bar.finish_and_clear();
                let aborted = batch::aborted_trial_path(&out, t);
                write_trial(&aborted, &trial)?;
                eprintln!(
                    "interrupted: {} finished trial(s) are in {}; {} kept as aborted; run again with --resume to finish",
                    ran + kept,
                    out.display(),
                    aborted.display()
                );
                std::process::exit(EXIT_INTERRUPTED);
            }
            write_trial(&path, &trial)?;
            ran += 1;
        }
        let trial = read_trial(&path)?;
        let message = match &plan.params {
            KindParams::FirstTimeLift(_) => {
                let row = score::score_first_time_lift(&trial, onset_mm, g_min.as_ref());
                let m = if row.success { "lifted" } else { "not lifted" };
                rows.lift.push(row);
                m.to_string()
            }
            KindParams::CalibrateLift(p) => {
                let row = score::score_calibration(&trial, onset_mm, p.max_slide_mm);
                let m = row
                    .g_min
                    .map_or("no g_min".into(), |g| format!("g_min {g:.3}"));
                rows.calibration.push(row);
                m
            }
            _ => {
                let row = score::score_trial(&trial, &spec);
                let m = format!("{:?}", row.verdict);
                rows.catch.push(row);
                m
            }
        };
        bar.set_message(format!("{}: {message}", t.trial_id));
        bar.inc(1);
    }
    bar.finish_and_clear();

    let csv_path = out.join("outcomes.csv");
    let json_path = out.join("outcomes.json");
    rows.write(&csv_path, &json_path)?;
    println!(
        "{} trials ({ran} run, {kept} already there) in {:.1} s",
        trials.len(),
        started.elapsed().as_secs_f64()
    );
    if rows.aborted > 0 {
        println!(
            "{} trial(s) aborted by a fault (see the fault column)",
            rows.aborted
        );
    }
    let mut outputs = vec![
        csv_path.display().to_string(),
        json_path.display().to_string(),
    ];
    if plan.kind == Kind::CalibrateLift {
        let table = GMinTable::from_rows(&rows.calibration);
        let path = out.join("g_min.json");
        write_atomic(&path, serde_json::to_string_pretty(&table)?.as_bytes())?;
        outputs.push(format!(
            "{} (for first_time_lift.calibration)",
            path.display()
        ));
    }
    outputs.push(out.join("batch.json").display().to_string());
    // The summary is the report's own table for this batch, so `tmo run` and `tmo report`
    // never disagree.
    let inputs = Inputs {
        batches: vec![Batch {
            dir: out.clone(),
            manifest,
            rows: rows.into_batch_rows(plan.kind),
        }],
        ..Default::default()
    };
    let tables = tmo::report::build::tables(&inputs);
    if tables.is_empty() {
        println!("(a collect batch: its outcomes are in the files below)");
    } else {
        print!("{}", tmo::report::render(&tables, tmo::report::Format::Md)?);
    }
    if plan.kind == Kind::FirstTimeLift && g_min.is_none() {
        println!("(no overgrasp: set first_time_lift.calibration to a calibrate_lift batch's g_min.json)");
    }
    println!(
        "wrote trial logs to {}, and {}",
        out.display(),
        outputs.join(", ")
    );
    Ok(0)
}

/// A batch's scored trials; one kind of row per protocol kind.
#[derive(Default)]
struct Rows {
    catch: Vec<OutcomeRow>,
    lift: Vec<LiftRow>,
    calibration: Vec<CalibrationRow>,
    aborted: usize,
}

fn write_rows<T: serde::Serialize>(rows: &[T], csv_path: &Path, json_path: &Path) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)?;
    }
    write_atomic(csv_path, &w.into_inner()?)?;
    write_atomic(json_path, serde_json::to_string_pretty(rows)?.as_bytes())
}

impl Rows {
    fn into_batch_rows(self, kind: Kind) -> BatchRows {
        match kind {
            Kind::FirstTimeLift => BatchRows::Lift(self.lift),
            Kind::CalibrateLift => BatchRows::Calibration(self.calibration),
            _ => BatchRows::Catch(self.catch),
        }
    }

    fn write(&mut self, csv_path: &Path, json_path: &Path) -> Result<()> {
        self.aborted = self.catch.iter().filter(|r| r.fault.is_some()).count()
            + self.lift.iter().filter(|r| r.fault.is_some()).count()
            + self
                .calibration
                .iter()
                .filter(|r| r.fault.is_some())
                .count();
        if !self.lift.is_empty() {
            write_rows(&self.lift, csv_path, json_path)
        } else if !self.calibration.is_empty() {
            write_rows(&self.calibration, csv_path, json_path)
        } else {
            write_rows(&self.catch, csv_path, json_path)
        }
    }
}
