//! `tmo sweep`: the paper's Fig. 5 grid as CSV, with its provenance beside it.
//!
//! Finished cells are appended to `<out>.partial` as they complete, so an interrupted
//! sweep loses at most the cells in flight and `--resume` runs only the rest; the final
//! CSV is sorted and written under its name only when every cell is done.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use tmo::slip::dataset::{split_trials, LabelSpec, Scope};
use tmo::slip::labels::OnsetSpec;
use tmo::slip::model::{ClassifierKind, Hyperparameters, TrialRef};
use tmo::slip::sweep::{parse_f64_grid, parse_usize_grid, HyperChoice, Shard, SweepRow, SweepSpec};
use tmo::slip::sweep_file::{merge, read_rows, run_to_file, write_rows, SweepPart, SweepTarget};
use tmo::trial::{expand_trial_paths, TrialMeta};

use super::slip::load_dataset;

/// How a sweep chooses each cell's C and gamma (a grid per cell would multiply the
/// sweep's fits by the grid's size: `tmo train --search grid` searches one cell).
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CellSearch {
    None,
    Bayes,
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    command: Option<SweepCommand>,
    /// Trial logs (.mcap) or directories of them; split by trial into train and test
    /// unless --test is given.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Test trials; when given, every trial in TRIALS trains.
    #[arg(long, num_args = 1..)]
    test: Vec<PathBuf>,
    /// Share of TRIALS held out for testing (whole trials, seeded) when --test is absent.
    #[arg(long, default_value_t = 0.5)]
    test_fraction: f64,
    /// Classifiers, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "svm-rbf,logreg,threshold"
    )]
    classifiers: Vec<ClassifierKind>,
    /// Static down-sampling proportions: start:end:step or a list.
    #[arg(long, default_value = "0.1:1.0:0.1")]
    downsample: String,
    /// Slip frames after onset: start:end or a list.
    #[arg(long, default_value = "1:15")]
    n_slip: String,
    /// Slip windows in seconds instead of frames (for sensors at other rates):
    /// start:end:step or a list; each becomes frames at the first trial's rate.
    #[arg(long, conflicts_with = "n_slip")]
    n_slip_s: Option<String>,
    /// One model on every sensor's frames (global) or one per sensor (local), in every cell.
    #[arg(long, value_enum, default_value = "global")]
    scope: Scope,
    /// Regularisation C when not searched.
    #[arg(long = "C", default_value_t = 3.989)]
    c: f64,
    /// RBF kernel width gamma when not searched (default: 1 / the number of features,
    /// scikit-learn's "scale" for standardised features: 1/60 for 30 pins).
    #[arg(long)]
    gamma: Option<f64>,
    /// Search C (and gamma) by Bayesian optimisation in every cell, on training trials only.
    #[arg(long, value_enum, default_value = "none")]
    search: CellSearch,
    /// Evaluations of each cell's search.
    #[arg(long, default_value_t = 12)]
    iters: usize,
    /// Cross-validation folds (split by trial) of each cell's search.
    #[arg(long, default_value_t = 3)]
    folds: usize,
    /// Range of C each search explores (log-uniform), LOW:HIGH.
    #[arg(long, value_name = "LOW:HIGH", default_value = "0.01:1000", value_parser = tmo::slip::tuning::parse_range)]
    c_range: [f64; 2],
    /// Range of gamma each RBF search explores (log-uniform), LOW:HIGH.
    #[arg(long, value_name = "LOW:HIGH", default_value = "0.0001:10", value_parser = tmo::slip::tuning::parse_range)]
    gamma_range: [f64; 2],
    /// Fit each of a search's models on at most this many rows (a fold's training rows
    /// sampled, each class alike; held-out folds are scored as --held-out-rows says, and
    /// each cell's model uses all its rows). Default: every row.
    #[arg(long, value_name = "ROWS", value_parser = tmo::slip::tuning::parse_search_rows)]
    search_rows: Option<usize>,
    /// The rows of each held-out fold each search scores: every row (as the test trials are
    /// scored), or the static rows down-sampled by d like the training folds (as
    /// scikit-learn's BayesSearchCV scores a training set down-sampled before the search).
    #[arg(long, value_enum, value_name = "ROWS", default_value = "every")]
    held_out_rows: tmo::slip::tuning::HeldOutRows,
    /// Fall below the held height that marks slip onset, mm.
    #[arg(long, default_value_t = 1.0)]
    onset_threshold_mm: f64,
    /// Seed of the split, the down-sampling and the search.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Finish an interrupted sweep with the same arguments, keeping its finished cells.
    #[arg(long)]
    resume: bool,
    /// Run only part K of N of the grid (e.g. 2/8, one per cluster job); `tmo sweep merge`
    /// joins the parts' CSVs into the one a single run writes.
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
    /// The CSV to write; its provenance goes beside it as .json, its heatmaps as .png.
    #[arg(long, value_parser = super::output::a_file, default_value = "results/sweep.csv")]
    out: PathBuf,
    /// Print the best cells and the files written as JSON instead of as text (progress
    /// and notes go to standard error).
    #[arg(long)]
    json: bool,
}

