//! `tmo import csv FILE... --out DIR`: other sensors' recordings into trial logs.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Result};
use tmo::import::{log_path, read_interchange, ImportOptions, Units};

#[derive(clap::Subcommand)]
pub enum ImportCommand {
    /// Recordings in the interchange CSV (docs/formats.md) into one trial log per trial.
    Csv(CsvArgs),
}

#[derive(clap::Args)]
pub struct CsvArgs {
    /// Interchange CSV files: one row per element per frame (`trial, sensor, frame, t_s,
    /// element, x, y` and one label source).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Directory for the logs, one `<trial>.mcap` per trial (a split's trials in DIR/<split>/).
    #[arg(long, value_parser = super::output::a_dir)]
    out: PathBuf,
    /// What the sensor is (e.g. xela-uskin-4x4), recorded with every trial.
    #[arg(long, default_value = "unnamed")]
    sensor_name: String,
    /// Units of the x and y columns.
    #[arg(long, value_enum, default_value_t = Units::Px)]
    units: Units,
    /// Column naming each trial's split (e.g. train, test): its trials go into DIR/<split>/.
    #[arg(long)]
    split_column: Option<String>,
    /// Largest per-frame step of an element that is a measurement, in --units; a bigger step
    /// counts as a lost element (tmo's pin tracker uses 20 px). Default: no limit.
    #[arg(long)]
    max_step: Option<f64>,
    /// The file's own names of interchange columns, as NAME=THEIRS pairs separated by commas
    /// (e.g. element=taxel,trial=run); the flag may be given more than once.
    #[arg(long, value_name = "NAME=THEIRS,...")]
    columns: Vec<String>,
    /// Element indices count from 1 in the file (the importer says so when it sees it).
    #[arg(long)]
    one_based: bool,
    /// Drop frames whose readings repeat the previous frame's exactly (a sensor slower than
    /// the log that recorded it) and number the rest anew; the count is said.
    #[arg(long, conflicts_with = "keep_repeats")]
    dedupe: bool,
    /// Import frames that repeat the previous frame's readings as they are (without it, an
    /// import in which more than a tenth of the frames repeat is refused before anything is
    /// written, naming --dedupe and this flag).
    #[arg(long)]
    keep_repeats: bool,
}

/// This command as the user gave it, with `flag` added: what to run instead.
fn command_with(flag: &str) -> String {
    let words: Vec<String> = std::iter::once("tmo".to_string())
        .chain(std::env::args().skip(1))
        .chain(std::iter::once(flag.to_string()))
        .collect();
    // arguments from the OS hold no NUL byte, the one thing a shell cannot quote
    shlex::try_join(words.iter().map(String::as_str)).unwrap_or_else(|_| words.join(" "))
}

/// `--columns element=taxel,trial=run` as interchange name -> the file's name.
fn column_map(given: &[String]) -> Result<BTreeMap<String, String>> {
    let mut map = BTreeMap::new();
    for pair in given.iter().flat_map(|g| g.split(',')) {
        let Some((ours, theirs)) = pair.split_once('=') else {
            bail!("--columns `{pair}`: expected NAME=THEIRS (e.g. element=taxel)");
        };
        let (ours, theirs) = (ours.trim(), theirs.trim());
        if ours.is_empty() || theirs.is_empty() {
            bail!("--columns `{pair}`: expected NAME=THEIRS with both names given");
        }
        if map.insert(ours.to_string(), theirs.to_string()).is_some() {
            bail!("--columns names `{ours}` twice");
        }
    }
    Ok(map)
}

