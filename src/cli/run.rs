//! `tmo run PROTOCOL.toml`: a batch of trials, their logs and their outcome table.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result};
use tmo::protocol::{self, Kind};
use tmo::runner::batch::{self, OutcomeRow};
use tmo::slip::model::ModelFile;
use tmo::trial::{read_trial, sha256_hex, write_trial};

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
}

#[derive(serde::Serialize)]
struct Manifest<'a> {
    protocol: String,
    protocol_sha256: &'a str,
    kind: Kind,
    seed: u64,
    repetitions: u32,
    backend: &'static str,
    trials: Vec<&'a str>,
}

fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("writing");
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

pub fn run(args: RunArgs) -> Result<()> {
    anyhow::ensure!(
        args.backend == Backend::Sim,
        "--backend replay and real are not implemented yet (issues 6 and 7); use --backend sim"
    );
    let mut plan = protocol::load(&args.protocol, 3)?;
    if let Some(seed) = args.seed {
        plan.seed = seed;
    }
    if let Some(n) = args.repeat {
        anyhow::ensure!(n >= 1, "--repeat must be at least 1");
        plan.repetitions = n;
    }
    anyhow::ensure!(
        matches!(
            plan.kind,
            Kind::HandRelease | Kind::RailCatch | Kind::RicePour
        ),
        "{}: {} protocols cannot run yet (hand_release, rail_catch and rice_pour so far)",
        args.protocol.display(),
        plan.kind
    );
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
    let manifest = Manifest {
        protocol: plan.source.display().to_string(),
        protocol_sha256: &plan.source_sha256,
        kind: plan.kind,
        seed: plan.seed,
        repetitions: plan.repetitions,
        backend: "sim",
        trials: trials.iter().map(|t| t.trial_id.as_str()).collect(),
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
    let bar = indicatif::ProgressBar::new(trials.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "run [{bar:30}] {pos}/{len} trials, {elapsed} (eta {eta}) {msg}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let started = std::time::Instant::now();
    let mut rows: Vec<OutcomeRow> = Vec::new();
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
            let trial = batch::run_sim_trial(&plan, t, &models, unix, &stop)
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
        let row = batch::score_trial(&trial, &spec);
        bar.set_message(format!("{}: {:?}", t.trial_id, row.verdict));
        rows.push(row);
        bar.inc(1);
    }
    bar.finish_and_clear();

    let csv_path = out.join("outcomes.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in &rows {
        w.serialize(r)?;
    }
    write_atomic(&csv_path, &w.into_inner()?)?;
    let json_path = out.join("outcomes.json");
    write_atomic(&json_path, serde_json::to_string_pretty(&rows)?.as_bytes())?;

    println!(
        "{} trials ({ran} run, {kept} already there) in {:.1} s",
        rows.len(),
        started.elapsed().as_secs_f64()
    );
    if plan.kind == Kind::RicePour {
        print_pour_table(&rows);
    } else {
        print_table(&rows);
    }
    let aborted = rows.iter().filter(|r| r.fault.is_some()).count();
    if aborted > 0 {
        println!("{aborted} trial(s) aborted by a sensor fault (see the fault column)");
    }
    println!(
        "wrote {} trial logs, {}, {} and {}",
        out.display(),
        csv_path.display(),
        json_path.display(),
        out.join("batch.json").display()
    );
    Ok(())
}

/// scope | strategy | grasp | TP | FP | FN | D (mm), as the paper's Table II.
fn print_table(rows: &[OutcomeRow]) {
    let mut cells: BTreeMap<(String, String, String), Vec<&OutcomeRow>> = BTreeMap::new();
    for r in rows {
        cells
            .entry((
                r.scope.clone(),
                r.strategy.clone(),
                format!("{}", r.grasp_deg),
            ))
            .or_default()
            .push(r);
    }
    println!(
        "{:<8} {:<9} {:>6} {:>4} {:>4} {:>4} {:>7}",
        "scope", "strategy", "grasp", "TP", "FP", "FN", "D (mm)"
    );
    for ((scope, strategy, grasp), rs) in cells {
        let count = |v: tmo::outcome::Verdict| rs.iter().filter(|r| r.verdict == v).count();
        let d: Vec<f64> = rs.iter().filter_map(|r| r.slip_distance_mm).collect();
        let mean_d = if d.is_empty() {
            "-".to_string()
        } else {
            format!("{:.1}", d.iter().sum::<f64>() / d.len() as f64)
        };
        println!(
            "{scope:<8} {strategy:<9} {grasp:>6} {:>4} {:>4} {:>4} {mean_d:>7}",
            count(tmo::outcome::Verdict::TruePositive),
            count(tmo::outcome::Verdict::FalsePositive),
            count(tmo::outcome::Verdict::FalseNegative),
        );
    }
}

/// object | trials | responses | dropped, as the paper's rice-pour results.
fn print_pour_table(rows: &[OutcomeRow]) {
    let mut cells: BTreeMap<(String, String), Vec<&OutcomeRow>> = BTreeMap::new();
    for r in rows {
        cells
            .entry((r.object.clone(), r.strategy.clone()))
            .or_default()
            .push(r);
    }
    println!(
        "{:<16} {:<9} {:>6} {:>10} {:>8}",
        "object", "strategy", "trials", "responses", "dropped"
    );
    for ((object, strategy), rs) in cells {
        println!(
            "{object:<16} {strategy:<9} {:>6} {:>10} {:>8}",
            rs.len(),
            rs.iter().map(|r| r.responses).sum::<usize>(),
            rs.iter().filter(|r| r.dropped).count()
        );
    }
}
