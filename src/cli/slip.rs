//! `tmo dataset`, `tmo train`, `tmo evaluate` and `tmo sweep`: the slip library from the command line.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Subcommand;
use tmo::slip::dataset::{Dataset, LabelSpec, Scope};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo::slip::metrics::Scores;
use tmo::slip::model::{self, ClassifierKind, Hyperparameters, ModelFile, TrialRef};
use tmo::slip::tuning::{self, TuneSpec};

#[derive(Subcommand)]
pub enum DatasetCommand {
    /// Writes features, labels and trial/sensor/frame ids as CSV (for pandas or scikit-learn).
    Export(ExportArgs),
}

/// How frames are labelled and sampled.
#[derive(clap::Args, Clone)]
pub struct LabelArgs {
    /// Frames labelled slip after the marker onset.
    #[arg(long, default_value_t = 13)]
    n_slip: usize,
    /// The slip window in seconds instead of frames (for sensors at other rates): n_slip is
    /// this times the first trial's frame rate, rounded.
    #[arg(long, conflicts_with = "n_slip")]
    n_slip_s: Option<f64>,
    /// Proportion of static frames kept (slip frames are never dropped). Default: 0.4 for
    /// train (the paper's balance), 1 for dataset export (every frame, e.g. of a test set).
    #[arg(long)]
    downsample: Option<f64>,
    /// Fall below the held height that marks slip onset, mm.
    #[arg(long, default_value_t = 1.0)]
    onset_threshold_mm: f64,
    /// Seed of the down-sampling.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    #[command(flatten)]
    labels: LabelArgs,
    /// What to write: feature rows, or the trials' raw frames as interchange CSV (one row per
    /// element per frame with each trial's onset, docs/formats.md; --n-slip and
    /// --downsample do not apply).
    #[arg(long, value_enum, default_value = "features")]
    format: ExportFormat,
    /// The CSV file to write (`-`: standard output).
    #[arg(long, value_parser = super::output::a_file_or_stdout)]
    out: PathBuf,
}

#[derive(clap::ValueEnum, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// Features, labels and trial/sensor/frame ids, one row per labelled frame.
    Features,
    /// The interchange CSV `tmo import csv` reads.
    Interchange,
}

