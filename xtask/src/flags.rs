//! Command-line flags.

use clap::{Parser, Subcommand};
use dgsph::overrides::Preset;
use std::path::PathBuf;

/// dgsph developer tasks.
#[derive(Debug, Parser)]
#[command(name = "xtask", about = "dgsph developer tasks")]
pub struct Cli {
    /// The task to run.
    #[command(subcommand)]
    pub command: Command,
}

/// Available tasks.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the validation scenes and compare them with reference data.
    Validate(ValidateArgs),
    /// Run one scene (the same as `dgsph run`).
    Run(Box<dgsph::cli::RunArgs>),
    /// Rebuild report.md and its figures from an output directory (`dgsph report`).
    Report(dgsph::cli::ReportArgs),
    /// The largest stable time step of each scheme (drop, Re 400 cavity, dam break; or the
    /// scenes given with `--scene`, at the spacings of `--dx`: a stability map).
    DtLimit(DtLimitArgs),
    /// Run a scene N times with its time step changed at round-off and give each result's
    /// mean, spread and standard error over the draws.
    Ensemble(Box<EnsembleArgs>),
    /// Compare two ensembles (`<tag>_ensemble.csv` files): each shared result's means, their
    /// difference and the difference in standard errors.
    EnsembleCompare(CompareArgs),
    /// Time two commands in alternation (A, B, A, B, …) and give each side's wall and step
    /// times, the ratio B/A and the load before each run.
    Interleave(InterleaveArgs),
}

/// Flags of `cargo xtask interleave`.
#[derive(Debug, clap::Args)]
pub struct InterleaveArgs {
    /// Command A, run by `sh -c` (e.g. `RAYON_NUM_THREADS=1 target/release/dgsph run …`).
    #[arg(long)]
    pub a: String,
    /// Command B, run by `sh -c`; ratios are B/A.
    #[arg(long)]
    pub b: String,
    /// Pairs of runs (A then B, this many times).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub pairs: u32,
    /// A's name in the table and its log files' names.
    #[arg(long, default_value = "A")]
    pub label_a: String,
    /// B's name in the table and its log files' names.
    #[arg(long, default_value = "B")]
    pub label_b: String,
    /// Directory of the logs, `interleave.csv` and `interleave.md`.
    #[arg(long, default_value = "target/interleave")]
    pub out: PathBuf,
}

/// Flags of `cargo xtask ensemble-compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The base ensemble's CSV.
    pub base: PathBuf,
    /// The ensemble compared with it (differences are other − base).
    pub other: PathBuf,
    /// The Markdown table's file.
    #[arg(long, default_value = "target/ensemble/compare.md")]
    pub out: PathBuf,
}

/// What the draws of `cargo xtask ensemble` change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Perturbed {
    /// The time step: draw k runs with Δt (1 − k ε), every step.
    Dt,
    /// The gravity vector: draw k runs with g (1 − k ε).
    Gravity,
}

/// Flags of `cargo xtask ensemble`.
#[derive(Debug, clap::Args)]
pub struct EnsembleArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Number of draws (draw k runs with Δt (1 − k ε), or g (1 − k ε)).
    #[arg(long, default_value_t = 9, value_parser = clap::value_parser!(u32).range(2..=1000))]
    pub draws: u32,
    /// The relative change ε between draws.
    #[arg(long, default_value_t = 1e-14)]
    pub perturbation: f64,
    /// What the draws change: `dt` (the time step, taken every step: an automatic step is
    /// switched off) or `gravity` (the scene's gravity vector; its time step as written, an
    /// automatic one included).
    #[arg(long, value_enum, default_value = "dt")]
    pub perturb: Perturbed,
    /// `full` (the scene as written) or `quick` (its `[quick]` overrides).
    #[arg(long, value_enum, default_value = "full")]
    pub preset: Preset,
    /// Output directory for `<tag>_ensemble.csv` and `<tag>_ensemble.md`.
    #[arg(long, default_value = "target/ensemble")]
    pub out: PathBuf,
    /// File prefix (default: the scene file's stem).
    #[arg(long)]
    pub tag: Option<String>,
    /// Changes to the scene (applied before the draws' perturbation).
    #[command(flatten)]
    pub overrides: dgsph::overrides::Overrides,
}

/// Flags of `cargo xtask dt-limit`.
#[derive(Debug, clap::Args)]
pub struct DtLimitArgs {
    /// `quick` (the scenes' `[quick]` sizes) or `full`.
    #[arg(long, value_enum, default_value = "quick")]
    pub preset: Preset,
    /// Search these scenes instead of the built-in three (repeatable), each trial to `--end`
    /// (default: the scene's end time after the preset).
    #[arg(long)]
    pub scene: Vec<PathBuf>,
    /// End time of every trial of the `--scene` scenes.
    #[arg(long)]
    pub end: Option<f64>,
    /// Particle spacings to search each scene at (a stability map: stable Δt against dx),
    /// comma-separated; default: the scene's own. The search starts from the scene's Δt scaled
    /// with dx.
    #[arg(long, value_delimiter = ',')]
    pub dx: Vec<f64>,
    /// Output directory for dt_limit.md and dt_limit.csv.
    #[arg(long, default_value = "target/dt-limit")]
    pub out: PathBuf,
}

/// Which scenes `validate` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Suite {
    /// The scenes of `cases/` (the paper's cases and the scene examples).
    Default,
    /// The hard cases of `cases/hard/`, each against the criteria its scene declares.
    Hard,
}

impl Suite {
    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Suite::Default => "default",
            Suite::Hard => "hard",
        }
    }
}

/// Flags of `cargo xtask validate`.
#[derive(Debug, clap::Args)]
pub struct ValidateArgs {
    /// `quick` (each scene's `[quick]` overrides) or `full` (alias `paper`: as written).
    #[arg(long, value_enum, default_value = "quick")]
    pub preset: Preset,
    /// The scene suite.
    #[arg(long, value_enum, default_value = "default")]
    pub suite: Suite,
    /// Run only the cases whose kind (e.g. `lid_driven_cavity`, `kernels`) or scene file stem
    /// (e.g. `cavity_density_quintic`) contains this string.
    #[arg(long)]
    pub case: Option<String>,
    /// Output directory for reports and frames.
    #[arg(long, default_value = "target/validation")]
    pub out: PathBuf,
    /// Directory of scene files (default: `cases`, or `cases/hard` for `--suite hard`).
    #[arg(long)]
    pub cases: Option<PathBuf>,
    /// Compare against the reference tables in this directory instead of the copy compiled in
    /// from `cases/reference/` (files it lacks keep the compiled copy).
    #[arg(long)]
    pub references: Option<PathBuf>,
    /// Instead of the validation cases, run the accuracy-against-cost sweep and write
    /// sweep.md, sweep.csv and the error-against-wall-time plots.
    #[arg(long)]
    pub sweep: bool,
    /// With `--sweep`: run only these studies (`dx`, `dt`, `tolerance`; default all).
    #[arg(long, value_delimiter = ',', requires = "sweep", value_parser = ["dx", "dt", "tolerance"])]
    pub study: Vec<String>,
    /// Records between particle frames (MCAP, ParaView).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub frame_every: Option<u64>,
    /// Checkpoint every N steps into the output directory.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub checkpoint_every: Option<u64>,
    /// Continue every run from its checkpoint (an error where there is none).
    #[arg(long)]
    pub resume: bool,
    /// Write ParaView frames of every run.
    #[arg(long)]
    pub vtk: bool,
}
