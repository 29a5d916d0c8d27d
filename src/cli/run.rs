//! `tmo run PROTOCOL.toml`: a batch of trials, their logs and their outcome table.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use tmo::protocol::{self, Kind};
use tmo::report::inputs::{Batch, Inputs};
use tmo::runner::batch_run::{run_batch, BatchEnd, BatchRequest, BatchRig, BatchSummary};
use tmo::runner::real_trial::{check_real_plan, open_real};
use tmo::runner::staging::Staging;

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
    /// The protocol file (TOML; examples in protocols/).
    protocol: PathBuf,
    /// Where the trials run: the simulator (`mock` is another name for it), recorded trials
    /// (with --from) or the real rig (with --hardware).
    #[arg(long, value_enum, default_value = "sim")]
    backend: Backend,
    /// Batch directory (default results/<protocol name>).
    #[arg(long, value_parser = super::output::a_dir)]
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
    /// With --resume: also run again the trials that ended on a fault (their logs are kept
    /// beside the batch as <id>.faulted-<n>.mcap). Without it a faulted trial is kept: a
    /// fault is an outcome (a refused motion, a device error), and the report counts it.
    #[arg(long, requires = "resume")]
    rerun_faulted: bool,
    /// Run only part K of N of the batch's trials (every N-th), e.g. one cluster job each;
    /// `tmo report` over the N directories joins them. Simulator only.
    #[arg(long, value_name = "K/N")]
    shard: Option<tmo::output::shard::Shard>,
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
    /// Serve the trials live over the Foxglove WebSocket protocol while the batch runs, at
    /// ADDR (default 127.0.0.1:8765; port 0 picks a free one). Simulated trials then run
    /// one at a time, at wall-clock speed; with `--backend replay` the recorded trials play
    /// first, as `tmo replay --live` does.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    live: Option<std::net::SocketAddr>,
    /// With --live: keep serving after the batch ends (the last trial stays in the viewer,
    /// which can still scrub it) until Ctrl-C.
    #[arg(long, requires = "live")]
    live_linger: bool,
    /// With --live: before the first trial, wait up to SECONDS for a viewer to subscribe,
    /// so it sees the first trial from its start (without one by then, the batch starts
    /// anyway, saying so).
    #[arg(long, requires = "live", value_name = "SECONDS", value_parser = super::live::parse_wait)]
    live_wait: Option<f64>,
    /// Print the batch's summary as JSON (counts, the report's tables, the files written)
    /// instead of as text; progress and notes go to standard error.
    #[arg(long)]
    json: bool,
    /// Run a model whose measured cost per frame exceeds its share of the rig's frame period
    /// (refused without this). On the simulator its outcomes do not depend on this machine's
    /// speed; on a real rig its trials fault on their deadline (docs/online.md).
    #[arg(long)]
    allow_slow_model: bool,
}

/// Runs `protocol` on the simulator into `out` as `tmo run PROTOCOL --out OUT [--resume]`
/// does: the path of presets such as `tmo sim collect`.
pub fn run_on_sim(protocol: PathBuf, out: PathBuf, resume: bool) -> Result<u8> {
    run(RunArgs {
        protocol,
        backend: Backend::Sim,
        out: Some(out),
        seed: None,
        repeat: None,
        resume,
        rerun_faulted: false,
        shard: None,
        hardware: None,
        unattended: false,
        from: Vec::new(),
        live: None,
        live_linger: false,
        live_wait: None,
        json: false,
        allow_slow_model: false,
    })
}