#[derive(clap::Args)]
pub struct TrainArgs {
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// The classifier to train.
    #[arg(long, value_enum, default_value = "svm-rbf")]
    classifier: ClassifierKind,
    /// One model on every sensor's frames (global) or one per sensor (local).
    #[arg(long, value_enum, default_value = "global")]
    scope: Scope,
    #[command(flatten)]
    labels: LabelArgs,
    /// Regularisation C (SVM, logistic regression).
    #[arg(long = "C", default_value_t = 3.989)]
    c: f64,
    /// RBF kernel width gamma (default: 1 / the number of features, scikit-learn's "scale"
    /// for standardised features: 1/60 for 30 pins).
    #[arg(long)]
    gamma: Option<f64>,
    /// Find C (and gamma) by cross-validated macro F1 instead (folds of whole trials):
    /// Bayesian optimisation over --c-range and --gamma-range, or every point of --c-grid x
    /// --gamma-grid, as scikit-learn's GridSearchCV. For a new sensor's data, search: the
    /// paper's C and gamma were chosen for TacTip pins.
    #[arg(long, value_enum, default_value = "none")]
    search: SearchMethod,
    /// The C values of --search grid, comma-separated.
    #[arg(long, value_name = "C,...", default_value = "0.1,1,10,100,1000", value_parser = parse_grid)]
    c_grid: GridValues,
    /// The gamma values of --search grid for the RBF SVM, comma-separated (default: the
    /// "scale" gamma, 1 / the number of features, times 0.1, 0.3, 1, 3 and 10).
    #[arg(long, value_name = "GAMMA,...", value_parser = parse_grid)]
    gamma_grid: Option<GridValues>,
    /// Evaluations of the search.
    #[arg(long, default_value_t = 20)]
    iters: usize,
    /// Cross-validation folds, split by trial: of the search, or (without one) of the
    /// held-out score `train` prints before the final fit; 0: no held-out score.
    #[arg(long, default_value_t = 3)]
    folds: usize,
    /// Range of C the search explores (log-uniform), LOW:HIGH.
    #[arg(long, value_name = "LOW:HIGH", default_value = "0.01:1000", value_parser = tuning::parse_range)]
    c_range: [f64; 2],
    /// Range of gamma the search explores for the RBF SVM (log-uniform), LOW:HIGH.
    #[arg(long, value_name = "LOW:HIGH", default_value = "0.0001:10", value_parser = tuning::parse_range)]
    gamma_range: [f64; 2],
    /// Fit each of the search's models on at most this many rows (a fold's training rows
    /// sampled, each class alike; held-out folds are scored as --held-out-rows says, and
    /// the final model uses all rows). Default: every row.
    #[arg(long, value_name = "ROWS", value_parser = tmo::slip::tuning::parse_search_rows)]
    search_rows: Option<usize>,
    /// The rows of each held-out fold the search scores: every row (as the test trials are
    /// scored), or the static rows down-sampled by d like the training folds (as
    /// scikit-learn's BayesSearchCV scores a training set down-sampled before the search).
    #[arg(long, value_enum, value_name = "ROWS", default_value = "every")]
    held_out_rows: tmo::slip::tuning::HeldOutRows,
    /// How whole trials are assigned to the folds: shuffled by --seed and dealt out in turn,
    /// or as scikit-learn's GroupKFold (the most rows first, each to the lightest fold; no
    /// seed), so that --search grid picks what GridSearchCV(cv=GroupKFold(k)) picks.
    #[arg(long, value_enum, value_name = "HOW", default_value = "shuffled")]
    fold_assignment: tmo::slip::tuning::FoldAssignment,
    /// Cap on the SVM solver's iterations: SMO pair steps for svm-rbf (default libsvm's,
    /// max(100 x rows, 10,000,000)), Newton steps for svm-linear (default 200).
    #[arg(long)]
    max_iterations: Option<usize>,
    /// An SVM fit that stops at its iteration cap before converging is an error (exit 2,
    /// no model written) instead of a warning.
    #[arg(long)]
    strict: bool,
    /// The model file to write (JSON, docs/formats.md).
    #[arg(long, value_parser = super::output::a_file)]
    out: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SearchMethod {
    None,
    Bayes,
    /// Every point of --c-grid x --gamma-grid.
    Grid,
}

/// The values of a grid axis, as given.
#[derive(Debug, Clone, PartialEq)]
pub struct GridValues(pub Vec<f64>);

/// A grid axis: comma-separated positive finite numbers, at most 100 of them.
fn parse_grid(text: &str) -> Result<GridValues, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| tmo::slip::search_range::searchable(*x))
                .ok_or_else(|| {
                    let [lo, hi] = tmo::slip::search_range::SEARCHABLE;
                    format!(
                        "expected numbers in {lo}..={hi} separated by commas, got {:?}",
                        v.trim()
                    )
                })
        })
        .collect::<Result<_, _>>()?;
    if values.len() > 100 {
        return Err(format!("at most 100 values, got {}", values.len()));
    }
    Ok(GridValues(values))
}

#[derive(clap::Args)]
pub struct EvaluateArgs {
    /// The model: a model file from `tmo train`, or an ONNX model (`.onnx`, docs/onnx.md).
    model: PathBuf,
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Also write the scores as JSON (for `tmo report`; `-`: standard output).
    #[arg(long, value_parser = super::output::a_file_or_stdout)]
    out: Option<PathBuf>,
    /// Print the scores as JSON (the `--out` file's contents) instead of as text.
    #[arg(long)]
    json: bool,
    /// Also write every row's slip value and class to this CSV (trial_id, sensor, seq,
    /// time_s, label, value, class): the model's output as the online loop reads it (an
    /// ONNX model's slip value, a tmo model's decision value), to check against another
    /// runtime's.
    #[arg(long, value_name = "FILE.csv")]
    rows: Option<PathBuf>,
    /// Score the trials a windowed model can classify and name the others (shorter than
    /// its window), rather than refuse them all.
    #[arg(long)]
    skip_short: bool,
}

