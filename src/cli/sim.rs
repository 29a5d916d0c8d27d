//! `tmo sim ...`: the simulated rig from the command line.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Subcommand;
use tmo::protocol::collect::{CollectPreset, CollectRig};
use tmo::runner::devices::Devices;
use tmo::runner::sim_presets::{self, Preset, PresetOptions};
use tmo::trace;
use tmo_sim::{FaultRates, ObjectLibrary, SimConfig, SimRig};

#[derive(Subcommand)]
pub enum SimCommand {
    /// Runs one simulated scenario and writes its physics, pins and markers as CSV.
    Trace(TraceArgs),
    /// Lists the object library.
    Objects,
    /// Lists the simulator's parameters: value, unit, plausible range, where the value
    /// comes from, and the findings it was calibrated against (sim/data/parameters.toml).
    /// A table on a terminal; tab-separated values (every field whole) when piped.
    Parameters(ParametersArgs),
    /// Records collect-mode trials (no reaction to slip) as training data.
    Collect(CollectArgs),
    /// Serves the simulated rig over the real rig's wire protocols (cameras and hand bus on
    /// pseudo-terminals, the UR controller on loopback TCP).
    Serve(super::serve::ServeArgs),
}

#[derive(clap::Args)]
pub struct ParametersArgs {
    /// Tab-separated values with every field whole, also on a terminal.
    #[arg(long)]
    tsv: bool,
}

#[derive(clap::Args)]
pub struct CollectArgs {
    /// Which rig: whole-hand release or the single-finger slip rail.
    #[arg(long, value_enum, default_value = "hand")]
    rig: CollectRig,
    /// Number of trials.
    #[arg(long, default_value_t = 20)]
    trials: u64,
    /// Objects, used in turn (default: the paper's five training objects, or the rail object).
    #[arg(long, value_delimiter = ',')]
    objects: Vec<String>,
    /// Grasp angles in degrees, each used for a full round of objects (default: the 0 deg
    /// grasp the paper trained on; 180 deg is the unseen grasp of the online test).
    #[arg(long, value_delimiter = ',', default_value = "0")]
    grasps: Vec<f64>,
    /// Batch seed; trial i uses seed * 1000003 + i.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulator parameters (TOML); the rig is set by --rig.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory; trials already there are kept and not run again (they must be this
    /// collection's own: another rig, object, grasp or seed is refused).
    #[arg(long, value_parser = super::output::a_dir, default_value = "trials/collect")]
    out: PathBuf,
}

#[derive(clap::Args)]
pub struct TraceArgs {
    /// What to simulate.
    #[arg(long, value_enum)]
    scenario: Preset,
    /// Object from the library (`tmo sim objects`); default crisps_can, or rail_object on the rail.
    #[arg(long)]
    object: Option<String>,
    /// Hand roll, degrees (the paper uses 0 and 180).
    #[arg(long, default_value_t = 0.0)]
    grasp_deg: f64,
    /// Seed of the trial's randomness (object, noise, units): the same seed, the same trace.
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
    #[arg(long, value_parser = super::output::a_dir, default_value = "results/trace")]
    out: PathBuf,
}

pub fn run(command: SimCommand) -> Result<()> {
    match command {
        SimCommand::Objects => {
            list_objects()?;
            Ok(())
        }
        SimCommand::Parameters(args) => {
            use std::io::IsTerminal;
            let table = !args.tsv && std::io::stdout().is_terminal();
            list_parameters(table).context("cannot write to standard output")
        }
        SimCommand::Trace(args) => sim_trace(args),
        // a collection's trials run as `tmo run` runs them (its exit codes too)
        SimCommand::Collect(args) => sim_collect(args).map(|_| ()),
        SimCommand::Serve(args) => super::serve::serve_cmd(args),
    }
}