#[derive(clap::Subcommand)]
enum SweepCommand {
    /// Join the CSVs of a sharded sweep (`tmo sweep ... --shard K/N`) into one.
    Merge(MergeArgs),
}

#[derive(clap::Args)]
struct MergeArgs {
    /// Every shard's CSV (each with its provenance .json beside it).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The merged CSV to write (its provenance .json and figures beside it).
    #[arg(long, value_parser = super::output::a_file, default_value = "results/sweep.csv")]
    out: PathBuf,
}

/// What `sweep.json` records. A shard's also names its part; `tmo sweep merge` checks
/// that the shards agree on everything else.
#[derive(serde::Serialize, serde::Deserialize, PartialEq)]
struct SweepProvenance {
    command: Vec<String>,
    classifiers: Vec<ClassifierKind>,
    downsample: Vec<f64>,
    n_slip: Vec<usize>,
    scope: Scope,
    hyperparameters: String,
    seed: u64,
    onset_threshold_mm: f64,
    train_trials: Vec<TrialRef>,
    test_trials: Vec<TrialRef>,
    tmo_version: String,
    git_revision: String,
    wall_seconds: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shard: Option<String>,
}

pub fn sweep(args: SweepArgs) -> Result<()> {
    if let Some(SweepCommand::Merge(m)) = args.command {
        return merge_shards(m);
    }
    let downsample = parse_f64_grid(&args.downsample).context("--downsample")?;
    let n_slip = match &args.n_slip_s {
        None => parse_usize_grid(&args.n_slip).context("--n-slip")?,
        Some(text) => {
            let seconds = parse_f64_grid(text).context("--n-slip-s")?;
            anyhow::ensure!(
                seconds.iter().all(|s| s.is_finite() && *s > 0.0),
                "--n-slip-s {text}: expected positive numbers of seconds"
            );
            let rate = super::slip::first_trial_rate(&args.trials)?;
            let mut frames: Vec<usize> = seconds
                .iter()
                .map(|s| tmo::slip::labels::frames_in(*s, rate))
                .collect();
            frames.sort_unstable();
            frames.dedup();
            super::output::note(format!(
                "--n-slip-s {text}: n_slip {frames:?} frames at {rate:.1} Hz"
            ));
            frames
        }
    };
    anyhow::ensure!(
        args.test_fraction > 0.0 && args.test_fraction < 1.0,
        "--test-fraction must be in (0, 1), got {}",
        tmo::quote::number(args.test_fraction)
    );
    anyhow::ensure!(
        args.onset_threshold_mm > 0.0,
        "--onset-threshold-mm must be positive"
    );
    let hyper = match args.search {
        CellSearch::None => HyperChoice::Fixed(Hyperparameters {
            c: args.c,
            gamma: super::slip::gamma_or_scale(args.gamma, &args.trials)?,
            max_iterations: None,
        }),
        CellSearch::Bayes => HyperChoice::Search {
            iterations: args.iters,
            folds: args.folds,
            ranges: tmo::slip::tuning::SearchRanges {
                c: args.c_range,
                gamma: args.gamma_range,
            },
            max_fit_rows: args.search_rows,
            held_out: args.held_out_rows,
        },
    };
    let spec = SweepSpec {
        classifiers: args.classifiers.clone(),
        downsample: downsample.clone(),
        n_slip: n_slip.clone(),
        scope: args.scope,
        hyper,
        seed: args.seed,
    };
    spec.check()?;

    // Label once with the largest n_slip; every cell narrows it.
    let labels = LabelSpec {
        n_slip: *n_slip.iter().max().expect("checked non-empty"),
        onset: OnsetSpec {
            drop_threshold_mm: args.onset_threshold_mm,
            ..Default::default()
        },
    };
    let mut paths = args.trials.clone();
    paths.extend(args.test.iter().cloned());
    let (data, refs, _) = load_dataset(&paths, &labels)?;
    let is_test: Vec<bool> = if args.test.is_empty() {
        let (_, test) = split_trials(refs.len(), args.test_fraction, args.seed);
        (0..refs.len() as u32).map(|t| test.contains(&t)).collect()
    } else {
        let n_train = expand_trial_paths(&args.trials)?.len();
        (0..refs.len()).map(|t| t >= n_train).collect()
    };
    let train = data.filter(|i| !is_test[data.trial[i] as usize]);
    let test = data.filter(|i| is_test[data.trial[i] as usize]);
    anyhow::ensure!(
        !train.is_empty() && !test.is_empty(),
        "need rows in both the training and the test trials"
    );

    let started = std::time::Instant::now();
    // The bar advances by each cell's expected cost, not by one a cell: the costliest cells
    // run first, so counting cells made the ETA swing from hours to minutes in one run.
    let bar = super::output::progress_bar(
        "sweep [{bar:30}] {percent:>3}% of the expected work, {elapsed} {msg}",
    );
    // cost units a second of the reference machine is cut into (the bar counts in integers)
    const TICKS: f64 = 1000.0;
    let costs = std::sync::OnceLock::new();
    let (cells_done, cells_to_run) = (
        std::sync::atomic::AtomicUsize::new(0),
        std::sync::atomic::AtomicUsize::new(0),
    );
    // cost finished so far, in ticks
    let cost_done = std::sync::atomic::AtomicU64::new(0);
    let (n_train, n_test) = (
        is_test.iter().filter(|t| !**t).count(),
        is_test.iter().filter(|t| **t).count(),
    );
    // Everything but the grid point that a cell's value depends on.
    let trial_hashes = |test: bool| {
        let joined: String = refs
            .iter()
            .zip(&is_test)
            .filter(|(_, t)| **t == test)
            .map(|(r, _)| r.sha256.as_str())
            .collect();
        tmo::trial::sha256_hex(joined.as_bytes())
    };
    let mut identity = format!(
        "scope {:?}\nhyperparameters {:?}\nseed {}\nonset_threshold_mm {}\ntraining trials {}\ntest trials {}\n",
        args.scope,
        hyper,
        args.seed,
        args.onset_threshold_mm,
        trial_hashes(false),
        trial_hashes(true)
    );
    if let Some(shard) = args.shard {
        identity.push_str(&format!("shard {shard}\n"));
    }
    // Ctrl-C starts no more cells; the cells in flight finish and are kept (as every
    // finished cell is), and `--resume` goes on from them.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    let target = SweepTarget {
        out: &args.out,
        resume: args.resume,
        identity,
        stop: Some(&stop),
        part: args.shard.map_or(SweepPart::Whole, SweepPart::Shard),
    };
    let result = run_to_file(
        &train,
        &test,
        &spec,
        &target,
        |cells, done| {
            let line = format!(
                "sweep: {} cells to run ({done} already done), {n_train} train trials ({} rows), {n_test} test trials ({} rows)",
                cells.len(),
                train.len(),
                test.len()
            );
            if args.json {
                super::output::note(&line);
            } else {
                // A failing standard output is reported by the results printed after the
                // sweep; this callback cannot return it.
                let _ = super::output::write_out(format_args!("{line}\n"));
            }
            let c = costs.get_or_init(|| spec.costs(cells, &train));
            cells_to_run.store(cells.len(), std::sync::atomic::Ordering::Relaxed);
            bar.set_length((c.total * TICKS).round() as u64);
        },
        |row| {
            use std::sync::atomic::Ordering::Relaxed;
            let done = cells_done.fetch_add(1, Relaxed) + 1;
            let ticks = (costs.get().map_or(0.0, |c| c.of(row)) * TICKS).round() as u64;
            let ticks_done = cost_done.fetch_add(ticks, Relaxed) + ticks;
            // indicatif's own ETA follows the recent rate, which swings as lumps of very
            // different cost finish; this one is the whole run's rate (CellCosts::eta_s)
            let eta = costs
                .get()
                .and_then(|c| c.eta_s(started.elapsed().as_secs_f64(), ticks_done as f64 / TICKS))
                .map_or(String::new(), |s| {
                    format!(
                        " (eta {})",
                        indicatif::HumanDuration(std::time::Duration::from_secs_f64(s))
                    )
                });
            super::output::detail(
                &bar,
                format!(
                    "cell {} n_slip {} d {}: macro F1 {:.3} ({:.1} s)",
                    row.classifier, row.n_slip, row.downsample, row.macro_f1, row.seconds
                ),
            );
            bar.set_message(format!(
                "{done}/{} cells{eta}; last: {} n_slip {} d {} F1 {:.3}",
                cells_to_run.load(Relaxed),
                row.classifier,
                row.n_slip,
                row.downsample,
                row.macro_f1
            ));
            bar.inc(ticks);
        },
    );
    bar.finish_and_clear();
    let result = match result {
        Err(e) if e.stopped() => {
            eprintln!(
                "interrupted: {} cell(s) finished this run are kept in {}; run again with --resume to finish",
                cells_done.load(std::sync::atomic::Ordering::Relaxed),
                tmo::slip::sweep_file::partial_path(&args.out).display()
            );
            std::process::exit(super::run::EXIT_INTERRUPTED);
        }
        other => other?,
    };
    if result.cut_torn_line {
        super::output::note(
            "note: the partial results ended in a line cut short (a write that did not finish); that cell ran again",
        );
    }
    let rows = result.rows;
    if let HyperChoice::Search { ranges, .. } = hyper {
        let at_ends: Vec<String> = rows
            .iter()
            .filter_map(|r| {
                let kind = args.classifiers.iter().find(|k| k.name() == r.classifier)?;
                let ends = ranges.ends_reached(*kind, r.c?, r.gamma.unwrap_or(f64::NAN));
                (!ends.is_empty()).then(|| {
                    let what: Vec<String> = ends
                        .iter()
                        .map(|(name, value, end)| format!("{name} {value:.4} at the {end} end"))
                        .collect();
                    format!(
                        "{} n_slip {} d {}: {}",
                        r.classifier,
                        r.n_slip,
                        r.downsample,
                        what.join(", ")
                    )
                })
            })
            .collect();
        if !at_ends.is_empty() {
            eprintln!(
                "warning: in {} of {} cells the search's best lies at an end of its range (the optimum may lie beyond; widen --c-range or --gamma-range): {}",
                at_ends.len(),
                rows.len(),
                at_ends.join("; ")
            );
        }
    }

    let (tmo_version, git_revision) = TrialMeta::code_version();
    let provenance = SweepProvenance {
        command: std::env::args().collect(),
        classifiers: spec.classifiers.clone(),
        downsample: downsample.clone(),
        n_slip: n_slip.clone(),
        scope: args.scope,
        hyperparameters: match hyper {
            HyperChoice::Fixed(h) => format!("fixed C = {}, gamma = {} (svm-rbf only)", h.c, h.gamma),
            HyperChoice::Search {
                iterations,
                folds,
                ranges,
                max_fit_rows,
                held_out,
            } => format!(
                "Bayesian search per cell: {iterations} evaluations, {folds}-fold CV by trial, C in [{}, {}], gamma in [{}, {}] (log-uniform){}, {}",
                ranges.c[0], ranges.c[1], ranges.gamma[0], ranges.gamma[1],
                max_fit_rows.map_or(String::new(), |n| format!(", fits on at most {n} rows")),
                held_out.describe()
            ),
        },
        seed: args.seed,
        onset_threshold_mm: args.onset_threshold_mm,
        train_trials: refs
            .iter()
            .zip(&is_test)
            .filter(|(_, t)| !**t)
            .map(|(r, _)| r.clone())
            .collect(),
        test_trials: refs
            .iter()
            .zip(&is_test)
            .filter(|(_, t)| **t)
            .map(|(r, _)| r.clone())
            .collect(),
        tmo_version,
        git_revision,
        wall_seconds: started.elapsed().as_secs_f64(),
        shard: args.shard.map(|s| s.to_string()),
    };
    write_outputs(
        &args.out,
        &provenance,
        &rows,
        started.elapsed().as_secs_f64(),
        args.json,
    )
}