/// Every row's slip value and class as CSV (`tmo evaluate --rows`): a row without a full
/// window has an empty value and class.
fn write_row_values(
    path: &std::path::Path,
    data: &tmo::slip::dataset::Dataset,
    values: &[Option<(f32, tmo::slip::Class)>],
) -> Result<()> {
    let mut w = super::output::atomic_csv(path)?;
    w.write_record([
        "trial_id", "sensor", "seq", "time_s", "label", "value", "class",
    ])?;
    let name = |c: tmo::slip::Class| match c {
        tmo::slip::Class::Slip => "slip",
        tmo::slip::Class::Static => "static",
    };
    for (i, v) in values.iter().enumerate() {
        w.write_record([
            data.trial_ids[data.trial[i] as usize].clone(),
            data.sensor[i].to_string(),
            data.seq[i].to_string(),
            format!("{:.6}", data.time_s[i]),
            name(data.y[i]).to_string(),
            // shortest text that reads back as the same f32
            v.map_or(String::new(), |(value, _)| value.to_string()),
            v.map_or(String::new(), |(_, class)| name(class).to_string()),
        ])?;
    }
    super::output::commit_csv(w, path)
}

/// The first of `trials` (files or directories of them), read: what defaults that depend on
/// the sensor (gamma, a slip window in seconds) are taken from.
fn first_trial(trials: &[PathBuf]) -> Result<(PathBuf, tmo::trial::Trial)> {
    let paths = tmo::trial::expand_trial_paths(trials)?;
    let first = paths
        .into_iter()
        .next()
        .ok_or_else(|| anyhow::anyhow!("no trial logs found"))?;
    let trial = tmo::trial::read_trial(&first)?;
    Ok((first, trial))
}

/// The RBF kernel's gamma: `given`, or one over the feature count of the first of `trials`.
pub fn gamma_or_scale(given: Option<f64>, trials: &[PathBuf]) -> Result<f64> {
    if let Some(g) = given {
        return Ok(g);
    }
    let (_, trial) = first_trial(trials)?;
    Ok(tmo::slip::model::scale_gamma(2 * trial.meta.pins))
}

/// The frame rate of the first of `trials` (one over its median frame interval), Hz: what
/// a slip window in seconds is turned into frames with.
pub fn first_trial_rate(trials: &[PathBuf]) -> Result<f64> {
    let (path, trial) = first_trial(trials)?;
    let rate = tmo::slip::dataset::trial_features(&trial)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .frame_rate_hz
        .ok_or_else(|| anyhow::anyhow!("{}: too few frames for a frame rate", path.display()))?;
    Ok(f64::from(rate))
}

impl LabelArgs {
    /// The share of static frames kept: `--downsample`, or the command's own default.
    fn downsample_or(&self, default: f64) -> f64 {
        self.downsample.unwrap_or(default)
    }
}

/// Static frames kept by `tmo train` unless told otherwise.
const TRAIN_DOWNSAMPLE: f64 = 0.4;

/// How frames are labelled; `trials` give the frame rate when the window is in seconds.
pub fn label_spec(args: &LabelArgs, trials: &[PathBuf]) -> Result<LabelSpec> {
    let n_slip = match args.n_slip_s {
        None => args.n_slip,
        Some(seconds) => {
            anyhow::ensure!(
                seconds.is_finite() && seconds > 0.0,
                "--n-slip-s must be a positive number of seconds, got {}",
                tmo::quote::number(seconds)
            );
            let rate = first_trial_rate(trials)?;
            let n = tmo::slip::labels::frames_in(seconds, rate);
            super::output::note(format!(
                "--n-slip-s {seconds}: n_slip {n} frames at {rate:.1} Hz"
            ));
            n
        }
    };
    anyhow::ensure!(
        (1..=tmo::slip::labels::MAX_N_SLIP).contains(&n_slip),
        "--n-slip must be 1..={} frames, got {n_slip}",
        tmo::slip::labels::MAX_N_SLIP
    );
    if let Some(d) = args.downsample {
        anyhow::ensure!(
            d > 0.0 && d <= 1.0,
            "--downsample must be in (0, 1], got {}",
            tmo::quote::number(d)
        );
    }
    anyhow::ensure!(
        args.onset_threshold_mm > 0.0,
        "--onset-threshold-mm must be positive"
    );
    Ok(LabelSpec {
        n_slip,
        onset: OnsetSpec {
            drop_threshold_mm: args.onset_threshold_mm,
            ..Default::default()
        },
    })
}

