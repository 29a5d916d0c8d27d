//! `tmo reproduce`: the paper's experiments in one command, and the findings table.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use tmo::output::shard::Shard;
use tmo::reproduce::{self, Backend, End, Options, Preset, Progress};

use super::run::EXIT_INTERRUPTED;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PresetArg {
    /// The fewest trials that run every step, a few seconds: checks an install, a
    /// cluster's setup or the pipeline's plumbing; its verdicts mean nothing.
    Smoke,
    /// Scaled down: about 20 s on two cores, one replicate.
    Quick,
    /// The paper's counts and grids.
    Paper,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    #[value(alias = "mock")]
    Sim,
    Real,
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct ReproduceArgs {
    #[command(subcommand)]
    command: Option<ReproduceCommand>,
    /// How much to run: `quick` (a few trials a cell, one replicate, about 20 s), `paper`
    /// (the paper's counts, five replicates, about 20 minutes on 2 cores), or `smoke` (every
    /// step on the fewest trials, to check a setup; its verdicts mean nothing).
    #[arg(long, value_enum, default_value = "quick")]
    preset: PresetArg,
    /// Independent replicates of every step, each with its own trial and learner seeds
    /// (default: 1 for quick, 5 for paper). Findings pool them.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=99))]
    replicates: Option<u32>,
    /// Run nothing: write the findings report again from the finished steps in --out.
    #[arg(long, conflicts_with = "resume")]
    findings_only: bool,
    /// Also vary every physical simulator parameter to the low and the high end of its
    /// plausible range (`tmo sim parameters`), rerun the steps it touches with the same
    /// seeds, and say which verdicts change (`sensitivity.md`, and a column of the page);
    /// beside them a noise reference, the baseline with other seeds, says which verdicts
    /// change with the seeds alone.
    #[arg(long)]
    sensitivity: bool,
    /// Replicates (and sensitivity variants) run side by side (default: one per core). The
    /// results are the same whatever the number; a real rig runs one at a time.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=256))]
    jobs: Option<u32>,
    /// Run only part K of N of the plan (the replicates, and with --sensitivity each
    /// variant's replicates, dealt out in turn), e.g. one per cluster job;
    /// `tmo reproduce merge` joins the parts and writes the findings.
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
    /// Run only the rail sweeps (with each job's rail collect), part K of N of them with
    /// --shard: the first stage of a reproduction spread over more processes than it has
    /// replicates, since the sweep is most of a replicate's time. The second stage runs
    /// with --sweep-from.
    #[arg(long, conflicts_with_all = ["sweep_from", "findings_only"])]
    sweep_only: bool,
    /// Take the rail sweeps' rows from these finished --sweep-only parts (every part's
    /// --out) instead of sweeping here; the findings are the same.
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with = "findings_only")]
    sweep_from: Vec<PathBuf>,
    /// With --sensitivity: keep the variants' trial logs (by default a variant's replicate
    /// removes them once it is finished, listing each with its SHA-256 in its step's
    /// pruned.json: some 850 MB a replicate at the paper's counts).
    #[arg(long, requires = "sensitivity")]
    keep_variant_logs: bool,
    /// With --sensitivity: vary only these parameters (comma-separated names; `reseeded`
    /// alone runs only the noise reference). `NAME=VALUE` is a switch: the parameter at
    /// that value, which may lie outside its range (to show a finding can fail).
    #[arg(long, value_delimiter = ',', requires = "sensitivity")]
    sensitivity_parameters: Vec<String>,
    /// The second stage of a sensitivity study (implies --sensitivity): vary, at this
    /// preset's counts, only what a finished screen (the --out of a `--sensitivity` run at
    /// the quick preset's counts) could not clear: every calibrated parameter, and every
    /// one whose screen changed more verdicts than the screen's noise reference did.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["sensitivity_parameters", "findings_only"])]
    screen: Option<PathBuf>,
    /// A slip model of your own (an ONNX model, or a model file of tmo's) in place of the
    /// whole hand's global model: every online hand step runs it and the hand's offline
    /// evaluation scores it, so the findings on the global model judge it (docs/onnx.md).
    /// tmo's own global model is still trained, and scored beside it.
    #[arg(long, value_name = "FILE", conflicts_with = "findings_only")]
    hand_model: Option<PathBuf>,
    /// Where every step's outputs and the findings report go.
    #[arg(long, value_parser = super::output::a_dir, default_value = "results/paper")]
    out: PathBuf,
    /// Finish or update a reproduction in --out: steps whose inputs are unchanged are kept.
    #[arg(long)]
    resume: bool,
    /// Where the trials run: the simulator, or the real rig (`--hardware`).
    #[arg(long, value_enum, default_value = "sim")]
    backend: BackendArg,
    /// With `--backend real`: the hand rig's hardware file.
    #[arg(long)]
    hardware: Option<PathBuf>,
    /// With `--backend real`: the single-finger rail rig's hardware file.
    #[arg(long)]
    rail_hardware: Option<PathBuf>,
    /// With `--backend real`: no operator step between trials (the rig resets itself).
    #[arg(long)]
    unattended: bool,
}

