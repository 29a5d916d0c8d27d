//! `tmo replay TRIALS... --model M... [--strategy 1Fr2Sen,2Fr2Sen] [--out DIR]`: what each model
//! and strategy would have done on recorded trials.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result};
use rayon::prelude::*;
use tmo::online::strategy::Strategy;
use tmo::outcome::CatchSpec;
use tmo::replay::{evaluate, ModelRef, ReplayOutcome, ReplayVerdict};
use tmo::report::{Cell, Table};
use tmo::slip::slip_model::SlipModel;
use tmo::trial::{expand_trial_paths, read_trial_bytes, sha256_hex, Trial};

/// Exit code when the replay finished but some trial logs could not be read.
pub const EXIT_SKIPPED: u8 = 3;

#[derive(clap::Args)]
pub struct ReplayArgs {
    /// Trial logs (.mcap) or directories of them (a batch directory works).
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// Models to compare: model files from `tmo train` or ONNX models (`.onnx`, docs/onnx.md);
    /// none with --live (the trials are played, not replayed).
    #[arg(long = "model", required_unless_present = "live", num_args = 1..)]
    models: Vec<PathBuf>,
    /// Strategies as NFrMSen (or the short NxM), comma-separated (default: the paper's six; those needing
    /// more sensors than a trial has are left out for it).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1Fr1Sen,2Fr1Sen,1Fr2Sen,2Fr2Sen,1Fr3Sen,2Fr3Sen"
    )]
    strategy: Vec<String>,
    /// Also write replay.csv (one line per trial, model and strategy) and replay.md here.
    #[arg(long, value_parser = super::output::a_dir)]
    out: Option<PathBuf>,
    /// Print the table and every replay's outcome as JSON instead of as text.
    #[arg(long)]
    json: bool,
    /// First play each trial log to a Foxglove viewer at wall-clock speed (every channel as
    /// recorded), served at ADDR (default 127.0.0.1:8765; port 0 picks a free one) over the
    /// Foxglove WebSocket protocol. Ctrl-C skips to the replay's table.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    live: Option<std::net::SocketAddr>,
    /// With --live: before the first trial, wait up to SECONDS for a viewer to subscribe
    /// (without one by then, the trials play anyway, saying so).
    #[arg(long, requires = "live", value_name = "SECONDS", value_parser = super::live::parse_wait)]
    live_wait: Option<f64>,
    /// Also write every frame's slip value and class, for each model, to this CSV (model,
    /// trial_id, sensor, seq, time_s, value, class): every frame of every trial through the
    /// online loop's own classifier, not only those before a replay's reaction.
    #[arg(long, value_name = "FILE.csv")]
    rows: Option<PathBuf>,
}

fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    // nearest rank, as a reader would count it off a list
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    Some(sorted[rank - 1])
}

fn table(rows: &[ReplayOutcome]) -> Table {
    let mut t = Table::new(
        "replay",
        "Replay: what each model and strategy would have done",
        &[
            "model",
            "strategy",
            "trials",
            "detected",
            "FP",
            "missed",
            "no slip",
            "undetermined",
            "latency median (ms)",
            "latency p90 (ms)",
            "latency median (frames)",
            "same as logged",
        ],
    );
    let mut cells: BTreeMap<(String, String), Vec<&ReplayOutcome>> = BTreeMap::new();
    for r in rows {
        cells
            .entry((r.model.clone(), r.strategy.clone()))
            .or_default()
            .push(r);
    }
    for ((model, strategy), rs) in cells {
        let n = |v: ReplayVerdict| rs.iter().filter(|r| r.verdict == v).count() as u64;
        let undetermined = n(ReplayVerdict::AfterLogged) + n(ReplayVerdict::Aborted);
        let determined = rs.len() as u64 - undetermined;
        let rate = |v| Cell::Rate {
            count: n(v),
            trials: determined,
        };
        let detected: Vec<&&ReplayOutcome> = rs
            .iter()
            .filter(|r| r.verdict == ReplayVerdict::Detected)
            .collect();
        let mut ms: Vec<f64> = detected
            .iter()
            .filter_map(|r| r.latency_s)
            .map(|s| 1000.0 * s)
            .collect();
        ms.sort_by(f64::total_cmp);
        let mut frames: Vec<f64> = detected
            .iter()
            .filter_map(|r| r.latency_frames)
            .map(|f| f as f64)
            .collect();
        frames.sort_by(f64::total_cmp);
        let compared: Vec<bool> = rs.iter().filter_map(|r| r.matches_logged).collect();
        t.push(vec![
            Cell::text(model),
            Cell::text(strategy),
            Cell::Count(rs.len() as u64),
            rate(ReplayVerdict::Detected),
            rate(ReplayVerdict::FalsePositive),
            rate(ReplayVerdict::Missed),
            // neither slipped nor reacted: with the three before, every determined trial
            rate(ReplayVerdict::NoSlip),
            Cell::Count(undetermined),
            Cell::number(percentile(&ms, 0.5), 0),
            Cell::number(percentile(&ms, 0.9), 0),
            Cell::number(percentile(&frames, 0.5), 0),
            if compared.is_empty() {
                Cell::Empty
            } else {
                Cell::Rate {
                    count: compared.iter().filter(|m| **m).count() as u64,
                    trials: compared.len() as u64,
                }
            },
        ]);
    }
    t
}

