//! The typed results of runs: `<run>.run.json` beside each run's files, and the `summary.json`
//! of a validation. Field names are part of the interface (`docs/outputs.md`); a change of
//! meaning bumps [`SCHEMA_VERSION`].

use serde::{Deserialize, Serialize};
use sph_cases::{Check, Criterion};
use std::collections::BTreeMap;

/// Version of the `summary.json` and `.run.json` layouts.
pub const SCHEMA_VERSION: u32 = 1;

/// Wall time and run count of one pass, summed over a run's steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhaseRecord {
    /// Seconds.
    pub seconds: f64,
    /// How many times it ran.
    pub runs: u64,
}

/// One scheme's run of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Layout version.
    pub schema_version: u32,
    /// Case kind (`lid_driven_cavity`, `flow`, ...).
    pub case: String,
    /// Run name (the scene file's stem or `--tag`); outputs are `<name>_<scheme>.*`.
    pub name: String,
    /// Scheme (`euler`, `predictor_corrector`, `dg`).
    pub scheme: String,
    /// Kernel (`quintic_spline`, `wendland_c2`, `cubic_spline`).
    pub kernel: String,
    /// Linear solver (`bicgstab_jacobi`, ...).
    pub solver: String,
    /// Dimension.
    pub dim: usize,
    /// Particle spacing.
    pub dx: f64,
    /// Time step.
    pub dt: f64,
    /// Fluid particles.
    pub fluid: usize,
    /// Wall particles.
    pub walls: usize,
    /// Steps taken over the whole run (a resumed run's earlier segments included).
    pub steps: usize,
    /// The step count reached.
    pub step: usize,
    /// The time reached.
    pub t: f64,
    /// Wall time of the run in seconds (of a resumed run: its last segment).
    pub wall_s: f64,
    /// Mean pressure-solver iterations per step.
    pub solver_iters_mean: f64,
    /// `completed`, `interrupted` (a signal stopped it after a step; its checkpoint continues
    /// it), or `failed: <the step error>`.
    pub status: String,
    /// Named results of the run (`null`: not finite, e.g. no steady state reached).
    pub results: BTreeMap<String, Option<f64>>,
    /// Time per pass over the run (passes that never ran are absent).
    pub phases: BTreeMap<String, PhaseRecord>,
}

/// One check as recorded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckRecord {
    /// Case (and run name).
    pub case: String,
    /// What is compared.
    pub check: String,
    /// The measured value (`null`: not finite, which fails).
    pub value: Option<f64>,
    /// What it must satisfy.
    pub criterion: Criterion,
    /// Whether it did.
    pub pass: bool,
    /// Wall time of the scene that produced the check.
    pub wall_s: f64,
    /// Where the reference comes from.
    pub source: String,
    /// Why the scene declares this check a known failure (it then does not fail a validation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_failure: Option<String>,
}

impl CheckRecord {
    /// The record of `check` measured in a scene that took `wall_s`.
    pub fn new(check: &Check, wall_s: f64) -> Self {
        Self {
            case: check.case.clone(),
            check: check.name.clone(),
            value: check.value.is_finite().then_some(check.value),
            criterion: check.criterion,
            pass: check.passed(),
            wall_s,
            source: check.source.clone(),
            known_failure: check.known_failure.clone(),
        }
    }
}

/// `summary.json` of a validation run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Layout version.
    pub schema_version: u32,
    /// `quick` or `paper`.
    pub preset: String,
    /// Suite (`default` or `hard`).
    pub suite: String,
    /// Git revision at launch (`-dirty` if the tree had changes), or `unknown`.
    pub git: String,
    /// Where the reference tables came from.
    pub references: String,
    /// True if every check passed and every run completed.
    pub passed: bool,
    /// Wall time of the whole validation in seconds.
    pub wall_s: f64,
    /// Every check.
    pub checks: Vec<CheckRecord>,
    /// Every run.
    pub runs: Vec<RunRecord>,
}

/// `Some(v)` for a finite `v`.
pub fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}