/// Loads trials and builds their labelled rows, noting trials without a slip onset.
pub fn load_dataset(
    paths: &[PathBuf],
    labels: &LabelSpec,
) -> Result<(Dataset, Vec<TrialRef>, FeatureSpec)> {
    let (ds, refs, features) = tmo::slip::dataset::load_labelled(paths, labels)?;
    if !ds.trials_without_onset.is_empty() {
        super::output::note(format!(
            "note: no slip onset (in the marker track or slip labels) in {} trial(s): {}",
            ds.trials_without_onset.len(),
            tmo::quote::list(&ds.trials_without_onset, tmo::quote::LISTED)
        ));
    }
    // Imported trials' rates were said at import: again only when asked (-v).
    match &ds.rate_spread {
        Some(spread) if !ds.all_imported => eprintln!("warning: {spread}"),
        Some(spread) if super::output::verbose() => {
            eprintln!("warning: {spread} (as the import said)")
        }
        _ => {}
    }
    Ok((ds, refs, features))
}

pub fn dataset_export(args: ExportArgs) -> Result<()> {
    let labels = label_spec(&args.labels, &args.trials)?;
    if args.format == ExportFormat::Interchange {
        anyhow::ensure!(
            args.labels.downsample.is_none(),
            "--downsample applies to feature rows; --format interchange writes every frame"
        );
        let paths = tmo::trial::expand_trial_paths(&args.trials)?;
        let trials = paths
            .iter()
            .map(|p| tmo::trial::read_trial(p))
            .collect::<Result<Vec<_>, _>>()?;
        let to_stdout = super::output::is_stdout(&args.out);
        if to_stdout {
            let stdout = std::io::BufWriter::new(std::io::stdout().lock());
            tmo::import::export_interchange(&trials, &labels.onset, stdout)
                .context("cannot write to standard output")?;
        } else {
            let mut file = tmo::output::atomic::AtomicFile::create(&args.out)
                .with_context(|| format!("cannot write {}", args.out.display()))?;
            tmo::import::export_interchange(&trials, &labels.onset, &mut file)
                .with_context(|| format!("cannot write {}", args.out.display()))?;
            file.commit()
                .with_context(|| format!("cannot write {}", args.out.display()))?;
        }
        say_written(
            format!("{} trial(s) as interchange CSV", trials.len()),
            &args.out,
        )?;
        return Ok(());
    }
    let (ds, _, _) = load_dataset(&args.trials, &labels)?;
    let ds = ds.downsample_static(args.labels.downsample_or(1.0), args.labels.seed);
    if super::output::is_stdout(&args.out) {
        let mut out = ds
            .write_csv_to(std::io::BufWriter::new(std::io::stdout().lock()))
            .context("cannot write to standard output")?;
        std::io::Write::flush(&mut out).context("cannot write to standard output")?;
    } else {
        ds.write_csv(&args.out)
            .with_context(|| format!("cannot write {}", args.out.display()))?;
    }
    say_written(
        format!(
            "{} rows ({} static, {} slip)",
            ds.len(),
            ds.count(tmo::slip::Class::Static),
            ds.count(tmo::slip::Class::Slip)
        ),
        &args.out,
    )
}

/// "wrote WHAT to OUT": on standard output, or on standard error when the output itself
/// went to standard output (`--out -`), which then holds the CSV alone.
fn say_written(what: String, out: &std::path::Path) -> Result<()> {
    if super::output::is_stdout(out) {
        super::output::note(format!("wrote {what} to standard output"));
    } else {
        outln!("wrote {what} to {}", out.display());
    }
    Ok(())
}