/// Returns whether some trial logs were skipped.
pub fn replay(args: ReplayArgs) -> Result<bool> {
    let strategies: Vec<Strategy> = args
        .strategy
        .iter()
        .map(|s| s.parse().with_context(|| format!("--strategy {s}")))
        .collect::<Result<_>>()?;
    // A strategy named twice would count every trial twice in its cells.
    for (i, s) in strategies.iter().enumerate() {
        anyhow::ensure!(
            !strategies[..i].contains(s),
            "--strategy {}: named more than once (each strategy is replayed once)",
            args.strategy[i]
        );
    }
    replay_with(
        &args.trials,
        &args.models,
        &strategies,
        ReplayOutputs {
            dir: args.out.as_deref(),
            json: args.json,
            rows: args.rows.as_deref(),
        },
        args.live.map(|addr| super::live::LiveArgs {
            addr,
            wait_s: args.live_wait,
        }),
    )
}

/// Where a replay's results go besides the table on standard output.
#[derive(Clone, Copy, Default)]
pub struct ReplayOutputs<'a> {
    /// replay.csv and replay.md.
    pub dir: Option<&'a std::path::Path>,
    /// The table and outcomes as JSON instead of text.
    pub json: bool,
    /// Every frame's value per model (`--rows`).
    pub rows: Option<&'a std::path::Path>,
}

/// Every classifiable frame of every trial through every model, as CSV at `path`.
fn write_frame_values(
    path: &std::path::Path,
    trials: &[(String, Trial)],
    models: &[(String, String, SlipModel)],
) -> Result<()> {
    let mut w = super::output::atomic_csv(path)?;
    w.write_record([
        "model", "trial_id", "sensor", "seq", "time_s", "value", "class",
    ])?;
    for (name, _, model) in models {
        let per_trial: Vec<Vec<tmo::online::classify::FrameValue>> = trials
            .par_iter()
            .map(|(tpath, t)| {
                tmo::online::classify::frame_values(model, usize::from(t.meta.sensors), &t.frames)
                    .with_context(|| format!("{name} on {tpath}"))
            })
            .collect::<Result<_>>()?;
        for ((_, t), values) in trials.iter().zip(per_trial) {
            for v in values {
                w.write_record([
                    name.clone(),
                    t.meta.trial_id.clone(),
                    v.sensor.to_string(),
                    v.seq.to_string(),
                    format!("{:.6}", v.time_s),
                    // shortest text that reads back as the same f32
                    v.value.to_string(),
                    match v.class {
                        tmo::slip::Class::Slip => "slip",
                        tmo::slip::Class::Static => "static",
                    }
                    .to_string(),
                ])?;
            }
        }
    }
    super::output::commit_csv(w, path)
}

