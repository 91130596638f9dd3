//! `cargo xtask`: dgsph's developer tasks.
//!
//! * `cargo xtask validate` runs the validation cases, compares them with reference or exact
//!   data, prints a pass/fail table, writes `target/validation/summary.json` and exits non-zero
//!   if any check fails.
//! * `cargo xtask run SCENE.toml` runs one scene and writes its time series as CSV under
//!   `target/runs/`.
//! * `cargo xtask validate --sweep` runs the accuracy-against-cost sweep ([`sweep`]).
//! * `cargo xtask report --out DIR` rebuilds `DIR/report.md` and its SVG figures from the CSV
//!   files there.
//!
//! xtask owns all file I/O and terminal output; the library crates do none.

mod flags;
mod mcap_sink;
mod report;
mod run;
mod sweep;
mod validate;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = flags::Cli::parse();
    // Run the task on a worker thread of the global rayon pool: a parallel loop started from
    // a worker runs its unsplit (short) parts inline, while one started from the main thread
    // is handed to the pool and waited for — a wake-up and a sleep per call, thousands per
    // step in the multigrid cycle's short coarse-level loops.
    rayon::scope(|_| run_task(cli))
}

fn run_task(cli: flags::Cli) -> std::process::ExitCode {
    let result = match cli.command {
        flags::Command::Validate(args) => validate::run(&args),
        flags::Command::Report(args) => report::write(&args.out).map(|path| {
            println!("report: {}", path.display());
            true
        }),
        flags::Command::Run(args) => run::load_scene(&args.scene)
            .and_then(|scene| run::apply_overrides(scene, &args))
            .and_then(|scene| {
                let name = args
                    .tag
                    .clone()
                    .unwrap_or_else(|| run::scene_stem(&args.scene));
                if scene.case != sph_cases::CaseKind::LidDrivenCavity
                    && (args.resume || args.checkpoint_every.is_some())
                {
                    anyhow::bail!(
                        "--resume and --checkpoint-every apply to lid_driven_cavity scenes only \
                         (drops are short)"
                    );
                }
                let options = run::RunOptions {
                    checkpoint_every: args.checkpoint_every,
                    resume: args.resume,
                    frame_stride: args.frame_stride,
                };
                run::run_scene(
                    &scene,
                    &name,
                    args.preset,
                    sph_cases::reference::References::embedded(),
                    &args.out,
                    &options,
                )
            })
            .map(|result| validate::print_checks(&result.checks)),
    };
    match result {
        Ok(true) => std::process::ExitCode::SUCCESS,
        Ok(false) => std::process::ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
