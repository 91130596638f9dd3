//! `cargo xtask`: dgsph's developer tasks, on the same code as the `dgsph` command.
//!
//! * `cargo xtask validate` runs every scene in `cases/` (the quick preset by default) and the
//!   foundation checks, compares them with reference or exact data, prints a pass/fail table,
//!   writes `summary.json` and `report.md` into `target/validation/`, and exits with the
//!   `dgsph` exit codes (0 all passed, 1 a check failed, 2 bad input, 3 a run failed, 4 an
//!   output error).
//! * `cargo xtask validate --sweep` runs the accuracy-against-cost sweep ([`sweep`]).
//! * `cargo xtask dt-limit` finds each scheme's largest stable time step ([`dt_limit`]).
//! * `cargo xtask ensemble SCENE` runs a scene over round-off-perturbed time steps and gives
//!   each result's distribution ([`ensemble`]); `cargo xtask ensemble-compare A.csv B.csv`
//!   says whether two such distributions differ beyond their spread ([`ensemble_compare`]).
//! * `cargo xtask interleave --a CMD --b CMD` times two commands in alternation and gives the
//!   ratio of their times with the load before each run ([`interleave`]).
//! * `cargo xtask run SCENE.toml` and `cargo xtask report DIR` are `dgsph run` and
//!   `dgsph report`.

mod dt_limit;
mod ensemble;
mod ensemble_compare;
mod flags;
mod interleave;
mod sweep;
mod validate;

use clap::Parser;
use dgsph::session::{AppError, exit};
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = flags::Cli::parse();
    // Run the task on a worker thread of the global rayon pool: a parallel loop started from
    // a worker runs its unsplit (short) parts inline, while one started from the main thread
    // is handed to the pool and waited for — a wake-up and a sleep per call, thousands per
    // step in the multigrid cycle's short coarse-level loops.
    if let Err(e) = dgsph::cli::start_thread_pool() {
        dgsph::warn!("error: {e}");
        return ExitCode::from(e.exit_code());
    }
    let result = rayon::scope(|_| match cli.command {
        flags::Command::Validate(args) => validate::run(&args),
        flags::Command::Run(args) => dgsph::cli::run(&args),
        flags::Command::DtLimit(args) => dt_limit::run(&args),
        flags::Command::Ensemble(args) => ensemble::run(&args),
        flags::Command::EnsembleCompare(args) => ensemble_compare::run(&args),
        flags::Command::Interleave(args) => interleave::run(&args),
        flags::Command::Report(args) => dgsph::report::write(&args.dir)
            .map(|p| {
                dgsph::say!("report: {}", p.display());
                exit::OK
            })
            .map_err(AppError::Input),
    });
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            dgsph::warn!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