/// Plays every trial to a live view at `live.addr`, one after another at wall-clock speed, until
/// the last one ends or Ctrl-C.
fn play_live(live: super::live::LiveArgs, trials: &[(String, Trial)]) -> Result<()> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let sensors = trials
        .iter()
        .map(|(_, t)| t.meta.sensors)
        .max()
        .unwrap_or(0);
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    let how = "each trial plays at wall-clock speed; Ctrl-C skips to the replay";
    let view = super::live::serve(live, sensors, how, &stop)?;
    for (i, (path, trial)) in trials.iter().enumerate() {
        super::output::note(format!("playing {path} ({}/{})", i + 1, trials.len()));
        if !view.play(trial, &stop) {
            super::output::note("stopped playing; replaying");
            break;
        }
    }
    Ok(())
}

/// The replay of `trials` through every model and strategy; whether some logs were skipped.
pub fn replay_with(
    trial_paths: &[PathBuf],
    model_paths: &[PathBuf],
    strategies: &[Strategy],
    outputs: ReplayOutputs<'_>,
    live: Option<super::live::LiveArgs>,
) -> Result<bool> {
    let ReplayOutputs {
        dir: out,
        json,
        rows: rows_path,
    } = outputs;
    let loaded: Vec<(String, SlipModel)> = model_paths
        .iter()
        .map(|p| {
            let bytes = std::fs::read(p).with_context(|| format!("cannot read {}", p.display()))?;
            Ok((sha256_hex(&bytes), SlipModel::load(p)?))
        })
        .collect::<Result<_>>()?;
    // each model by its name in tables (`tmo.name`, else the file's stem), as `tmo run` names them
    let names = tmo::slip::slip_model::unique_names(
        model_paths
            .iter()
            .map(PathBuf::as_path)
            .zip(loaded.iter().map(|(_, m)| m)),
    );
    let models: Vec<(String, String, SlipModel)> = names
        .into_iter()
        .zip(loaded)
        .map(|(name, (sha256, model))| (name, sha256, model))
        .collect();
    let paths = expand_trial_paths(trial_paths)?;
    anyhow::ensure!(!paths.is_empty(), "no trial logs (.mcap) found");
    // Each log is read once: hashed (a copy or a folder given twice is refused) and parsed.
    let read = paths
        .iter()
        .map(|p| {
            let bytes = tmo::trial::read_log_file(p)?;
            Ok((sha256_hex(&bytes), read_trial_bytes(p, &bytes)))
        })
        .collect::<Result<Vec<_>>>()?;
    tmo::trial::refuse_duplicates(
        paths
            .iter()
            .map(PathBuf::as_path)
            .zip(read.iter().map(|(hash, _)| hash.as_str())),
    )?;
    for ((_, _, m), mpath) in models.iter().zip(model_paths) {
        let mpath = mpath.display();
        let seen = read.iter().filter(|(h, _)| m.trained_on_log(h)).count();
        if seen > 0 {
            eprintln!(
                "warning: {mpath}: {seen} of these {} trial log(s) are among its training trials: its replays of them are not held out",
                read.len()
            );
        }
    }
    // A damaged log is named and skipped; the rest of the set is still evaluated.
    let mut trials: Vec<(String, Trial)> = Vec::new();
    let mut skipped = 0;
    for (p, (_, parsed)) in paths.iter().zip(read) {
        match parsed {
            Ok(t) => match t.unusable() {
                Some(why) => {
                    eprintln!("skipped {}: cannot be used as a trial: {why}", p.display());
                    skipped += 1;
                }
                None => trials.push((p.display().to_string(), t)),
            },
            Err(e) => {
                eprintln!("skipped {}: {e}", p.display());
                skipped += 1;
            }
        }
    }
    anyhow::ensure!(
        !trials.is_empty(),
        "none of the {} trial log(s) could be read (see above)",
        paths.len()
    );
    for (tpath, t) in &trials {
        for ((_, _, m), mpath) in models.iter().zip(model_paths) {
            let mpath = mpath.display();
            if let Err(e) = m.fits(usize::from(t.meta.sensors), t.meta.pins) {
                anyhow::bail!("{mpath} cannot replay {tpath}: {e}");
            }
            // a windowed model never classifies a trial shorter than its window
            let per_sensor = t.frames.len() / usize::from(t.meta.sensors).max(1);
            if let Err(e) = m.fits_frames(per_sensor) {
                anyhow::bail!("{mpath} cannot replay {tpath}: {e}");
            }
            let own = tmo::slip::dataset::trial_features(t)
                .map_err(|e| anyhow::anyhow!("{tpath}: {e}"))?;
            if let Some((what, theirs, ours)) = m.features().mismatch(&own) {
                anyhow::bail!(
                    "{mpath} cannot replay {tpath}: its {what} is {theirs}, the model's {ours}"
                );
            }
            if let Some(why) = m.features().rate_differs(&own) {
                eprintln!("warning: {mpath} on {tpath}: {why}");
            }
        }
    }
    if let Some(live) = live {
        play_live(live, &trials)?;
        if models.is_empty() {
            super::output::note(format!(
                "played {} trial(s); no --model, so nothing was replayed",
                trials.len()
            ));
            return Ok(skipped > 0);
        }
    }
    let mut jobs = Vec::new();
    for (ti, (_, t)) in trials.iter().enumerate() {
        for (mi, _) in models.iter().enumerate() {
            for s in strategies {
                if s.check(u32::from(t.meta.sensors)).is_ok() {
                    jobs.push((ti, mi, *s));
                }
            }
        }
    }
    if let Some(path) = rows_path {
        write_frame_values(path, &trials, &models)?;
        super::output::note(format!("wrote every frame's value to {}", path.display()));
    }
    let spec = CatchSpec::default();
    let bar = super::output::counting_bar("replay", "replays");
    bar.set_length(jobs.len() as u64);
    let started = std::time::Instant::now();
    let rows: Vec<ReplayOutcome> = jobs
        .par_iter()
        .map(|&(ti, mi, s)| {
            let (path, trial) = &trials[ti];
            let (name, sha256, file) = &models[mi];
            let model = ModelRef { name, sha256, file };
            let r =
                evaluate(trial, path, model, s, &spec).with_context(|| format!("replaying {path}"));
            if let Ok(o) = &r {
                super::output::detail(
                    &bar,
                    format!(
                        "{path}: {} {} {}: {}",
                        o.model,
                        o.strategy,
                        o.window,
                        serde_json::to_value(o.verdict)
                            .ok()
                            .and_then(|v| v.as_str().map(str::to_string))
                            .unwrap_or_default()
                    ),
                );
            }
            bar.inc(1);
            r
        })
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    let t = table(&rows);
    let wall_s = started.elapsed().as_secs_f64();
    if !json {
        outln!(
            "{} replays of {} trial(s) x {} model(s) x {} strateg(ies) in {wall_s:.1} s\n",
            rows.len(),
            trials.len(),
            models.len(),
            strategies.len(),
        );
        crate::cli::output::write_out(format_args!("{}", t.markdown()))?;
    }
    let mut outputs = Vec::new();
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let mut w = csv::Writer::from_writer(Vec::new());
        for r in &rows {
            w.serialize(r)?;
        }
        let csv = w.into_inner().map_err(|e| e.into_error())?;
        tmo::output::atomic::write_atomic(&dir.join("replay.csv"), &csv)?;
        tmo::output::atomic::write_atomic(&dir.join("replay.md"), t.markdown().as_bytes())?;
        outputs = vec![dir.join("replay.csv"), dir.join("replay.md")];
        if !json {
            outln!(
                "wrote {} and {}",
                outputs[0].display(),
                outputs[1].display()
            );
        }
    }
    if json {
        let v = serde_json::json!({
            "replays": rows.len(),
            "trials": trials.len(),
            "models": models.len(),
            "strategies": strategies.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
            "skipped": skipped,
            "wall_s": wall_s,
            "table": t,
            "outcomes": rows,
            "outputs": outputs,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
    }
    if skipped > 0 {
        eprintln!("{skipped} trial log(s) skipped (see above); exit code {EXIT_SKIPPED}");
    }
    Ok(skipped > 0)
}