fn print_scores(label: &str, s: &Scores) -> Result<()> {
    let c = &s.confusion;
    outln!(
        "{label:<10} macro F1 {:.3} | slip P {:.3} R {:.3} F1 {:.3} | static P {:.3} R {:.3} F1 {:.3} | TP {} FP {} TN {} FN {}",
        s.macro_f1, s.slip.precision, s.slip.recall, s.slip.f1, s.static_.precision, s.static_.recall, s.static_.f1,
        c.true_slip, c.false_slip, c.true_static, c.false_static
    );
    Ok(())
}

/// Checks where a model will be written before any training: a fit takes minutes, and its
/// result should not be lost to a path that cannot take it. Creates missing parent folders.
fn check_model_out(out: &std::path::Path) -> Result<()> {
    anyhow::ensure!(
        !out.is_dir(),
        "--out {}: is a folder; expected the model file's path (e.g. {}/model.json)",
        out.display(),
        out.display()
    );
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| {
            format!(
                "--out {}: cannot create {}",
                out.display(),
                parent.display()
            )
        })?;
    }
    // The model is written beside its final name first; that file must be creatable.
    let partial = out.with_extension("json.partial");
    tmo::output::atomic::create_fresh(&partial)
        .with_context(|| format!("--out {}: cannot write there", out.display()))?;
    let _ = std::fs::remove_file(&partial);
    Ok(())
}