#[derive(clap::Subcommand)]
enum ReproduceCommand {
    /// Join the parts of a sharded reproduction (`tmo reproduce --shard K/N`) into one and
    /// write its findings report.
    Merge(MergeArgs),
}

#[derive(clap::Args)]
struct MergeArgs {
    /// Every shard's --out directory.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Where the joined reproduction and its findings report go (it must hold none yet).
    #[arg(long, value_parser = super::output::a_dir, default_value = "results/paper")]
    out: PathBuf,
}

pub fn run(args: ReproduceArgs) -> Result<u8> {
    if let Some(ReproduceCommand::Merge(m)) = args.command {
        return merge(m);
    }
    let backend = match args.backend {
        BackendArg::Sim => Backend::Sim,
        BackendArg::Real => {
            let (Some(hand), Some(rail)) = (args.hardware.clone(), args.rail_hardware.clone())
            else {
                anyhow::bail!("--backend real needs --hardware FILE (the hand rig) and --rail-hardware FILE (the single-finger rail rig); `tmo sim serve` writes one for the simulator (--rig rail for the rail)");
            };
            Backend::Real {
                hand,
                rail,
                unattended: args.unattended,
            }
        }
    };
    let preset = match args.preset {
        PresetArg::Smoke => Preset::Smoke,
        PresetArg::Quick => Preset::Quick,
        PresetArg::Paper => Preset::Paper,
    };
    let sensitivity = match &args.screen {
        Some(dir) => Some(second_stage(dir)?),
        None => args
            .sensitivity
            .then(|| reproduce::sensitivity::parameters_named(&args.sensitivity_parameters)),
    };
    // read and checked before anything runs: a model that cannot stand in fails now
    let hand_model = args
        .hand_model
        .as_deref()
        .map(reproduce::hand_model::HandModel::read)
        .transpose()?;
    let mut options = Options {
        hand_model,
        out: args.out.clone(),
        preset,
        replicates: args
            .replicates
            .unwrap_or_else(|| preset.default_replicates()),
        resume: args.resume,
        shard: args.shard,
        sweep_only: args.sweep_only,
        sweep_from: args.sweep_from.clone(),
        keep_variant_logs: args.keep_variant_logs,
        backend,
        sensitivity,
        jobs: args.jobs.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            |j| j as usize,
        ),
    };
    // The study builds on a baseline: right after `tmo reproduce`, `tmo reproduce
    // --sensitivity` finds that finished baseline in the same directory and keeps it, as
    // --resume would, rather than stop at "already holds a reproduction".
    if options.sensitivity.is_some()
        && !options.resume
        && !args.findings_only
        && reproduce::replicate_dir(&options.out, 1).is_dir()
    {
        let problems = reproduce::check::check_plan(
            &options.out,
            &options.preset,
            options.replicates,
            &[],
            &options.backend,
        )?;
        if problems.iter().all(|p| !p.is_fatal()) {
            super::output::note(format!(
                "{} holds this plan's finished baseline: the sensitivity study builds on it (as with --resume)",
                options.out.display()
            ));
            options.resume = true;
        }
    }
    if args.findings_only {
        let first = reproduce::replicate_dir(&options.out, 1);
        if !first.is_dir() {
            anyhow::bail!(
                "{} holds no reproduction (no {}): run `tmo reproduce --out {}` first",
                options.out.display(),
                first.display(),
                options.out.display()
            );
        }
        let variants = match &options.sensitivity {
            Some(only) => {
                let study = reproduce::sensitivity::study(&tmo_sim::parameters::built_in(), only)
                    .map_err(anyhow::Error::msg)?;
                // a variant never run has no verdicts to compare (a study from before the
                // noise reference existed has none)
                let (run, missing): (Vec<_>, Vec<_>) = study
                    .into_iter()
                    .partition(|v| v.dir(&options.out).is_dir());
                // T4-9: no study at all is not a study of nothing
                anyhow::ensure!(
                    !run.is_empty(),
                    "{} holds no sensitivity study (no {}): drop --sensitivity, or run the study with `tmo reproduce --out {} --sensitivity --resume`",
                    options.out.display(),
                    options.out.join("sensitivity").display(),
                    options.out.display()
                );
                if !missing.is_empty() {
                    outln!(
                        "not run, left out of the study: {}",
                        missing
                            .iter()
                            .map(|v| v.dir_name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                }
                Some(run)
            }
            None => None,
        };
        check_before_findings(&options, variants.as_deref().unwrap_or_default())?;
        let report = reproduce::page::write_findings(
            &options.out,
            &preset,
            options.replicates,
            variants.as_deref(),
        )?;
        print_report(&report, &options)?;
        return Ok(0);
    }
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;

    let multi = indicatif::MultiProgress::new();
    if super::output::quiet() {
        multi.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let steps = multi.add(indicatif::ProgressBar::new(0));
    steps.set_style(
        indicatif::ProgressStyle::with_template("reproduce [{bar:20}] {elapsed} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let work = multi.add(indicatif::ProgressBar::new(0));
    work.set_style(
        indicatif::ProgressStyle::with_template("  [{bar:30}] {pos}/{len} (eta {eta}) {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let progress = Progress {
        steps,
        work,
        step_lines: !super::output::quiet() && {
            use std::io::IsTerminal;
            !std::io::stderr().is_terminal()
        },
    };
    let started = std::time::Instant::now();
    let end = reproduce::reproduce(&options, &stop, &progress);
    progress.work.finish_and_clear();
    progress.steps.finish_and_clear();
    match end? {
        End::Interrupted { step } => {
            eprintln!(
                "interrupted in step {step}: finished steps and trials are kept in {}; run again with --resume to finish",
                options.out.display()
            );
            std::process::exit(EXIT_INTERRUPTED);
        }
        End::Finished {
            ran,
            kept,
            remade,
            report,
        } => {
            warn_remade(&remade);
            outln!(
                "reproduce ({} preset): {} step(s) run, {} already done, in {:.1} s",
                options.preset.name(),
                ran.len(),
                kept.len(),
                started.elapsed().as_secs_f64()
            );
            print_report(&report, &options)?;
        }
        End::SweepPart { record } => {
            let chains: usize = record.jobs.iter().map(|j| j.chains.len()).sum();
            outln!(
                "reproduce ({} preset), sweep part {}: {chains} chain(s) of {} job(s)' rail sweeps in {:.1} s",
                options.preset.name(),
                record.part,
                record.jobs.len(),
                started.elapsed().as_secs_f64(),
            );
            outln!(
                "wrote {} and the part's sweep rows under {}; run the other steps with `tmo reproduce --sweep-from` and every part's directory",
                options.out.join(reproduce::sweep_parts::RECORD).display(),
                options.out.display()
            );
        }
        End::Shard {
            ran,
            kept,
            remade,
            record,
        } => {
            warn_remade(&remade);
            outln!(
                "reproduce ({} preset), shard {}: {} step(s) run, {} already done, in {:.1} s; {} job(s) of the plan",
                options.preset.name(),
                record.shard,
                ran.len(),
                kept.len(),
                started.elapsed().as_secs_f64(),
                record.jobs.len()
            );
            outln!(
                "wrote {} and the shard's step outputs under {}; join the shards with `tmo reproduce merge`",
                options.out.join(reproduce::shards::RECORD).display(),
                options.out.display()
            );
        }
    }
    Ok(0)
}

/// Finished steps a resume could not keep, each with why it ran again.
fn warn_remade(remade: &[String]) {
    for why in remade {
        eprintln!("warning: ran again {why}");
    }
}

/// Refuses to write a page from replicates or steps the plan does not have (missing,
/// unfinished, another replicate's copy, made for other inputs, altered), and says what
/// the page leaves out or was made by another build.
fn check_before_findings(
    options: &Options,
    variants: &[reproduce::sensitivity::Variant],
) -> Result<()> {
    let problems = reproduce::check::check_plan(
        &options.out,
        &options.preset,
        options.replicates,
        variants,
        &options.backend,
    )?;
    let (fatal, builds): (Vec<_>, Vec<_>) = problems.iter().partition(|p| p.is_fatal());
    if !fatal.is_empty() {
        let other_inputs = |p: &&reproduce::check::Problem| {
            matches!(p, reproduce::check::Problem::OtherInputs { .. })
        };
        if fatal.iter().any(other_inputs) {
            if let Some(fits) = reproduce::check::preset_that_fits(
                &options.out,
                &options.preset,
                options.replicates,
                variants,
                &options.backend,
            )? {
                anyhow::bail!(
                    "{} holds a reproduction with the {} preset, not the {} preset this page was asked of: add `--preset {}`",
                    options.out.display(),
                    fits.name(),
                    options.preset.name(),
                    fits.name()
                );
            }
        }
        let shown: Vec<String> = fatal.iter().take(12).map(|p| format!("  {p}")).collect();
        anyhow::bail!(
            "{} does not hold the {} replicate(s) this page would say it pools:\n{}{}\nfinish or remake them with `tmo reproduce --out {} --replicates {} --resume` (with the same preset{}), or write the page for the replicates it has (--replicates K)",
            options.out.display(),
            options.replicates,
            shown.join("\n"),
            if fatal.len() > shown.len() {
                format!("\n  ... and {} more", fatal.len() - shown.len())
            } else {
                String::new()
            },
            options.out.display(),
            options.replicates,
            if variants.is_empty() { "" } else { " and study" }
        );
    }
    if let Some(reproduce::check::Problem::OtherBuild {
        version, revision, ..
    }) = builds.first()
    {
        super::output::note(format!(
            "{} step(s) were made by tmo {version} ({revision}), not this build: the page is written by this build from their outputs",
            builds.len()
        ));
    }
    let beyond = reproduce::check::beyond(&options.out, options.replicates);
    if !beyond.is_empty() {
        super::output::note(format!(
            "{} also holds replicate(s) {}: this page pools only replicates 1 to {} (--replicates {} takes them all)",
            options.out.display(),
            beyond
                .iter()
                .map(|r| r.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            options.replicates,
            options.replicates + beyond.len() as u32
        ));
    }
    Ok(())
}

/// The parameters of a sensitivity study's second stage, from its screen in `dir`, each
/// said with why it was chosen.
fn second_stage(dir: &std::path::Path) -> Result<Vec<String>> {
    let (reference, screened) = reproduce::screen::read(dir)?;
    let records = tmo_sim::parameters::built_in();
    let variable = reproduce::sensitivity::variable(&records);
    let chosen = reproduce::screen::second_stage(&records, &variable, reference, &screened);
    let unvaried: Vec<&str> = records
        .iter()
        .filter(|r| !r.calibrated_against.is_empty() && !variable.contains(&r.name))
        .map(|r| r.name.as_str())
        .collect();
    if !unvaried.is_empty() {
        super::output::note(format!(
            "calibrated but not varied by any study (an object's property): {}",
            unvaried.join(", ")
        ));
    }
    super::output::note(format!(
        "second stage: the screen's noise reference changed {reference} verdicts; {} of {} screened parameters are varied here",
        chosen.len(),
        screened.len()
    ));
    for s in &chosen {
        let mut why = Vec::new();
        if !s.calibrated_against.is_empty() {
            why.push(format!("calibrated against {}", s.calibrated_against.len()));
        }
        match s.screen_changes {
            Some(c) if c > reference => why.push(format!("changed {c} verdicts in the screen")),
            None if screened.contains_key(&s.parameter) => {
                why.push("its screen did not finish".into())
            }
            None => why.push("not in the screen".into()),
            _ => {}
        }
        super::output::note(format!("  {}: {}", s.parameter, why.join("; ")));
    }
    Ok(if chosen.is_empty() {
        vec![reproduce::sensitivity::RESEEDED.to_string()]
    } else {
        chosen.into_iter().map(|s| s.parameter).collect()
    })
}

fn merge(args: MergeArgs) -> Result<u8> {
    let merged = reproduce::shards::merge(&args.shards, &args.out)?;
    outln!(
        "merged {} shards ({} jobs; the longest shard took {:.1} s)",
        merged.shards,
        merged.jobs,
        merged.longest_shard_s
    );
    outln!("{}", merged.report.summary_line());
    for line in merged.report.standing_lines() {
        outln!("  {line}");
    }
    for line in merged.report.lead_paragraphs() {
        outln!("{}", line.replace('`', ""));
    }
    outln!(
        "wrote {} (open it in a browser), {}, {} and every replicate's step outputs under {}",
        merged.report.html.display(),
        merged.report.md.display(),
        merged.report.json.display(),
        args.out.display()
    );
    Ok(0)
}

fn print_report(report: &reproduce::page::Written, options: &Options) -> Result<()> {
    outln!("{}", report.summary_line());
    for line in report.standing_lines() {
        outln!("  {line}");
    }
    outln!("{}", report.noise_text().replace('`', ""));
    if let Some(m) = &report.hand_model {
        outln!("{}", m.line().replace('`', ""));
    }
    if let Some((n, agree)) = report.truth_agreement {
        outln!(
            "marker-scored verdicts agree with the simulator's ground truth in {agree} of {n} catch trials ({:.1} %)",
            100.0 * agree as f64 / n.max(1) as f64
        );
    }
    outln!(
        "wrote {} (open it in a browser), {}, {} and every replicate's step outputs under {}",
        report.html.display(),
        report.md.display(),
        report.json.display(),
        options.out.display()
    );
    Ok(())
}