pub fn run(command: ImportCommand) -> Result<()> {
    let ImportCommand::Csv(args) = command;
    if let Some(m) = args.max_step {
        if !(m.is_finite() && m > 0.0) {
            bail!("--max-step {m}: expected a positive number");
        }
    }
    let opts = ImportOptions {
        sensor_name: args.sensor_name,
        units: args.units,
        split_column: args.split_column,
        max_step: args.max_step,
        columns: column_map(&args.columns)?,
        one_based: args.one_based,
        dedupe: args.dedupe,
    };
    // Every file is read and checked before anything is written: nothing half-imported.
    let mut trials = Vec::new();
    let mut seen: BTreeMap<String, PathBuf> = BTreeMap::new();
    for file in &args.files {
        let summary = read_interchange(file, &opts)?;
        if !summary.ignored_columns.is_empty() {
            super::output::note(format!(
                "{}: columns not used: {}",
                file.display(),
                summary.ignored_columns.join(", ")
            ));
        }
        for t in summary.trials {
            let path = log_path(&args.out, &t);
            if let Some(other) = seen.insert(path.display().to_string(), file.clone()) {
                bail!(
                    "{}: trial `{}` would be written to {}, as a trial of {} is",
                    file.display(),
                    t.name,
                    path.display(),
                    other.display()
                );
            }
            if path.exists() {
                bail!(
                    "{} already exists: import into an empty directory (or remove it)",
                    path.display()
                );
            }
            trials.push((path, t));
        }
    }
    let Some((_, first)) = trials.first() else {
        bail!("no trials in the given files");
    };
    let imported: Vec<_> = trials.iter().map(|(_, t)| t.clone()).collect();
    if !opts.dedupe && !args.keep_repeats {
        if let Some(why) = tmo::import::too_many_repeats(&imported) {
            bail!(
                "{why}; nothing was written. Drop them and number the rest anew:\n  {}\nor import them as they are:\n  {}",
                command_with("--dedupe"),
                command_with("--keep-repeats")
            );
        }
    }
    let (warnings, notes) = tmo::import::import_notes(&imported, opts.dedupe);
    for w in warnings {
        eprintln!("warning: {w}");
    }
    for n in notes {
        super::output::note(n);
    }
    let bar = super::output::counting_bar("importing", "trials");
    bar.set_length(trials.len() as u64);
    let mut splits: BTreeMap<String, usize> = BTreeMap::new();
    for (k, (path, t)) in trials.iter().enumerate() {
        if let Err(e) = tmo::trial::write_trial(path, &t.trial) {
            bar.finish_and_clear();
            // The logs are made from the CSV, which is untouched: a half import is only
            // in the way of the next try, so it goes.
            for (written, _) in &trials[..k] {
                let _ = std::fs::remove_file(written);
            }
            bail!(
                "importing trial `{}`: {e}; nothing was imported (the {k} log(s) written before it were removed): run the same command again",
                t.name
            );
        }
        *splits
            .entry(t.split.clone().unwrap_or_default())
            .or_default() += 1;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let p = &first.trial.meta.parameters;
    let get = |k: &str| p.get(k).map_or("", String::as_str);
    // tmo numbers sensors from 0 (train, evaluate and replay say "sensor 0"); the file's
    // own names are mapped to those numbers here, once.
    let numbered: Vec<String> = get("sensor_names")
        .split(',')
        .filter(|n| !n.is_empty())
        .enumerate()
        .map(|(k, name)| format!("{k} = {name}"))
        .collect();
    outln!(
        "{} trial(s): {} sensor(s) (as tmo numbers them: {}) of {} elements, {}, {}, labels from the {}",
        trials.len(),
        first.trial.meta.sensors,
        numbered.join(", "),
        first.trial.meta.pins,
        get("units"),
        tmo::import::rate_summary(&imported),
        get("label_source")
    );
    for (split, n) in &splits {
        let dir = if split.is_empty() {
            args.out.clone()
        } else {
            log_path(
                &args.out,
                &trials
                    .iter()
                    .find(|t| t.1.split.as_deref() == Some(split))
                    .expect("counted")
                    .1,
            )
            .parent()
            .expect("a log has a folder")
            .to_path_buf()
        };
        outln!("  {n} trial log(s) in {}", dir.display());
    }
    // The paper's C and gamma were chosen for TacTip pins; another sensor's are its own.
    let train_dir = if splits.contains_key("train") {
        args.out.join("train")
    } else {
        args.out.clone()
    };
    super::output::note(format!(
        "next: search this sensor's classifier settings, e.g. `tmo train {} --search grid --out model.json` (cross-validated by trial)",
        train_dir.display()
    ));
    Ok(())
}
