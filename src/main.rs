//! The `tmo` command line. Exit codes: 0 success, 2 error (bad input or a failed run).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use tmo::collect::{self, CollectRig, CollectSpec};
use tmo::scenario::Devices;
use tmo::sim_presets::{self, Preset, PresetOptions};
use tmo::slip::dataset::{Dataset, LabelSpec, Scope};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo::slip::metrics::Scores;
use tmo::slip::model::{self, ClassifierKind, Hyperparameters, ModelFile, TrialRef};
use tmo::slip::tuning::{self, TuneSpec};
use tmo::trace;
use tmo::trial::{load_trials, TrialMeta};
use tmo_hal::sim::{FaultRates, ObjectLibrary, SimConfig, SimRig};

#[derive(Parser)]
#[command(
    name = "tmo",
    version,
    about = "Tactile slip-detection experiments on the Tactile Model O hand"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The simulated rig.
    #[command(subcommand)]
    Sim(SimCommand),
    /// Labelled feature data from recorded trials.
    #[command(subcommand)]
    Dataset(DatasetCommand),
    /// Trains a slip classifier on recorded trials and writes a model file.
    Train(TrainArgs),
    /// Scores a model on recorded trials (never down-sampled).
    Evaluate(EvaluateArgs),
}

#[derive(Subcommand)]
enum DatasetCommand {
    /// Writes features, labels and trial/sensor/frame ids as CSV (for pandas or scikit-learn).
    Export(ExportArgs),
}

/// How frames are labelled and sampled.
#[derive(clap::Args, Clone)]
struct LabelArgs {
    /// Frames labelled slip after the marker onset.
    #[arg(long, default_value_t = 13)]
    n_slip: usize,
    /// Proportion of static frames kept (slip frames are never dropped).
    #[arg(long, default_value_t = 0.4)]
    downsample: f64,
    /// Fall below the held height that marks slip onset, mm.
    #[arg(long, default_value_t = 1.0)]
    onset_threshold_mm: f64,
    /// Seed of the down-sampling.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(clap::Args)]
struct ExportArgs {
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    #[command(flatten)]
    labels: LabelArgs,
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args)]
struct TrainArgs {
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    #[arg(long, value_enum, default_value = "svm-rbf")]
    classifier: ClassifierKind,
    #[arg(long, value_enum, default_value = "global")]
    scope: Scope,
    #[command(flatten)]
    labels: LabelArgs,
    /// Regularisation C (SVM, logistic regression).
    #[arg(long = "C", default_value_t = 3.989)]
    c: f64,
    /// RBF kernel width gamma.
    #[arg(long, default_value_t = 1.104)]
    gamma: f64,
    /// Find C (and gamma) by Bayesian optimisation of cross-validated macro F1 instead.
    #[arg(long, value_enum, default_value = "none")]
    search: SearchMethod,
    /// Evaluations of the search.
    #[arg(long, default_value_t = 20)]
    iters: usize,
    /// Cross-validation folds (split by trial) of the search.
    #[arg(long, default_value_t = 3)]
    folds: usize,
    #[arg(long)]
    out: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SearchMethod {
    None,
    Bayes,
}

#[derive(clap::Args)]
struct EvaluateArgs {
    model: PathBuf,
    /// Trial logs (.mcap) or directories of them.
    #[arg(required = true)]
    trials: Vec<PathBuf>,
}

#[derive(Subcommand)]
enum SimCommand {
    /// Runs one simulated scenario and writes its physics, pins and markers as CSV.
    Trace(TraceArgs),
    /// Lists the object library.
    Objects,
    /// Records collect-mode trials (no reaction to slip) as training data.
    Collect(CollectArgs),
}

#[derive(clap::Args)]
struct CollectArgs {
    /// Which rig: whole-hand release or the single-finger slip rail.
    #[arg(long, value_enum, default_value = "hand")]
    rig: CollectRig,
    /// Number of trials.
    #[arg(long, default_value_t = 20)]
    trials: u64,
    /// Objects, used in turn (default: the paper's five training objects, or the rail object).
    #[arg(long, value_delimiter = ',')]
    objects: Vec<String>,
    /// Grasp angles in degrees, each used for a full round of objects.
    #[arg(long, value_delimiter = ',', default_value = "0,180")]
    grasps: Vec<f64>,
    /// Batch seed; trial i uses seed * 1000003 + i.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulator parameters (TOML); the rig is set by --rig.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory; trials already there are kept and not run again.
    #[arg(long, default_value = "trials/collect")]
    out: PathBuf,
}

#[derive(clap::Args)]
struct TraceArgs {
    /// What to simulate.
    #[arg(long, value_enum)]
    scenario: Preset,
    /// Object from the library (`tmo sim objects`); default crisps_can, or rail_object on the rail.
    #[arg(long)]
    object: Option<String>,
    /// Hand roll, degrees (the paper uses 0 and 180).
    #[arg(long, default_value_t = 0.0)]
    grasp_deg: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulated seconds.
    #[arg(long, default_value_t = 5.0)]
    duration: f64,
    /// Rail retraction speed, mm/s (the paper draws it from 0.1..5).
    #[arg(long, default_value_t = 2.0)]
    retract_speed: f64,
    /// Rice poured per second in the pour scenario, g/s.
    #[arg(long, default_value_t = 40.0)]
    pour_rate: f64,
    /// Simulator parameters (TOML, the fields of `sim.toml` in a trace); the scenario sets the rig.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Turn off sensor faults (mis-detected pins, dropped and stale frames).
    #[arg(long)]
    no_faults: bool,
    /// Output directory.
    #[arg(long, default_value = "results/trace")]
    out: PathBuf,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Sim(SimCommand::Objects) => {
            println!(
                "{:<16} {:>6} {:>9} {:>10} {:>5} {:>5} {:>8}",
                "name", "ycb", "mass_g", "width_mm", "mu_s", "mu_k", "k_N/mm"
            );
            for o in ObjectLibrary::built_in().iter() {
                println!(
                    "{:<16} {:>6} {:>9.1} {:>10.1} {:>5.2} {:>5.2} {:>8.1}",
                    o.name,
                    o.ycb_id.as_deref().unwrap_or("-"),
                    o.mass_g,
                    o.width_mm,
                    o.mu_static,
                    o.mu_kinetic,
                    o.stiffness_n_per_mm
                );
            }
            Ok(())
        }
        Command::Sim(SimCommand::Trace(args)) => sim_trace(args),
        Command::Sim(SimCommand::Collect(args)) => sim_collect(args),
        Command::Dataset(DatasetCommand::Export(args)) => dataset_export(args),
        Command::Train(args) => train(args),
        Command::Evaluate(args) => evaluate(args),
    }
}

