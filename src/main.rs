//! The `tmo` command line. Exit codes: 0 success, 2 error (bad input or a failed run).

mod cli;

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};
use cli::sim::SimCommand;
use cli::slip::{DatasetCommand, EvaluateArgs, TrainArgs};
use cli::sweep::SweepArgs;

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
    /// Runs a protocol's batch of trials on the simulator.
    Run(cli::run::RunArgs),
    /// The paper's tables (and figures) from recorded batches, sweeps and evaluations.
    Report(cli::report::ReportArgs),
    /// Trains and scores every cell of a classifier x n_slip x down-sampling grid (paper Fig. 5).
    Sweep(SweepArgs),
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
        Command::Sim(command) => cli::sim::run(command),
        Command::Dataset(DatasetCommand::Export(args)) => cli::slip::dataset_export(args),
        Command::Train(args) => cli::slip::train(args),
        Command::Evaluate(args) => cli::slip::evaluate(args),
        Command::Sweep(args) => cli::sweep::sweep(args),
        Command::Run(args) => cli::run::run(args),
        Command::Report(args) => cli::report::report(args),
    }
}
