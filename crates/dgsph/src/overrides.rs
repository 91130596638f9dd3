//! Command-line changes to a scene (`--dt`, `--schemes`, ...) and the presets, applied before a
//! run and validated like the scene itself.

use crate::session::AppError;
use sph_cases::blocks::FreeSurfaceSpec;
use sph_cases::{Scene, ShiftingSpec, registry};

/// How much of a scene to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// The scene's `[quick]` overrides: coarse, short (validation on every change).
    Quick,
    /// The scene as written (the paper's resolutions and end times for the paper's cases).
    #[value(alias = "paper")]
    Full,
}

impl Preset {
    /// The scene with this preset applied.
    pub fn apply(self, scene: &Scene) -> Scene {
        match self {
            Preset::Quick => scene.quick(),
            Preset::Full => scene.clone(),
        }
    }

    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Quick => "quick",
            Preset::Full => "full",
        }
    }
}

/// Changes to a scene from the command line.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct Overrides {
    /// Override the particle spacing.
    #[arg(long, allow_negative_numbers = true)]
    pub dx: Option<f64>,
    /// Override the time step.
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Override the end time.
    #[arg(long, allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Override the schemes (comma-separated: `euler,predictor_corrector,dg`).
    #[arg(long)]
    pub schemes: Option<String>,
    /// Override the kernel (`quintic_spline`, `wendland_c2`, `cubic_spline`).
    #[arg(long)]
    pub kernel: Option<String>,
    /// Override the solver (`bicgstab_jacobi`, `bicgstab_ilu0`, `bicgstab_amg`, `gmres_amg`,
    /// `sparse_lu`).
    #[arg(long)]
    pub solver: Option<String>,
    /// Override the solver's relative tolerance.
    #[arg(long, allow_negative_numbers = true)]
    pub solver_tolerance: Option<f64>,
    /// Override the free-surface threshold on ∇·r.
    #[arg(long, allow_negative_numbers = true)]
    pub div_r_threshold: Option<f64>,
    /// Override the DG Hessian (`eq25` or `quadratic_fit`).
    #[arg(long)]
    pub dg_hessian: Option<String>,
    /// Override the cavity's Reynolds number.
    #[arg(long, allow_negative_numbers = true)]
    pub re: Option<f64>,
    /// Declare particle shifting with this coefficient A (Lind et al. 2012).
    #[arg(long, allow_negative_numbers = true)]
    pub shifting: Option<f64>,
    /// Override the steps between records (`[output] sample_every`).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub sample_every: Option<u64>,
}

fn named<T: serde::de::DeserializeOwned>(flag: &str, value: &str) -> Result<T, AppError> {
    serde_json::from_value(serde_json::Value::String(value.trim().to_string()))
        .map_err(|_| AppError::Input(anyhow::anyhow!("{flag}: unknown value {value:?}")))
}

impl Overrides {
    /// The scene with the overrides applied, re-validated (errors name the flag's key).
    pub fn apply(&self, mut scene: Scene) -> Result<Scene, AppError> {
        if let Some(dx) = self.dx {
            scene.dx = dx;
        }
        if let Some(dt) = self.dt {
            scene.dt = dt;
        }
        if let Some(t) = self.t_end {
            scene.t_end = t;
        }
        if let Some(list) = &self.schemes {
            scene.schemes = list
                .split(',')
                .map(|s| named("--schemes", s))
                .collect::<Result<_, _>>()?;
        }
        if let Some(k) = &self.kernel {
            scene.kernel = named("--kernel", k)?;
        }
        if let Some(k) = &self.solver {
            scene.solver = named("--solver", k)?;
        }
        if let Some(t) = self.solver_tolerance {
            scene.solver_tolerance = Some(t);
        }
        if let Some(th) = self.div_r_threshold {
            let Some(spec) = scene.free_surface else {
                return Err(AppError::Input(anyhow::anyhow!(
                    "--div-r-threshold applies to scenes with a free surface; this one has no \
                     [free_surface] table"
                )));
            };
            scene.free_surface = Some(FreeSurfaceSpec {
                div_r_threshold: Some(th),
                ..spec
            });
        }
        if let Some(h) = &self.dg_hessian {
            scene.dg_hessian = named("--dg-hessian", h)?;
        }
        if let Some(re) = self.re {
            match scene.cavity.as_mut() {
                Some(c) => c.reynolds = re,
                None => {
                    return Err(AppError::Input(anyhow::anyhow!(
                        "--re applies to lid_driven_cavity scenes only"
                    )));
                }
            }
        }
        if let Some(a) = self.shifting {
            // A scene's other shifting keys stay as declared; only the coefficient changes.
            scene.effects.shifting = Some(match scene.effects.shifting {
                Some(spec) => ShiftingSpec {
                    coefficient: a,
                    ..spec
                },
                None => ShiftingSpec {
                    coefficient: a,
                    velocity: None,
                    velocity_correction: None,
                },
            });
        }
        if let Some(n) = self.sample_every {
            scene.output.sample_every = Some(usize::try_from(n).unwrap_or(usize::MAX));
        }
        scene
            .validate("the scene with the command-line overrides")
            .and_then(|()| registry::validate(&scene, "the scene with the command-line overrides"))
            .map_err(|e| AppError::Input(e.into()))?;
        Ok(scene)
    }
}