/// Runs the batch; the exit code (0, or 3 when a replay skipped damaged logs).
pub fn run(args: RunArgs) -> Result<u8> {
    anyhow::ensure!(
        args.shard.is_none() || args.backend == Backend::Sim,
        "--shard splits simulated batches (--backend sim); a real rig runs its trials in one batch"
    );
    anyhow::ensure!(
        args.backend != Backend::Real || args.hardware.is_some(),
        "--backend real needs --hardware FILE (see hardware/tmo.toml; `tmo sim serve` writes one for the simulator)"
    );
    let mut plan = protocol::load(&args.protocol, 3)?;
    // On the real backend everything that can be refused is, before a device is opened.
    let real_rig = match &args.hardware {
        Some(path) if args.backend == Backend::Real => {
            let hw = tmo::runner::hardware::load(path)?;
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
            super::replay::ReplayOutputs {
                dir: args.out.as_deref(),
                json: args.json,
                rows: None,
            },
            // the recorded trials play to the viewer first, as `tmo replay --live` does
            args.live.map(|addr| super::live::LiveArgs {
                addr,
                wait_s: args.live_wait,
            }),
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
    tmo::runner::batch::check_size(&plan).with_context(|| args.protocol.display().to_string())?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("results").join(
            args.protocol
                .file_stem()
                .map_or("batch".into(), |s| s.to_string_lossy().into_owned()),
        )
    });

    // Ctrl-C: the running trial makes the rig safe and ends; its log is kept as aborted.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;

    // The real rig is opened once for the batch; the simulator builds a rig per trial.
    let mut rig = match real_rig {
        Some((path, hw, staging)) => {
            let rig = open_real(hw, plan.safety)
                .with_context(|| format!("opening the devices of {}", path.display()))?;
            BatchRig::Real {
                staging,
                rig: Box::new(rig),
            }
        }
        None => BatchRig::Sim,
    };
    let live = match args.live {
        Some(addr) => {
            // the hand's three fingertips, or the rail's one
            let sensors = if plan.kind == Kind::RailCatch { 1 } else { 3 };
            let live = super::live::LiveArgs {
                addr,
                wait_s: args.live_wait,
            };
            let how = "simulated trials run one at a time, at wall-clock speed";
            Some(super::live::serve(live, sensors, how, &stop)?)
        }
        None => None,
    };
    let bar = super::output::counting_bar("run", "trials");
    let request = BatchRequest {
        plan: &plan,
        out: &out,
        resume: args.resume,
        rerun_faulted: args.rerun_faulted,
        shard: args.shard,
        live: live.as_ref(),
        on_trial: Some(&|line: &str| super::output::detail(&bar, line)),
        on_warning: Some(&|line: &str| bar.suspend(|| eprintln!("warning: {line}"))),
        on_note: Some(&|line: &str| bar.suspend(|| super::output::note(line))),
        allow_slow_model: args.allow_slow_model,
    };
    let end = run_batch(&request, &mut rig, &stop, &bar).map_err(|e| {
        let resumable = e.is_resumable();
        let e = anyhow::Error::new(e).context(args.protocol.display().to_string());
        if resumable {
            e.context(format!(
                "finished trials are kept in {}; run again with --resume to finish",
                out.display()
            ))
        } else {
            e
        }
    })?;
    bar.finish_and_clear();
    let summary = match end {
        BatchEnd::Finished(s) => *s,
        BatchEnd::Interrupted {
            finished,
            aborted_logs,
            before_trial,
            operator_gone,
        } => {
            anyhow::ensure!(
                !operator_gone,
                "the operator's terminal closed before {before_trial}: {finished} finished trial(s) are in {}; run again with --resume to finish",
                out.display()
            );
            if aborted_logs.is_empty() {
                eprintln!(
                    "interrupted before {before_trial}: {finished} finished trial(s) are in {}; run again with --resume to finish",
                    out.display()
                );
            } else {
                let names: Vec<String> = aborted_logs
                    .iter()
                    .map(|a| a.display().to_string())
                    .collect();
                eprintln!(
                    "interrupted: {finished} finished trial(s) are in {}; {} kept as aborted; run again with --resume to finish",
                    out.display(),
                    names.join(", ")
                );
            }
            std::process::exit(EXIT_INTERRUPTED);
        }
    };
    if args.json {
        outln!(
            "{}",
            serde_json::to_string_pretty(&summary_json(&out, plan.kind, summary)?)?
        );
    } else {
        print_summary(&out, plan.kind, summary)?;
    }
    if let (true, Some(view)) = (args.live_linger, &live) {
        eprintln!(
            "the batch is done; the live view stays at {} until Ctrl-C",
            view.url()
        );
        while !stop.load(std::sync::atomic::Ordering::Relaxed) {
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    }
    Ok(0)
}

/// The batch's own report tables, so `tmo run` and `tmo report` never disagree.
fn batch_tables(out: &Path, kind: Kind, summary: &mut BatchSummary) -> Vec<tmo::report::Table> {
    let timing = std::mem::take(&mut summary.rows.timing);
    let inputs = Inputs {
        batches: vec![Batch {
            dir: out.to_path_buf(),
            manifest: summary.manifest.clone(),
            rows: std::mem::take(&mut summary.rows).into_batch_rows(kind),
            timing,
        }],
        ..Default::default()
    };
    tmo::report::build::tables(&inputs)
}

/// `tmo run --json`: what the text summary says, as one JSON object.
fn summary_json(out: &Path, kind: Kind, mut summary: BatchSummary) -> Result<serde_json::Value> {
    let aborted = summary.rows.aborted();
    let truth = summary.rows.truth_agreement();
    let tables = batch_tables(out, kind, &mut summary);
    let tables: serde_json::Value =
        serde_json::from_str(&tmo::report::render(&tables, tmo::report::Format::Json)?)?;
    Ok(serde_json::json!({
        "kind": kind.to_string(),
        "dir": out,
        "trials": summary.ran + summary.kept,
        "ran": summary.ran,
        "already_there": summary.kept,
        "rerun_faulted": summary.rerun_faulted,
        "aborted": aborted,
        "wall_s": summary.wall_s,
        "truth_agreement": truth.map(|(n, agree)| serde_json::json!({"trials": n, "agree": agree})),
        "without_calibration": summary.without_calibration,
        "tables": tables,
        "outputs": summary.outputs,
    }))
}

/// What `tmo run` prints after a batch: counts, the kind's table, where the files went.
pub fn print_summary(out: &Path, kind: Kind, mut summary: BatchSummary) -> Result<()> {
    outln!(
        "{} trials ({} run, {} already there) in {:.1} s",
        summary.ran + summary.kept,
        summary.ran,
        summary.kept,
        summary.wall_s
    );
    if summary.rerun_faulted > 0 {
        outln!(
            "{} faulted trial(s) run again; their earlier logs are beside the batch as <id>.faulted-<n>.mcap",
            summary.rerun_faulted
        );
    }
    let aborted = summary.rows.aborted();
    if aborted > 0 {
        outln!("{aborted} trial(s) aborted by a fault (see the fault column)");
    }
    if let Some((n, agree)) = summary.rows.truth_agreement() {
        outln!(
            "marker-scored verdicts agree with the simulator's ground truth in {agree} of {n} trials ({:.0} %)",
            100.0 * agree as f64 / n as f64
        );
    }
    let mut outputs: Vec<String> = summary
        .outputs
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    if kind == Kind::CalibrateLift {
        if let Some(g) = outputs.iter_mut().find(|p| p.ends_with("g_min.json")) {
            g.push_str(" (for first_time_lift.calibration)");
        }
    }
    let tables = batch_tables(out, kind, &mut summary);
    if tables.is_empty() {
        outln!("(a collect batch: its outcomes are in the files below)");
    } else {
        crate::cli::output::write_out(format_args!(
            "{}",
            tmo::report::render(&tables, tmo::report::Format::Md)?
        ))?;
    }
    if summary.without_calibration {
        outln!("(no overgrasp: set first_time_lift.calibration to a calibrate_lift batch's g_min.json)");
    }
    outln!(
        "wrote trial logs to {}, and {}",
        out.display(),
        outputs.join(", ")
    );
    Ok(())
}