pub fn train(args: TrainArgs) -> Result<()> {
    check_model_out(&args.out)?;
    // a grid axis nothing reads would be ignored without a word
    if args.gamma_grid.is_some() {
        anyhow::ensure!(
            args.search == SearchMethod::Grid,
            "--gamma-grid is the gamma axis of --search grid; add --search grid or leave it out"
        );
        anyhow::ensure!(
            args.classifier.uses_gamma(),
            "--gamma-grid: the {} classifier has no gamma (only svm-rbf has); leave it out",
            args.classifier.name()
        );
    }
    // one writer per model file: two trainings aimed at one path would leave the last's
    let _lock = tmo::output::lock::OutputLock::acquire(&args.out)?;
    let labels = label_spec(&args.labels, &args.trials)?;
    let (ds, refs, features) = load_dataset(&args.trials, &labels)?;
    let started = std::time::Instant::now();
    let (hyper, search) = match args.search {
        SearchMethod::None => (
            Hyperparameters {
                c: args.c,
                gamma: args
                    .gamma
                    .unwrap_or_else(|| tmo::slip::model::scale_gamma(features.len())),
                max_iterations: None,
            },
            None,
        ),
        SearchMethod::Grid | SearchMethod::Bayes => {
            let grid = args.search == SearchMethod::Grid;
            anyhow::ensure!(
                args.classifier != ClassifierKind::Threshold,
                "--search {}: the threshold classifier has no hyperparameters",
                if grid { "grid" } else { "bayes" }
            );
            let spec = TuneSpec {
                kind: args.classifier,
                scope: args.scope,
                downsample: args.labels.downsample_or(TRAIN_DOWNSAMPLE),
                seed: args.labels.seed,
                iterations: if grid { 0 } else { args.iters },
                folds: args.folds,
                ranges: tuning::SearchRanges {
                    c: args.c_range,
                    gamma: args.gamma_range,
                },
                max_fit_rows: args.search_rows,
                held_out: args.held_out_rows,
                assignment: args.fold_assignment,
            };
            let point = |h: &Hyperparameters| {
                let gamma = if args.classifier.uses_gamma() {
                    format!(" gamma {:.5}", h.gamma)
                } else {
                    String::new()
                };
                format!("C {:.4}{gamma}", h.c)
            };
            // A search takes minutes: each evaluation shows as it finishes.
            let searched = if grid {
                let scale = tmo::slip::model::scale_gamma(features.len());
                let gammas = args.gamma_grid.clone().map_or_else(
                    || [0.1, 0.3, 1.0, 3.0, 10.0].map(|k| k * scale).to_vec(),
                    |g| g.0,
                );
                let bar = super::output::counting_bar("grid", "points");
                let per_c = if args.classifier.uses_gamma() {
                    gammas.len()
                } else {
                    1
                };
                bar.set_length((args.c_grid.0.len() * per_c) as u64);
                let searched = tuning::grid_search_reporting(
                    &ds,
                    &spec,
                    &args.c_grid.0,
                    &gammas,
                    |done, h, f1| {
                        let at = point(h);
                        super::output::detail(
                            &bar,
                            format!("point {done}: {at}: cross-validated macro F1 {f1:.3}"),
                        );
                        bar.set_position(done as u64);
                    },
                );
                bar.finish_and_clear();
                searched
            } else {
                let bar = super::output::counting_bar("search", "evaluations");
                bar.set_length(spec.iterations as u64);
                let mut best_so_far = f64::NEG_INFINITY;
                let searched = tuning::search_reporting(&ds, &spec, |done, h, f1| {
                    best_so_far = best_so_far.max(f1);
                    let at = point(h);
                    super::output::detail(
                        &bar,
                        format!("evaluation {done}: {at}: cross-validated macro F1 {f1:.3}"),
                    );
                    bar.set_message(format!("last: {at} F1 {f1:.3}; best F1 {best_so_far:.3}"));
                    bar.set_position(done as u64);
                });
                bar.finish_and_clear();
                searched
            };
            let (hyper, record) = searched?;
            let best = record
                .evaluations
                .iter()
                .map(|e| e.score)
                .fold(f64::NEG_INFINITY, f64::max);
            let at = point(&hyper)
                .replacen("C ", "C = ", 1)
                .replace(" gamma ", ", gamma = ");
            let n = record.evaluations.len();
            if grid {
                outln!("grid: {n} points, best cross-validated macro F1 {best:.3} at {at}");
            } else {
                outln!("search: {n} evaluations, best cross-validated macro F1 {best:.3} at {at}");
            }
            for (name, value, end) in record.best_on_range_ends() {
                let name_flag = name.to_lowercase();
                if grid {
                    eprintln!("warning: the grid's best {name} ({value:.4}) is its {end} value; the optimum may lie beyond it (extend --{name_flag}-grid)");
                } else {
                    eprintln!("warning: the search's best {name} ({value:.4}) lies at the {end} end of its range; the optimum may lie beyond it (widen --{name_flag}-range)");
                }
            }
            (hyper, Some(record))
        }
    };
    let hyper = Hyperparameters {
        max_iterations: args.max_iterations,
        ..hyper
    };
    let spec = model::TrainSpec {
        kind: args.classifier,
        hyper,
        scope: args.scope,
        features,
        labels,
        downsample: args.labels.downsample_or(TRAIN_DOWNSAMPLE),
        seed: args.labels.seed,
    };
    let held_out = match (&search, args.folds) {
        // a search has cross-validated its choice already, and says so
        (Some(_), _) | (None, 0) => None,
        (None, folds) => cross_validate_fixed(&ds, &args, &spec, folds)?,
    };
    let file = ModelFile::train(&ds, &spec, refs, search)?;
    let unconverged: Vec<String> = file
        .unconverged()
        .into_iter()
        .map(|(sensor, iterations, gap)| {
            format!(
                "the SVM{} stopped at its iteration limit ({iterations} iterations) with an optimality gap of {gap:.4} (converged means below 0.001): its boundary is approximate; a smaller C converges sooner",
                sensor.map_or(String::new(), |s| format!(" of sensor {s}"))
            )
        })
        .collect();
    anyhow::ensure!(
        !args.strict || unconverged.is_empty(),
        "--strict: {}; no model written",
        unconverged.join("; ")
    );
    file.save(&args.out)?;
    for u in &unconverged {
        eprintln!("warning: {u}");
    }
    let fitted: usize = file.models.iter().map(|m| m.training_rows).sum();
    outln!(
        "trained {} ({} scope) on {} trials: {} rows, {} of them fitted (static rows down-sampled to {}), in {:.2} s",
        args.classifier.name(),
        args.scope.name(),
        file.training_trials.len(),
        ds.len(),
        fitted,
        args.labels.downsample_or(TRAIN_DOWNSAMPLE),
        started.elapsed().as_secs_f64()
    );
    if let Some(folds) = &held_out {
        print_held_out(folds)?;
    }
    outln!("scores on the fitted rows (training data; `tmo evaluate` scores held-out trials):");
    for m in &file.models {
        let label = m
            .sensor
            .map_or("global".to_string(), |s| format!("sensor {s}"));
        print_scores(&label, &m.training_scores)?;
    }
    outln!("wrote {}", args.out.display());
    Ok(())
}

