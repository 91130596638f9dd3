//! `dgsph`: run, check and report incompressible SPH scenes.
//!
//! ```text
//! dgsph run SCENE.toml [--out DIR] [--preset full|quick] [--tag NAME] [--vtk] ...
//! dgsph check SCENE.toml          # parse and validate; particle counts, memory, steps
//! dgsph report DIR                # report.md and figures from an output directory
//! dgsph --version
//! ```
//!
//! Exit codes: 0 success, 1 a check failed, 2 bad input (scene, flags, checkpoint), 3 a run
//! stopped at a failed step (a blow-up, a solver that did not converge), 4 results could not
//! be written.

use clap::{Parser, Subcommand};
use dgsph::cli::{CheckArgs, ReportArgs, RunArgs};
use dgsph::session::{AppError, exit};
use std::process::ExitCode;

/// Incompressible SPH (Euler, predictor–corrector and DG-ISPH) in 2D and 3D.
#[derive(Debug, Parser)]
#[command(name = "dgsph", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene: every scheme it names, writing records (CSV, MCAP), tables, checkpoints
    /// and optionally ParaView frames into the output directory.
    Run(Box<RunArgs>),
    /// Parse and validate a scene without running it: particle counts, estimated memory,
    /// steps and the effects it declares.
    Check(CheckArgs),
    /// Rebuild report.md and its figures from an output directory.
    Report(ReportArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Run on a worker of the global rayon pool: a parallel loop started from a worker runs its
    // short parts inline instead of waking the pool (see ARCHITECTURE.md).
    if let Err(e) = dgsph::cli::start_thread_pool() {
        dgsph::warn!("error: {e}");
        return ExitCode::from(e.exit_code());
    }
    let code = rayon::scope(|_| match cli.command {
        Command::Run(args) => dgsph::cli::run(&args),
        Command::Check(args) => dgsph::cli::check(&args),
        Command::Report(args) => match dgsph::report::write(&args.dir) {
            Ok(p) => {
                dgsph::say!("report: {}", p.display());
                Ok(exit::OK)
            }
            Err(e) => Err(AppError::Input(e)),
        },
    });
    match code {
        Ok(c) => ExitCode::from(c),
        Err(e) => {
            dgsph::warn!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