/// A classifier's best cell, and how many cells it has and their mean macro F1.
struct BestCell<'r> {
    row: &'r SweepRow,
    cells: usize,
    mean_macro_f1: f64,
}

/// Each classifier's best cell, in the sweep's classifier order (one pass per classifier).
fn best_cells<'r>(provenance: &SweepProvenance, rows: &'r [SweepRow]) -> Vec<BestCell<'r>> {
    provenance
        .classifiers
        .iter()
        .filter_map(|kind| {
            let of_kind: Vec<&SweepRow> = rows
                .iter()
                .filter(|r| r.classifier == kind.name())
                .collect();
            let row = *of_kind
                .iter()
                .max_by(|a, b| a.macro_f1.total_cmp(&b.macro_f1))?;
            Some(BestCell {
                row,
                cells: of_kind.len(),
                mean_macro_f1: of_kind.iter().map(|r| r.macro_f1).sum::<f64>()
                    / of_kind.len() as f64,
            })
        })
        .collect()
}

/// Writes the provenance beside the CSV, prints the best cells and draws the heatmaps.
fn write_outputs(
    out: &std::path::Path,
    provenance: &SweepProvenance,
    rows: &[SweepRow],
    seconds: f64,
    json: bool,
) -> Result<()> {
    let meta_path = out.with_extension("json");
    tmo::output::atomic::write_atomic(
        &meta_path,
        serde_json::to_string_pretty(provenance)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", meta_path.display()))?;
    let figures = draw_heatmaps(out, provenance, rows)?;
    let best = best_cells(provenance, rows);
    if json {
        let best: Vec<serde_json::Value> = best
            .iter()
            .map(|b| {
                serde_json::json!({
                    "classifier": b.row.classifier,
                    "best_macro_f1": b.row.macro_f1,
                    "n_slip": b.row.n_slip,
                    "downsample": b.row.downsample,
                    "c": b.row.c,
                    "gamma": b.row.gamma,
                    "cells": b.cells,
                    "mean_macro_f1": b.mean_macro_f1,
                })
            })
            .collect();
        let mut outputs = vec![out.to_path_buf(), meta_path];
        outputs.extend(figures);
        let v = serde_json::json!({
            "cells": rows.len(),
            "wall_s": seconds,
            "best": best,
            "outputs": outputs,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    outln!(
        "{} cells in {:.1} s; best test macro F1 per classifier:",
        rows.len(),
        seconds
    );
    for BestCell {
        row: r,
        cells,
        mean_macro_f1,
    } in &best
    {
        let hyper = match (r.c, r.gamma) {
            (Some(c), Some(gamma)) => format!(" (C {c:.4}, gamma {gamma:.5})"),
            (Some(c), None) => format!(" (C {c:.4})"),
            _ => String::new(),
        };
        outln!(
            "  {:<10} {:.3} at n_slip {:>2}, d {}{hyper}; mean over {cells} cells {mean_macro_f1:.3}",
            r.classifier, r.macro_f1, r.n_slip, r.downsample,
        );
    }
    outln!("wrote {} and {}", out.display(), meta_path.display());
    if !figures.is_empty() {
        let names: Vec<String> = figures.iter().map(|p| p.display().to_string()).collect();
        outln!("wrote {}", names.join(", "));
    }
    Ok(())
}

/// The paper's Fig. 5 beside the CSV, through the same code as `tmo report --plots`; none
/// for a shard, whose heatmaps would show holes (`tmo sweep merge` draws the whole grid).
fn draw_heatmaps(
    out: &std::path::Path,
    provenance: &SweepProvenance,
    rows: &[SweepRow],
) -> Result<Vec<std::path::PathBuf>> {
    if provenance.shard.is_some() {
        return Ok(Vec::new());
    }
    let plot_dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    // Named after the CSV, so two sweeps in one directory keep their own figures.
    let prefix = out
        .file_stem()
        .map_or(String::new(), |s| format!("{}_", s.to_string_lossy()));
    Ok(tmo::plots::offline::sweep_heatmaps(
        rows, plot_dir, &prefix,
    )?)
}

/// `tmo sweep merge`: the shards' rows as one sweep, after checking that the shards are the
/// parts of one grid (same settings and trials, each part once, none missing).
/// A shard's provenance as a sweep writes it: a grid of proportions and frame counts, a
/// finite positive onset threshold and wall time.
fn check_provenance(path: &Path, p: &SweepProvenance) -> Result<()> {
    let bad = |what: &str| anyhow::anyhow!("{}: {what}", path.display());
    if p.classifiers.is_empty() || p.downsample.is_empty() || p.n_slip.is_empty() {
        return Err(bad(
            "expected classifiers, downsample and n_slip grids that are not empty",
        ));
    }
    if !p
        .downsample
        .iter()
        .all(|d| d.is_finite() && *d > 0.0 && *d <= 1.0)
    {
        return Err(bad("`downsample`: expected proportions in (0, 1]"));
    }
    if !p.n_slip.iter().all(|n| (1..=10_000).contains(n)) {
        return Err(bad("`n_slip`: expected frame counts from 1 to 10000"));
    }
    if !(p.onset_threshold_mm.is_finite() && p.onset_threshold_mm > 0.0) {
        return Err(bad(
            "`onset_threshold_mm`: expected a positive number of mm",
        ));
    }
    if !(p.wall_seconds.is_finite() && p.wall_seconds >= 0.0) {
        return Err(bad(
            "`wall_seconds`: expected a number of seconds, 0 or more",
        ));
    }
    Ok(())
}

fn merge_shards(args: MergeArgs) -> Result<()> {
    let started = std::time::Instant::now();
    let mut first: Option<(PathBuf, SweepProvenance)> = None;
    let mut parts = Vec::new();
    let mut seen: Vec<(Shard, PathBuf)> = Vec::new();
    let mut wall = 0.0f64;
    // the merge must not write over one of its own inputs
    let same_file = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    };
    for csv in &args.shards {
        anyhow::ensure!(
            !same_file(csv, &args.out)
                && !same_file(
                    &csv.with_extension("json"),
                    &args.out.with_extension("json")
                ),
            "--out {} is the shard {} (or its provenance): write the merged sweep to another file",
            args.out.display(),
            csv.display()
        );
    }
    for csv in &args.shards {
        let meta_path = csv.with_extension("json");
        let text = std::fs::read_to_string(&meta_path).with_context(|| {
            format!(
                "cannot read {}, the provenance `tmo sweep --shard` writes beside {}",
                meta_path.display(),
                csv.display()
            )
        })?;
        let mut p: SweepProvenance = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a sweep's provenance", meta_path.display()))?;
        let shard: Shard = p
            .shard
            .as_deref()
            .with_context(|| {
                format!(
                    "{}: not a shard (its sweep ran without --shard)",
                    meta_path.display()
                )
            })?
            .parse()
            .with_context(|| format!("{}: shard", meta_path.display()))?;
        if let Some((_, other)) = seen.iter().find(|(s, _)| s.index == shard.index) {
            anyhow::bail!(
                "{} and {} are both shard {shard}",
                csv.display(),
                other.display()
            );
        }
        check_provenance(&meta_path, &p)?;
        seen.push((shard, csv.clone()));
        wall = wall.max(p.wall_seconds);
        // what may differ between the parts of one sweep
        p.command.clear();
        p.wall_seconds = 0.0;
        p.shard = None;
        match &first {
            None => first = Some((csv.clone(), p)),
            Some((path, f)) => {
                anyhow::ensure!(
                    *f == p,
                    "{} is a shard of another sweep than {} (settings, trials or code version differ)",
                    csv.display(),
                    path.display()
                );
            }
        }
        let rows = read_rows(csv)?;
        // the rows as `tmo report` would take them: a tampered or damaged score is refused
        // here, not written into a merged sweep the report then refuses
        tmo::report::checks::sweep(csv, &rows)?;
        parts.push((csv.clone(), rows));
    }
    let (_, mut provenance) = first.context("no shards given")?;
    let count = seen[0].0.count;
    if let Some((s, path)) = seen.iter().find(|(s, _)| s.count != count) {
        anyhow::bail!(
            "{} is shard {s}, another shard is of {count}",
            path.display()
        );
    }
    let missing: Vec<String> = (1..=count)
        .filter(|k| !seen.iter().any(|(s, _)| s.index == *k))
        .map(|k| format!("{k}/{count}"))
        .collect();
    anyhow::ensure!(
        missing.is_empty(),
        "shard(s) {} not given",
        missing.join(", ")
    );
    let spec = SweepSpec {
        classifiers: provenance.classifiers.clone(),
        downsample: provenance.downsample.clone(),
        n_slip: provenance.n_slip.clone(),
        scope: provenance.scope,
        hyper: HyperChoice::Fixed(Hyperparameters::default()),
        seed: provenance.seed,
    };
    let rows = merge(&spec, parts)?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    // one writer at a time, as for a sweep
    let _lock = tmo::output::lock::OutputLock::acquire(&args.out)?;
    write_rows(&args.out, &rows)?;
    provenance.command = std::env::args().collect();
    // the shards ran side by side: the sweep took as long as the slowest
    provenance.wall_seconds = wall;
    outln!("merged {count} shards into {} cells", rows.len());
    write_outputs(
        &args.out,
        &provenance,
        &rows,
        started.elapsed().as_secs_f64(),
        false,
    )
}
