//! `tmo sim ...`: the simulated rig from the command line.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Subcommand;
use tmo::collect::{self, CollectRig, CollectSpec};
use tmo::scenario::Devices;
use tmo::sim_presets::{self, Preset, PresetOptions};
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
    Parameters,
    /// Records collect-mode trials (no reaction to slip) as training data.
    Collect(CollectArgs),
    /// Serves the simulated rig over the real rig's wire protocols (cameras and hand bus on
    /// pseudo-terminals, the UR controller on loopback TCP).
    Serve(super::serve::ServeArgs),
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
    #[arg(long, default_value = "trials/collect")]
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
    #[arg(long, default_value = "results/trace")]
    out: PathBuf,
}

pub fn run(command: SimCommand) -> Result<()> {
    match command {
        SimCommand::Objects => {
            list_objects();
            Ok(())
        }
        SimCommand::Parameters => list_parameters().context("cannot write to standard output"),
        SimCommand::Trace(args) => sim_trace(args),
        SimCommand::Collect(args) => sim_collect(args),
        SimCommand::Serve(args) => super::serve::serve_cmd(args),
    }
}

fn list_parameters() -> std::io::Result<()> {
    use std::io::Write;
    let records = tmo_sim::parameters::built_in();
    let mut out = std::io::stdout().lock();
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

fn list_objects() {
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

pub fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

fn sim_collect(args: CollectArgs) -> Result<()> {
    anyhow::ensure!(args.trials > 0, "--trials must be at least 1");
    anyhow::ensure!(!args.grasps.is_empty(), "--grasps needs at least one angle");
    for g in &args.grasps {
        anyhow::ensure!(
            (-360.0..=360.0).contains(g),
            "--grasps: expected angles in -360..=360 degrees, got {g}"
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
    let base = match &args.config {
        Some(p) => load_sim_config(p)?,
        None => SimConfig::default(),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let bar = super::output::counting_bar("collect", "trials");
    bar.set_length(args.trials);
    let spec_of = |i: u64| {
        let n = objects.len() as u64;
        CollectSpec {
            rig: args.rig,
            object: objects[(i % n) as usize].clone(),
            grasp_deg: args.grasps[((i / n) % args.grasps.len() as u64) as usize],
            seed: collect::trial_seed(args.seed, i),
            base: base.clone(),
        }
    };
    // Trials already there must be this collection's own (an earlier, interrupted run of
    // it): checked before any trial runs, so nothing is added to another collection.
    let mut already = vec![false; args.trials as usize];
    for i in 0..args.trials {
        let path = args.out.join(format!("trial-{i:04}.mcap"));
        if path.exists() {
            let kept = tmo::trial::read_trial(&path)?;
            if let Some(why) = spec_of(i).differs_from(&kept.meta) {
                anyhow::bail!(
                    "{} already holds another collection's trial: {}: {why}; nothing was added (use another --out)",
                    args.out.display(),
                    path.display()
                );
            }
            already[i as usize] = true;
        }
    }
    let (mut ran, mut kept) = (0, 0);
    for i in 0..args.trials {
        let trial_id = format!("trial-{i:04}");
        let path = args.out.join(format!("{trial_id}.mcap"));
        if already[i as usize] {
            kept += 1;
            bar.inc(1);
            continue;
        }
        let spec = spec_of(i);
        let trial = collect::collect_trial(&spec, &trial_id, unix_now())
            .with_context(|| format!("trial {trial_id}"))?;
        tmo::trial::write_trial(&path, &trial)?;
        super::output::detail(
            &bar,
            format!(
                "{trial_id}: {} at {} deg, seed {}: {} frames",
                spec.object,
                spec.grasp_deg,
                spec.seed,
                trial.frames.len()
            ),
        );
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
