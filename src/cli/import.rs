//! `tmo import csv FILE... --out DIR`: other sensors' recordings into trial logs.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
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
    #[arg(long)]
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
    let bar = super::output::counting_bar("importing", "trials");
    bar.set_length(trials.len() as u64);
    let mut splits: BTreeMap<String, usize> = BTreeMap::new();
    for (path, t) in &trials {
        tmo::trial::write_trial(path, &t.trial)
            .with_context(|| format!("importing trial `{}`", t.name))?;
        *splits
            .entry(t.split.clone().unwrap_or_default())
            .or_default() += 1;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let Some((_, first)) = trials.first() else {
        bail!("no trials in the given files");
    };
    let p = &first.trial.meta.parameters;
    let get = |k: &str| p.get(k).map_or("", String::as_str);
    outln!(
        "{} trial(s): {} sensor(s) ({}) of {} elements, {}, about {} Hz, labels from the {}",
        trials.len(),
        first.trial.meta.sensors,
        get("sensor_names"),
        first.trial.meta.pins,
        get("units"),
        get("rate_hz"),
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
    Ok(())
}
