//! The `tmo` command line. Exit codes: 0 success, 2 error (bad input or a failed run),
//! 3 finished but some inputs were skipped (`tmo replay`), 130 a batch stopped by Ctrl-C.

/// `println!` for results: an error, not a panic, when standard output fails (see
/// `cli::output::write_out`). Only in functions that return `anyhow::Result`.
macro_rules! outln {
    () => {
        $crate::cli::output::write_out(format_args!("\n"))?
    };
    ($($arg:tt)*) => {
        $crate::cli::output::write_out(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

mod cli;

use std::process::ExitCode;

use anyhow::Result;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use cli::sim::SimCommand;
use cli::slip::{DatasetCommand, EvaluateArgs, TrainArgs};
use cli::sweep::SweepArgs;

/// The exit codes, as `docs/commands.md` gives them.
const EXIT_CODES_HELP: &str = "Exit codes:\n  0    success\n  2    error: bad input, a device fault, a failed write, a missing trial path, a replay that read no log\n  3    a replay that finished but skipped damaged trial logs (named on standard error)\n  130  stopped by Ctrl-C: the rig is made safe, finished trials are kept, `--resume` goes on\n\nCommand reference: docs/commands.md";

#[derive(Parser)]
#[command(
    name = "tmo",
    // The git revision too: trial logs and models record it, and a bug report needs it.
    version = concat!(env!("CARGO_PKG_VERSION"), " (", env!("TMO_GIT_REVISION"), ")"),
    about = "Tactile slip-detection experiments on the Tactile Model O hand",
    after_help = EXIT_CODES_HELP
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Say only results, warnings and errors: no progress bars, no notes.
    // global options come after each command's own in its help (display order)
    #[arg(short, long, global = true, display_order = 900)]
    quiet: bool,
    /// Also say each item as it finishes (trial, sweep cell, search evaluation, replayed log).
    #[arg(short, long, global = true, action = clap::ArgAction::Count, display_order = 901)]
    verbose: u8,
    /// Colour help and errors: `auto` on a terminal unless NO_COLOR is set.
    #[arg(long, global = true, value_enum, default_value_t = cli::output::ColorWhen::Auto, value_name = "WHEN", display_order = 902)]
    color: cli::output::ColorWhen,
}

/// In the order of a researcher's work: collect (or import) trials, train and score
/// classifiers, run them online, then report; `reproduce` does all of it for the paper.
#[derive(Subcommand)]
enum Command {
    /// The simulated rig.
    #[command(subcommand)]
    Sim(SimCommand),
    /// The real rig's hardware file.
    #[command(subcommand)]
    Hardware(cli::hardware::HardwareCommand),
    /// Other sensors' recordings (any number of elements, any rate) into trial logs.
    #[command(subcommand)]
    Import(cli::import::ImportCommand),
    /// Labelled feature data from recorded trials.
    #[command(subcommand)]
    Dataset(DatasetCommand),
    /// Trains a slip classifier on recorded trials and writes a model file.
    Train(TrainArgs),
    /// Scores a model on recorded trials (never down-sampled).
    Evaluate(EvaluateArgs),
    /// Trains and scores every cell of a classifier x n_slip x down-sampling grid (paper Fig. 5).
    Sweep(SweepArgs),
    /// Runs a protocol's batch of trials: on the simulator, over recorded trials, or on the real rig.
    Run(cli::run::RunArgs),
    /// What models and strategies would have done on recorded trials (replay backend).
    Replay(cli::replay::ReplayArgs),
    /// The paper's tables (and figures) from recorded batches, sweeps and evaluations.
    Report(cli::report::ReportArgs),
    /// The paper's experiments end to end, and a findings table against the paper.
    Reproduce(cli::reproduce::ReproduceArgs),
    /// Prints a shell completion script, e.g. `tmo completions bash > ~/.local/share/bash-completion/completions/tmo`.
    Completions {
        /// The shell to complete in.
        shell: clap_complete::Shell,
    },
}

fn main() -> ExitCode {
    // Rust's runtime ignores SIGPIPE, so a closed stdout (`tmo report ... | head`) made
    // every print panic. Restored, tmo ends quietly there, as Unix tools do. Sockets are not
    // affected: std writes to them with MSG_NOSIGNAL, and a lost peer stays an error.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // `--color` is read before clap parses, so that clap's own help and errors follow it.
    let color = cli::output::ColorWhen::from_args(std::env::args_os());
    let matches = Cli::command().color(color.clap()).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    cli::output::set_level(cli.quiet, cli.verbose);
    match run(cli) {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes, each said once: library errors often include their cause in
/// their own message, which `{:#}` would then repeat.
fn error_text(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

fn run(cli: Cli) -> Result<u8> {
    if let Command::Replay(args) = cli.command {
        let skipped = cli::replay::replay(args)?;
        return Ok(if skipped {
            cli::replay::EXIT_SKIPPED
        } else {
            0
        });
    }
    if let Command::Run(args) = cli.command {
        return cli::run::run(args);
    }
    if let Command::Reproduce(args) = cli.command {
        return cli::reproduce::run(args);
    }
    if let Command::Completions { shell } = cli.command {
        // into memory first: `generate` panics if its writer fails
        let mut script = Vec::new();
        clap_complete::generate(shell, &mut Cli::command(), "tmo", &mut script);
        cli::output::write_out(format_args!("{}", String::from_utf8_lossy(&script)))?;
        return Ok(0);
    }
    match cli.command {
        Command::Sim(command) => cli::sim::run(command),
        Command::Hardware(command) => cli::hardware::run(command),
        Command::Import(command) => cli::import::run(command),
        Command::Dataset(DatasetCommand::Export(args)) => cli::slip::dataset_export(args),
        Command::Train(args) => cli::slip::train(args),
        Command::Evaluate(args) => cli::slip::evaluate(args),
        Command::Sweep(args) => cli::sweep::sweep(args),
        Command::Run(_) => unreachable!("handled above"),
        Command::Report(args) => cli::report::report(args),
        Command::Replay(_) | Command::Reproduce(_) | Command::Completions { .. } => {
            unreachable!("handled above")
        }
    }?;
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every argument of every subcommand, as `tmo sub ... --name`, that has no help text.
    fn without_help(cmd: &clap::Command, path: &str, out: &mut Vec<String>) {
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            if matches!(id, "help" | "version") {
                continue;
            }
            if arg.get_help().is_none() && arg.get_long_help().is_none() {
                out.push(format!("{path} {id}"));
            }
        }
        for sub in cmd.get_subcommands() {
            if sub.get_name() == "help" {
                continue;
            }
            if sub.get_about().is_none() {
                out.push(format!("{path} {} (the command)", sub.get_name()));
            }
            without_help(sub, &format!("{path} {}", sub.get_name()), out);
        }
    }

    #[test]
    fn the_command_line_is_well_formed() {
        // clap's own checks: no two arguments share a name or a short flag (the global
        // -q and -v included), defaults parse, and so on
        Cli::command().debug_assert();
    }

    #[test]
    fn every_command_and_argument_has_help() {
        let mut missing = Vec::new();
        without_help(&Cli::command(), "tmo", &mut missing);
        assert!(missing.is_empty(), "no help text: {missing:#?}");
    }
}