fn load_sim_config(path: &Path) -> Result<SimConfig> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

fn sim_trace(args: TraceArgs) -> Result<()> {
    anyhow::ensure!(
        args.duration > 0.0 && args.duration <= 600.0,
        "--duration must be in (0, 600] s, got {}",
        args.duration
    );
    let mut base = match &args.config {
        Some(p) => load_sim_config(p)?,
        None => SimConfig::default(),
    };
    base.seed = args.seed;
    if args.no_faults {
        base.faults = FaultRates::none();
    }
    let options = PresetOptions {
        object: args.object.clone(),
        grasp_deg: args.grasp_deg,
        retract_speed_mm_s: args.retract_speed,
        pour_rate_g_per_s: args.pour_rate,
    };
    let (config, script) = sim_presets::build(args.scenario, &options, base)?;
    let rig = SimRig::new(config.clone()).with_context(|| match &args.config {
        Some(p) => format!("invalid simulator configuration in {}", p.display()),
        None => "invalid simulator configuration".to_string(),
    })?;
    let probe = rig.probe();
    let mut devices = Devices {
        clock: rig.clock(),
        hand: rig.hand(),
        arm: rig.arm(),
        markers: rig.marker_tracker(),
        sensors: rig.tactile_sensors(),
    };
    let mut truth = Vec::new();
    let wall = std::time::Instant::now();
    let recording = devices.run(script, args.duration, |_| truth.push(probe.state()))?;
    let elapsed = wall.elapsed().as_secs_f64();
    let files = trace::write_trace(
        &args.out,
        &config,
        &truth,
        &recording.frames,
        &recording.markers,
    )?;

    let events = probe.events();
    let times = |v: &[f64]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter()
                .map(|t| format!("{t:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let last = truth.last().cloned().unwrap_or_default();
    println!(
        "scenario {:?}, seed {}, {:.1} s simulated in {:.2} s",
        args.scenario, args.seed, args.duration, elapsed
    );
    println!("  slip onsets (s):  {}", times(&events.slip_onsets_s));
    println!("  catches (s):      {}", times(&events.catches_s));
    println!(
        "  dropped at (s):   {}",
        events.drop_s.map_or("no".into(), |t| format!("{t:.3}"))
    );
    println!(
        "  object height:    {:.1} mm at the end (started {:.1} mm)",
        last.object_mm,
        truth.first().map_or(0.0, |t| t.object_mm)
    );
    println!(
        "  frames: {}, marker samples: {}",
        recording.frames.len(),
        recording.markers.len()
    );
    println!(
        "wrote {}, {}, {}, {}",
        files.truth.display(),
        files.pins.display(),
        files.markers.display(),
        files.config.display()
    );
    Ok(())
}

fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

fn sim_collect(args: CollectArgs) -> Result<()> {
    anyhow::ensure!(args.trials > 0, "--trials must be at least 1");
    anyhow::ensure!(!args.grasps.is_empty(), "--grasps needs at least one angle");
    let objects = if !args.objects.is_empty() {
        args.objects.clone()
    } else {
        match args.rig {
            CollectRig::Hand => [
                "crisps_can",
                "windex_bottle",
                "bleach_bottle",
                "mustard_bottle",
                "banana",
            ]
            .map(String::from)
            .to_vec(),
            CollectRig::Rail => vec!["rail_object".to_string()],
        }
    };
    let library = ObjectLibrary::built_in();
    for o in &objects {
        library.get(o).with_context(|| "--objects")?;
    }
    let base = match &args.config {
        Some(p) => load_sim_config(p)?,
        None => SimConfig::default(),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let bar = indicatif::ProgressBar::new(args.trials);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix} [{bar:30}] {pos}/{len} trials, {elapsed} (eta {eta})",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_prefix("collect");
    let (mut ran, mut kept) = (0, 0);
    for i in 0..args.trials {
        let trial_id = format!("trial-{i:04}");
        let path = args.out.join(format!("{trial_id}.mcap"));
        if path.exists() {
            kept += 1;
            bar.inc(1);
            continue;
        }
        let n = objects.len() as u64;
        let spec = CollectSpec {
            rig: args.rig,
            object: objects[(i % n) as usize].clone(),
            grasp_deg: args.grasps[((i / n) % args.grasps.len() as u64) as usize],
            seed: collect::trial_seed(args.seed, i),
            base: base.clone(),
        };
        let trial = collect::collect_trial(&spec, &trial_id, unix_now())
            .with_context(|| format!("trial {trial_id}"))?;
        tmo::trial::write_trial(&path, &trial)?;
        ran += 1;
        bar.inc(1);
    }
    bar.finish_and_clear();
    println!(
        "collected {ran} trials ({kept} already there) in {}",
        args.out.display()
    );
    Ok(())
}

fn label_spec(args: &LabelArgs) -> Result<LabelSpec> {
    anyhow::ensure!(args.n_slip >= 1, "--n-slip must be at least 1");
    anyhow::ensure!(
        args.downsample > 0.0 && args.downsample <= 1.0,
        "--downsample must be in (0, 1], got {}",
        args.downsample
    );
    anyhow::ensure!(
        args.onset_threshold_mm > 0.0,
        "--onset-threshold-mm must be positive"
    );
    Ok(LabelSpec {
        n_slip: args.n_slip,
        onset: OnsetSpec {
            drop_threshold_mm: args.onset_threshold_mm,
            ..Default::default()
        },
    })
}

/// Loads trials and builds their labelled rows; all trials must have the same pin count.
fn load_dataset(
    paths: &[PathBuf],
    labels: &LabelSpec,
) -> Result<(Dataset, Vec<TrialRef>, FeatureSpec)> {
    let loaded = load_trials(paths)?;
    anyhow::ensure!(
        !loaded.is_empty(),
        "no trial logs (.mcap) found in {}",
        paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let pins = loaded[0].2.meta.pins;
    for (path, _, t) in &loaded {
        anyhow::ensure!(
            t.meta.pins == pins,
            "{}: {} pins per sensor, but {} has {pins}",
            path.display(),
            t.meta.pins,
            loaded[0].0.display()
        );
    }
    let features = FeatureSpec::new(pins);
    let refs = loaded
        .iter()
        .map(|(p, h, t)| TrialRef {
            trial_id: t.meta.trial_id.clone(),
            path: p.display().to_string(),
            sha256: h.clone(),
        })
        .collect();
    let trials: Vec<_> = loaded.into_iter().map(|(_, _, t)| t).collect();
    let ds = Dataset::from_trials(&trials, &features, labels);
    if !ds.trials_without_onset.is_empty() {
        eprintln!(
            "note: no slip onset in the marker track of {} trial(s): {}",
            ds.trials_without_onset.len(),
            ds.trials_without_onset.join(", ")
        );
    }
    Ok((ds, refs, features))
}

fn dataset_export(args: ExportArgs) -> Result<()> {
    let labels = label_spec(&args.labels)?;
    let (ds, _, _) = load_dataset(&args.trials, &labels)?;
    let ds = ds.downsample_static(args.labels.downsample, args.labels.seed);
    ds.write_csv(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!(
        "wrote {} rows ({} static, {} slip) to {}",
        ds.len(),
        ds.count(tmo::slip::Class::Static),
        ds.count(tmo::slip::Class::Slip),
        args.out.display()
    );
    Ok(())
}

fn print_scores(label: &str, s: &Scores) {
    let c = &s.confusion;
    println!(
        "{label:<10} macro F1 {:.3} | slip P {:.3} R {:.3} F1 {:.3} | static P {:.3} R {:.3} F1 {:.3} | TP {} FP {} TN {} FN {}",
        s.macro_f1, s.slip.precision, s.slip.recall, s.slip.f1, s.static_.precision, s.static_.recall, s.static_.f1,
        c.true_slip, c.false_slip, c.true_static, c.false_static
    );
}

fn train(args: TrainArgs) -> Result<()> {
    let labels = label_spec(&args.labels)?;
    let (ds, refs, features) = load_dataset(&args.trials, &labels)?;
    let started = std::time::Instant::now();
    let (hyper, search) = match args.search {
        SearchMethod::None => (
            Hyperparameters {
                c: args.c,
                gamma: args.gamma,
            },
            None,
        ),
        SearchMethod::Bayes => {
            anyhow::ensure!(
                args.classifier != ClassifierKind::Threshold,
                "--search bayes: the threshold classifier has no hyperparameters"
            );
            let spec = TuneSpec {
                kind: args.classifier,
                scope: args.scope,
                downsample: args.labels.downsample,
                seed: args.labels.seed,
                iterations: args.iters,
                folds: args.folds,
            };
            let (hyper, record) = tuning::search(&ds, &spec)?;
            let best = record
                .evaluations
                .iter()
                .map(|e| e.score)
                .fold(f64::NEG_INFINITY, f64::max);
            println!("search: {} evaluations, best cross-validated macro F1 {best:.3} at C = {:.4}, gamma = {:.5}", record.evaluations.len(), hyper.c, hyper.gamma);
            (hyper, Some(record))
        }
    };
    let models = model::train_models(
        &ds,
        args.classifier,
        hyper,
        args.scope,
        args.labels.downsample,
        args.labels.seed,
    )?;
    let (tmo_version, git_revision) = TrialMeta::code_version();
    let file = ModelFile {
        format: model::MODEL_FORMAT.into(),
        version: model::MODEL_FORMAT_VERSION,
        classifier: args.classifier,
        hyperparameters: hyper,
        features,
        labels,
        downsample: args.labels.downsample,
        seed: args.labels.seed,
        scope: args.scope,
        sensors: ds.sensors(),
        models,
        training_trials: refs,
        search,
        tmo_version,
        git_revision,
    };
    file.save(&args.out)?;
    println!(
        "trained {} ({:?} scope) on {} trials, {} rows, in {:.2} s",
        args.classifier.name(),
        args.scope,
        file.training_trials.len(),
        ds.len(),
        started.elapsed().as_secs_f64()
    );
    for m in &file.models {
        let label = m
            .sensor
            .map_or("global".to_string(), |s| format!("sensor {s}"));
        print_scores(&label, &m.training_scores);
    }
    println!("wrote {}", args.out.display());
    Ok(())
}

fn evaluate(args: EvaluateArgs) -> Result<()> {
    let model = ModelFile::load(&args.model)?;
    let (ds, _, features) = load_dataset(&args.trials, &model.labels)?;
    anyhow::ensure!(
        features == model.features,
        "{}: the trials have {} pins, the model expects {}",
        args.model.display(),
        features.pins,
        model.features.pins
    );
    let (overall, per_sensor) = model.evaluate(&ds)?;
    println!(
        "{} ({:?} scope) on {} rows",
        model.classifier.name(),
        model.scope,
        ds.len()
    );
    print_scores("overall", &overall);
    for (s, scores) in &per_sensor {
        print_scores(&format!("sensor {s}"), scores);
    }
    Ok(())
}