/// Each fold's scores when trained on the others (by trial) with `spec`'s settings, or
/// `None` (and a note) when the library says the folds cannot be made (too few trials, or
/// fewer than 2 folds).
fn cross_validate_fixed(
    ds: &Dataset,
    args: &TrainArgs,
    spec: &model::TrainSpec,
    folds: usize,
) -> Result<Option<Vec<tmo::slip::metrics::Scores>>> {
    let tune = TuneSpec {
        kind: spec.kind,
        scope: spec.scope,
        downsample: spec.downsample,
        seed: spec.seed,
        iterations: 0,
        folds,
        ranges: tuning::SearchRanges {
            c: args.c_range,
            gamma: args.gamma_range,
        },
        max_fit_rows: None,
        // What the model will meet: every row of unseen trials.
        held_out: tuning::HeldOutRows::Every,
        assignment: args.fold_assignment,
    };
    let bar = super::output::progress_bar("cross-validating by trial {spinner} {elapsed}");
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let scores = tuning::cross_validate(ds, &tune, spec.hyper);
    bar.finish_and_clear();
    match scores {
        Ok(scores) => Ok(Some(scores)),
        Err(e @ (tuning::TuneError::TooFewTrials { .. } | tuning::TuneError::Folds(_))) => {
            super::output::note(format!("note: no held-out score: {e}"));
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// The held-out folds' scores, labelled as such, and a warning for a fold on which the
/// model detects (almost) no slip: such a model scores well on its training rows and never
/// fires on a new trial.
fn print_held_out(folds: &[tmo::slip::metrics::Scores]) -> Result<()> {
    let n = folds.len() as f64;
    let mean = |f: fn(&tmo::slip::metrics::Scores) -> f64| folds.iter().map(f).sum::<f64>() / n;
    let each: Vec<String> = folds.iter().map(|s| format!("{:.3}", s.macro_f1)).collect();
    outln!(
        "held-out scores, cross-validated by trial ({} folds, each scored on every row of its trials by a model trained on the others): macro F1 {:.3} (folds {}), slip precision {:.3}, slip recall {:.3}",
        folds.len(),
        mean(|s| s.macro_f1),
        each.join(", "),
        mean(|s| s.slip.precision),
        mean(|s| s.slip.recall),
    );
    for (k, s) in folds.iter().enumerate() {
        if s.detects_almost_no_slip() {
            eprintln!(
                "warning: on held-out fold {} the model detects almost no slip ({} of {} slip rows): it would miss slips on new trials (a smaller --gamma, or --search bayes, usually helps)",
                k + 1,
                s.confusion.true_slip,
                s.slip.support
            );
        }
    }
    Ok(())
}

pub fn evaluate(args: EvaluateArgs) -> Result<()> {
    // `--out -`: the JSON alone on standard output, as --json gives it
    let json = args.json || args.out.as_deref().is_some_and(super::output::is_stdout);
    let model = tmo::slip::slip_model::SlipModel::load(&args.model)?;
    let (ds, refs, features) = load_dataset(&args.trials, model.labels())?;
    if let Some((what, theirs, ours)) = model.features().mismatch(&features) {
        anyhow::bail!(
            "{}: cannot read these trials: their {what} is {theirs}, the model's {ours}",
            args.model.display()
        );
    }
    if let Some(why) = model.features().rate_differs(&features) {
        eprintln!("warning: {}: {why}", args.model.display());
    }
    let short = model.short_trials(&ds);
    let ds = if short.is_empty() {
        ds
    } else if args.skip_short {
        let names: Vec<&str> = short
            .iter()
            .map(|(t, _)| ds.trial_ids[*t as usize].as_str())
            .collect();
        eprintln!(
            "warning: {}: {} trial(s) shorter than its window of {} frames are not scored (--skip-short): {}",
            args.model.display(),
            short.len(),
            model.window(),
            shortened(&names, 5)
        );
        let skip: std::collections::BTreeSet<u32> = short.iter().map(|(t, _)| *t).collect();
        let kept = ds.filter(|i| !skip.contains(&ds.trial[i]));
        anyhow::ensure!(
            !kept.is_empty(),
            "{}: every trial is shorter than its window of {} frames: nothing to score",
            args.model.display(),
            model.window()
        );
        kept
    } else {
        let why = model.fits_trials(&ds).err().unwrap_or_default();
        anyhow::bail!(
            "{}: {why} ({} trial(s) too short; --skip-short scores the others)",
            args.model.display(),
            short.len()
        );
    };
    let evaluated = model.evaluate(&ds)?;
    if let Some(path) = &args.rows {
        write_row_values(path, &ds, &model.row_values(&ds)?)?;
        super::output::note(format!("wrote every row's value to {}", path.display()));
    }
    let (overall, per_sensor) = (evaluated.overall, evaluated.per_sensor);
    if evaluated.rows_without_window > 0 {
        super::output::note(format!(
            "note: {}: {} of {} rows come before a full window of {} frames of their trial and sensor (or after a dropped frame) and are scored static, as the online loop gives them no class",
            args.model.display(),
            evaluated.rows_without_window,
            ds.len(),
            model.window()
        ));
    }
    let trained_on = model.trained_on(&refs);
    if !trained_on.is_empty() {
        let names: Vec<&str> = trained_on.iter().map(|t| t.trial_id.as_str()).collect();
        eprintln!(
            "warning: {}: {} of these {} trials are among its training trials ({}): their scores are on training data, not held out",
            args.model.display(),
            trained_on.len(),
            refs.len(),
            shortened(&names, 5)
        );
    }
    let unseen = model.unseen_sensors(&ds.sensors());
    if !unseen.is_empty() {
        super::output::note(format!(
            "note: {}: a global model trained on sensors {:?} also scores sensor(s) {:?}, which it never saw: their scores measure how it generalises",
            args.model.display(),
            model.sensors(),
            unseen
        ));
    }
    if !json {
        outln!(
            "{}: {} ({} scope) on {} rows",
            model.name(&args.model),
            model.classifier_name(),
            model.scope().name(),
            ds.len()
        );
        print_scores("overall", &overall)?;
        for (s, scores) in &per_sensor {
            print_scores(&format!("sensor {s}"), scores)?;
        }
    }
    if args.out.is_none() && !json {
        return Ok(());
    }
    let evaluation = tmo::slip::evaluation::Evaluation::of(
        &args.model,
        &model,
        refs.len(),
        ds.len(),
        overall,
        per_sensor,
    )?;
    let text = serde_json::to_string_pretty(&evaluation)?;
    let out = args.out.as_ref().filter(|o| !super::output::is_stdout(o));
    if json {
        outln!("{text}");
    }
    if let Some(out) = out {
        tmo::output::atomic::write_atomic(out, text.as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
        // standard output holds the JSON alone when --json asks for it
        if json {
            super::output::note(format!("wrote {}", out.display()));
        } else {
            outln!("wrote {}", out.display());
        }
    }
    Ok(())
}

/// `names` joined by commas, the first `at_most` of them and how many more.
fn shortened(names: &[&str], at_most: usize) -> String {
    let shown = names[..names.len().min(at_most)].join(", ");
    match names.len().saturating_sub(at_most) {
        0 => shown,
        more => format!("{shown} and {more} more"),
    }
}