/// The parameters as a table a terminal shows: one line each, the source cut to its first
/// words (`--tsv` gives it whole).
fn parameter_table(records: &[tmo_sim::parameters::ParameterRecord]) -> String {
    const SOURCE_CHARS: usize = 48;
    let rows: Vec<[String; 6]> = records
        .iter()
        .map(|r| {
            let source: String = if r.source.chars().count() > SOURCE_CHARS {
                let cut: String = r.source.chars().take(SOURCE_CHARS - 1).collect();
                format!("{}…", cut.trim_end())
            } else {
                r.source.clone()
            };
            [
                r.name.clone(),
                r.value.map_or("per object".to_string(), tmo::quote::number),
                r.unit.clone(),
                format!(
                    "{}..{}",
                    tmo::quote::number(r.range[0]),
                    tmo::quote::number(r.range[1])
                ),
                if r.calibrated_against.is_empty() {
                    "-".to_string()
                } else {
                    format!("{} finding(s)", r.calibrated_against.len())
                },
                source,
            ]
        })
        .collect();
    let header = [
        "parameter",
        "value",
        "unit",
        "range",
        "calibrated",
        "source",
    ];
    let width = |k: usize| {
        rows.iter()
            .map(|r| r[k].chars().count())
            .chain([header[k].len()])
            .max()
            .unwrap_or(0)
    };
    let widths: Vec<usize> = (0..5).map(width).collect();
    let line = |cells: [&str; 6]| {
        let mut s = String::new();
        for (k, cell) in cells.iter().enumerate().take(5) {
            s += &format!("{cell:<w$}  ", w = widths[k]);
        }
        s += cells[5];
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(header);
    for r in &rows {
        out += &line([&r[0], &r[1], &r[2], &r[3], &r[4], &r[5]]);
    }
    out
}

fn list_parameters(table: bool) -> std::io::Result<()> {
    use std::io::Write;
    let records = tmo_sim::parameters::built_in();
    let mut out = std::io::stdout().lock();
    if table {
        write!(out, "{}", parameter_table(&records))?;
        out.flush()?;
        eprintln!(
            "{} parameters (sim/data/parameters.toml); `tmo sim parameters --tsv` gives every field whole, with the basis and the findings each was calibrated against",
            records.len()
        );
        return Ok(());
    }
    writeln!(
        out,
        "parameter\tvalue\tunit\trange\tbasis\tcalibrated against\tsource"
    )?;
    for r in &records {
        let value = r.value.map_or("per object".to_string(), |v| v.to_string());
        let basis = serde_json::to_value(r.basis)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        writeln!(
            out,
            "{}\t{value}\t{}\t{}..{}\t{basis}\t{}\t{}",
            r.name,
            r.unit,
            r.range[0],
            r.range[1],
            if r.calibrated_against.is_empty() {
                "-".to_string()
            } else {
                r.calibrated_against.join(",")
            },
            r.source
        )?;
    }
    out.flush()?;
    let calibrated = records
        .iter()
        .filter(|r| !r.calibrated_against.is_empty())
        .count();
    eprintln!(
        "{} parameters, {calibrated} of them calibrated against findings (sim/data/parameters.toml)",
        records.len()
    );
    Ok(())
}

fn list_objects() -> Result<()> {
    outln!(
        "{:<16} {:>6} {:>9} {:>10} {:>5} {:>5} {:>8}",
        "name",
        "ycb",
        "mass_g",
        "width_mm",
        "mu_s",
        "mu_k",
        "k_N/mm"
    );
    for o in ObjectLibrary::built_in().iter() {
        outln!(
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

fn load_sim_config(path: &Path) -> Result<SimConfig> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

fn sim_trace(args: TraceArgs) -> Result<()> {
    anyhow::ensure!(
        args.duration > 0.0 && args.duration <= 600.0,
        "--duration must be in (0, 600] s, got {}",
        tmo::quote::number(args.duration)
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
    let mut devices = Devices::of_sim(&rig);
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
    outln!(
        "scenario {:?}, seed {}, {:.1} s simulated in {:.2} s",
        args.scenario,
        args.seed,
        args.duration,
        elapsed
    );
    outln!("  slip onsets (s):  {}", times(&events.slip_onsets_s));
    outln!("  catches (s):      {}", times(&events.catches_s));
    outln!(
        "  dropped at (s):   {}",
        events.drop_s.map_or("no".into(), |t| format!("{t:.3}"))
    );
    outln!(
        "  object height:    {:.1} mm at the end (started {:.1} mm)",
        last.object_mm,
        truth.first().map_or(0.0, |t| t.object_mm)
    );
    outln!(
        "  frames: {}, marker samples: {}",
        recording.frames.len(),
        recording.markers.len()
    );
    outln!(
        "wrote {}, {}, {}, {}",
        files.truth.display(),
        files.pins.display(),
        files.markers.display(),
        files.config.display()
    );
    Ok(())
}

fn sim_collect(args: CollectArgs) -> Result<u8> {
    anyhow::ensure!(args.trials > 0, "--trials must be at least 1");
    anyhow::ensure!(!args.grasps.is_empty(), "--grasps needs at least one angle");
    for g in &args.grasps {
        anyhow::ensure!(
            (-360.0..=360.0).contains(g),
            "--grasps: expected angles in -360..=360 degrees, got {}",
            tmo::quote::number(*g)
        );
    }
    let objects = if !args.objects.is_empty() {
        args.objects.clone()
    } else {
        match args.rig {
            CollectRig::Hand => tmo::protocol::PAPER_TRAINING_OBJECTS
                .map(String::from)
                .to_vec(),
            CollectRig::Rail => vec!["rail_object".to_string()],
        }
    };
    let library = ObjectLibrary::built_in();
    for o in &objects {
        library.get(o).with_context(|| "--objects")?;
        let rail_object = o == "rail_object";
        anyhow::ensure!(
            rail_object == (args.rig == CollectRig::Rail),
            "--objects: `{o}` {}",
            if rail_object {
                "belongs to the slip rail (--rig rail)"
            } else {
                "is a hand object; the rail holds only rail_object"
            }
        );
    }
    // The rail has no grasp angle: its trials are the rail object's alone.
    let grasps = match args.rig {
        CollectRig::Hand => args.grasps.clone(),
        CollectRig::Rail => vec![0.0],
    };
    let cells = (objects.len() * grasps.len()) as u64;
    anyhow::ensure!(
        args.trials.is_multiple_of(cells),
        "--trials {}: expected a multiple of {cells} (each of the {} object(s) at each of the {} grasp(s) the same number of times), e.g. {}",
        args.trials,
        objects.len(),
        grasps.len(),
        (args.trials / cells + 1) * cells
    );
    let repetitions = u32::try_from(args.trials / cells)
        .ok()
        .filter(|r| u64::from(*r) * cells <= 1_000_000)
        .context("--trials: at most 1,000,000 trials in one collection")?;
    let mut protocol = CollectPreset {
        rig: args.rig,
        repetitions,
        seed: args.seed,
        objects: &objects,
        grasps_deg: &grasps,
    }
    .protocol();
    if let Some(path) = &args.config {
        protocol += &sim_table(&load_sim_config(path)?)
            .with_context(|| format!("--config {}", path.display()))?;
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    // The collection is a protocol like any other: `tmo run` on this file, with the same
    // seed, records the same trials.
    let file = args.out.join("protocol.toml");
    if let Ok(kept) = std::fs::read_to_string(&file) {
        anyhow::ensure!(
            kept == protocol,
            "{} already holds another collection (its protocol.toml differs: another rig, objects, grasps, count, seed or --config); nothing was added (use another --out)",
            args.out.display()
        );
    }
    tmo::output::atomic::write_atomic(&file, protocol.as_bytes())
        .with_context(|| format!("cannot write {}", file.display()))?;
    super::run::run_on_sim(file, args.out.clone(), true)
}

/// A simulator configuration file as a protocol's `[sim]` table: the numbers that differ
/// from the defaults. A configuration that differs in anything else (the rig, which the
/// collection sets) is refused.
fn sim_table(config: &SimConfig) -> Result<String> {
    // the numbers a protocol's `[sim]` table can set: every field but the seed and the rig
    let numbers = |c: &SimConfig| -> Vec<(String, f64)> {
        let mut v = serde_json::to_value(c).expect("a config serialises");
        let map = v.as_object_mut().expect("a config is a table");
        map.remove("seed");
        map.remove("rig");
        tmo_sim::config::numbers_by_name(&v).0
    };
    let defaults: std::collections::BTreeMap<String, f64> =
        numbers(&SimConfig::default()).into_iter().collect();
    let changed: Vec<(String, f64)> = numbers(config)
        .into_iter()
        .filter(|(name, value)| defaults.get(name) != Some(value))
        .collect();
    let mut rebuilt = SimConfig::default();
    rebuilt
        .set_parameters(changed.iter().map(|(k, v)| (k.as_str(), *v)))
        .map_err(anyhow::Error::msg)?;
    let mut compared = config.clone();
    compared.seed = rebuilt.seed;
    compared.rig = rebuilt.rig.clone();
    anyhow::ensure!(
        compared == rebuilt,
        "only the simulator's numeric parameters (`tmo sim parameters`) can be set for a collection"
    );
    if changed.is_empty() {
        return Ok(String::new());
    }
    let lines: String = changed
        .iter()
        .map(|(k, v)| format!("\"{k}\" = {v:?}\n"))
        .collect();
    Ok(format!("\n[sim]\n{lines}"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_parameter_table_is_one_short_line_a_parameter() {
        let records = tmo_sim::parameters::built_in();
        let table = super::parameter_table(&records);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), records.len() + 1);
        assert!(lines[0].starts_with("parameter"), "{}", lines[0]);
        let longest = lines.iter().map(|l| l.chars().count()).max().unwrap();
        assert!(longest < 200, "{longest}");
        assert!(
            table.contains("physics.finger_stiffness_n_per_mm"),
            "{table}"
        );
    }
}
