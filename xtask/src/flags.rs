//! Command-line flags.

use clap::{Parser, Subcommand, ValueEnum};
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
    /// Run the validation cases and compare them with reference data.
    Validate(ValidateArgs),
    /// Run one scene file and write its time series as CSV.
    Run(Box<RunArgs>),
    /// Rebuild report.md and its figures from the CSV files of an output directory.
    Report(ReportArgs),
}

/// Flags of `cargo xtask report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Directory holding the CSV files (and summary.json) of a validation or run.
    #[arg(long, default_value = "target/validation")]
    pub out: PathBuf,
}

/// Flags of `cargo xtask run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Scene file (TOML), e.g. cases/elliptical_drop.toml.
    pub scene: PathBuf,
    /// Resolution / duration preset.
    #[arg(long, value_enum, default_value = "paper")]
    pub preset: Preset,
    /// Output directory for the CSV files.
    #[arg(long, default_value = "target/runs")]
    pub out: PathBuf,
    /// Override the scene's particle spacing.
    #[arg(long)]
    pub dx: Option<f64>,
    /// Override the scene's time step.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Override the scene's end time.
    #[arg(long)]
    pub t_end: Option<f64>,
    /// Override the free-surface threshold on ∇·r.
    #[arg(long)]
    pub div_r_threshold: Option<f64>,
    /// Override the DG Hessian (`eq25` or `quadratic_fit`).
    #[arg(long)]
    pub dg_hessian: Option<String>,
    /// Override the cavity's Reynolds number.
    #[arg(long)]
    pub re: Option<f64>,
    /// Override the kernel (`quintic_spline`, `wendland_c2`, `cubic_spline`).
    #[arg(long)]
    pub kernel: Option<String>,
    /// Override the schemes (comma-separated: `euler,predictor_corrector,dg`).
    #[arg(long)]
    pub schemes: Option<String>,
    /// Declare particle shifting with this coefficient A (Lind et al. 2012).
    #[arg(long)]
    pub shifting: Option<f64>,
    /// Override the solver (`bicgstab_jacobi`, `bicgstab_ilu0`, `bicgstab_amg`, `sparse_lu`).
    #[arg(long)]
    pub solver: Option<String>,
    /// Override the solver's relative tolerance.
    #[arg(long)]
    pub solver_tolerance: Option<f64>,
    /// Output file prefix (default: the scene file's stem).
    #[arg(long)]
    pub tag: Option<String>,
    /// Cavity runs: write `<out>/<prefix>_<scheme>.checkpoint.json` every N steps (and at the end).
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<usize>,
    /// Cavity runs: continue from `<out>/<prefix>_<scheme>.checkpoint.json` where one exists,
    /// appending to the CSV time series (runs longer than a session).
    #[arg(long)]
    pub resume: bool,
    /// Write every N-th particle frame to MCAP (default: every drop step, ~40 cavity frames).
    #[arg(long, value_name = "N")]
    pub frame_stride: Option<usize>,
}

/// How much to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// A few minutes on a laptop: coarse resolutions, short end times.
    Quick,
    /// The paper's resolutions and end times (long: start in the background).
    Paper,
}

/// Flags of `cargo xtask validate`.
#[derive(Debug, clap::Args)]
pub struct ValidateArgs {
    /// Resolution / duration preset.
    #[arg(long, value_enum, default_value = "quick")]
    pub preset: Preset,
    /// Run only the cases whose kind (e.g. `lid_driven_cavity`, `kernels`) or scene file stem
    /// (e.g. `cavity_density_quintic`) contains this string.
    #[arg(long)]
    pub case: Option<String>,
    /// Output directory for reports and frames.
    #[arg(long, default_value = "target/validation")]
    pub out: PathBuf,
    /// Directory of scene files.
    #[arg(long, default_value = "cases")]
    pub cases: PathBuf,
    /// Compare against the reference tables in this directory instead of the copy compiled in
    /// from `cases/reference/` (files it lacks keep the compiled copy).
    #[arg(long)]
    pub references: Option<PathBuf>,
    /// Instead of the validation cases, run the accuracy-against-cost sweep (every scheme over
    /// three resolutions, both kernels, two solvers; a Δt refinement) and write sweep.md,
    /// sweep.csv and the error-against-wall-time plots. Takes tens of minutes.
    #[arg(long)]
    pub sweep: bool,
    /// Write every N-th particle frame to MCAP (default: every drop step, ~40 cavity frames).
    #[arg(long, value_name = "N")]
    pub frame_stride: Option<usize>,
    /// Cavity runs: checkpoint every N steps into the output directory.
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<usize>,
    /// Cavity runs: continue from their checkpoints (a `--preset paper` spanning sessions).
    #[arg(long)]
    pub resume: bool,
}
