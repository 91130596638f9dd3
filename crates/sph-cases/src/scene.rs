//! Scene files: TOML under the repository's `cases/` directory.
//!
//! ```toml
//! case = "elliptical_drop"       # elliptical_drop | spheroid_drop | prescribed_ellipse | prescribed_ellipsoid
//! dim = 2
//! dx = 0.025                     # initial particle spacing
//! h_over_dx = 1.3                # smoothing length / spacing (default 1.3)
//! kernel = "quintic_spline"      # quintic_spline | wendland_c2 | cubic_spline (default quintic_spline)
//! dt = 2e-4                      # fixed time step
//! t_end = 0.003
//! schemes = ["euler", "predictor_corrector", "dg"]
//! [free_surface]                 # absent: no free surface (Dirichlet rows)
//! div_r_threshold = 1.5
//! [quick]                        # overrides for `cargo xtask validate` (quick preset)
//! dx = 0.05
//! ```
//!
//! Unknown keys are errors, and every value is range-checked by [`Scene::validate`].

use crate::CaseError;
use serde::{Deserialize, Serialize};
use sph_integrators::WallCondition;
use sph_integrators::{Effects, FreeSurface, SchemeKind, Shifting, SimConfig, Viscosity};
use sph_kernels::KernelKind;
use sph_operators::HessianForm;
use sph_pressure::SolverKind;

/// Which case a scene runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CaseKind {
    /// 2D free-surface drop of the paper's Section 5 (Eq. 29).
    EllipticalDrop,
    /// 3D free-surface prolate spheroid of Section 5 (Eq. 30).
    SpheroidDrop,
    /// 2D particles advected by a prescribed linear field (Section 3, Eq. 14).
    PrescribedEllipse,
    /// 3D particles advected by a prescribed linear field (Section 3, Eq. 15).
    PrescribedEllipsoid,
    /// Lid-driven cavity (Section 6): unit square (2D) or cube (3D), walls of dummy particles,
    /// lid `y = 1` moving in `+x`.
    LidDrivenCavity,
}

impl CaseKind {
    /// The case name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            CaseKind::EllipticalDrop => "elliptical_drop",
            CaseKind::SpheroidDrop => "spheroid_drop",
            CaseKind::PrescribedEllipse => "prescribed_ellipse",
            CaseKind::PrescribedEllipsoid => "prescribed_ellipsoid",
            CaseKind::LidDrivenCavity => "lid_driven_cavity",
        }
    }

    /// The dimension the case is defined in (the cavity's default: 2).
    pub fn dim(self) -> usize {
        match self {
            CaseKind::EllipticalDrop | CaseKind::PrescribedEllipse => 2,
            CaseKind::SpheroidDrop | CaseKind::PrescribedEllipsoid => 3,
            CaseKind::LidDrivenCavity => 2,
        }
    }

    /// Whether the case can run in `dim` dimensions.
    pub fn supports_dim(self, dim: usize) -> bool {
        match self {
            CaseKind::LidDrivenCavity => dim == 2 || dim == 3,
            _ => dim == self.dim(),
        }
    }
}

/// Parameters of the lid-driven cavity (`[cavity]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CavitySpec {
    /// Reynolds number `U L / ν` (L = 1); sets the viscosity.
    pub reynolds: f64,
    /// Lid speed `U`. Default 1.
    #[serde(default = "one")]
    pub lid_speed: f64,
    /// Layers of wall particles. Default: enough to fill the kernel support.
    pub wall_layers: Option<usize>,
    /// Spacing of the uniform probe array of the density error (Eq. 31). Default `dx`.
    pub probe_spacing: Option<f64>,
    /// Times at which the density-error field is written. Default none.
    #[serde(default)]
    pub snapshots: Vec<f64>,
    /// Steps between time-series records. Default: about 400 records per run.
    pub sample_every: Option<usize>,
    /// Ghia comparison tolerances `[rms, max]` of the centreline velocities. Default
    /// `[0.02, 0.05]`.
    pub ghia_tolerance: Option<[f64; 2]>,
    /// Whether the Ghia deviation is a pass/fail check (it is always measured). Default true.
    pub check_ghia: Option<bool>,
    /// How the walls' no-penetration condition enters the projection: `"continuation"`
    /// (default) or `"reflection"` (the condition of the runs before 2026-11-30), see
    /// [`WallCondition`].
    #[serde(default)]
    pub wall_condition: WallCondition,
}

fn one() -> f64 {
    1.0
}

/// Particle shifting as declared in a scene (the spacing is the scene's `dx`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShiftingSpec {
    /// Lind et al.'s `A` (they use 2).
    pub coefficient: f64,
}

/// Explicit effects a scene declares (`[effects]`). Absent ones are not computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectsSpec {
    /// Laminar viscosity `{ nu = ... }` (the cavity derives it from `reynolds` instead).
    pub viscosity: Option<Viscosity>,
    /// Body-force acceleration `[gx, gy, gz]`.
    pub gravity: Option<[f64; 3]>,
    /// Particle shifting `{ coefficient = 2.0 }`.
    pub shifting: Option<ShiftingSpec>,
}

/// DG Hessian choice in a scene (`"eq25"` or `"quadratic_fit"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DgHessianChoice {
    /// Paper Eq. 25 with coefficient d + 2.
    #[default]
    Eq25,
    /// Least-squares Hessian, exact for quadratic fields.
    QuadraticFit,
}

impl From<DgHessianChoice> for HessianForm {
    fn from(c: DgHessianChoice) -> Self {
        match c {
            DgHessianChoice::Eq25 => HessianForm::Eq25,
            DgHessianChoice::QuadraticFit => HessianForm::QuadraticFit,
        }
    }
}

/// Overrides applied by the quick validation preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuickOverrides {
    /// Coarser spacing.
    pub dx: Option<f64>,
    /// Shorter run.
    pub t_end: Option<f64>,
    /// Another time step (with a coarser `dx`).
    pub dt: Option<f64>,
    /// Cavity: whether the Ghia deviation is checked (a short quick run is not yet steady).
    pub check_ghia: Option<bool>,
}

/// A scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Case to run.
    pub case: CaseKind,
    /// Spatial dimension (must match the case).
    pub dim: usize,
    /// Initial particle spacing.
    pub dx: f64,
    /// `h / dx`. Default 1.3 (the paper's).
    #[serde(default = "default_h_over_dx")]
    pub h_over_dx: f64,
    /// Kernel. Default quintic spline.
    #[serde(default = "default_kernel")]
    pub kernel: KernelKind,
    /// Fixed time step.
    pub dt: f64,
    /// End time. Runs end on the last full step at or before it; a remaining fraction is taken
    /// as a separate short step and flagged in the records.
    pub t_end: f64,
    /// Schemes to run (each from the same initial state).
    pub schemes: Vec<SchemeKind>,
    /// Free surface; absent means none.
    pub free_surface: Option<FreeSurface>,
    /// Linear solver. Default BiCGSTAB + Jacobi.
    #[serde(default)]
    pub solver: SolverKind,
    /// Relative residual tolerance of the pressure solve. Default 1e-9.
    pub solver_tolerance: Option<f64>,
    /// Hessian of the DG equation. Default `eq25`.
    #[serde(default)]
    pub dg_hessian: DgHessianChoice,
    /// Lid-driven cavity parameters (required by, and only allowed for, `lid_driven_cavity`).
    pub cavity: Option<CavitySpec>,
    /// Explicit effects. Default: none.
    #[serde(default)]
    pub effects: EffectsSpec,
    /// Quick-preset overrides.
    pub quick: Option<QuickOverrides>,
}

fn default_h_over_dx() -> f64 {
    1.3
}

fn default_kernel() -> KernelKind {
    KernelKind::QuinticSpline
}

impl Scene {
    /// The paper's drop setup (Section 5) for `case` at spacing `dx` and step `dt`, run to
    /// `t_end`: quintic kernel, h = 1.3 dx, the default free-surface threshold of the dimension,
    /// all three schemes, Eq. 25 Hessian, default solver. Callers change what they study.
    pub fn paper_drop(case: CaseKind, dx: f64, dt: f64, t_end: f64) -> Self {
        Scene {
            case,
            dim: case.dim(),
            dx,
            h_over_dx: default_h_over_dx(),
            kernel: default_kernel(),
            dt,
            t_end,
            schemes: SchemeKind::ALL.to_vec(),
            free_surface: Some(FreeSurface::default_for(case.dim())),
            solver: SolverKind::default(),
            solver_tolerance: None,
            dg_hessian: DgHessianChoice::default(),
            cavity: None,
            effects: EffectsSpec::default(),
            quick: None,
        }
    }

    /// The numerical configuration of the scene (kernel, h, free surface, solver, DG Hessian,
    /// declared effects). Cases add what they derive (e.g. the cavity's viscosity).
    pub fn sim_config(&self) -> SimConfig {
        let mut config = SimConfig::new(self.kernel, self.h_over_dx * self.dx);
        config.free_surface = self.free_surface;
        config.solver = self.solver;
        if let Some(tol) = self.solver_tolerance {
            config.solve.rel_tolerance = tol;
        }
        config.dg_hessian = self.dg_hessian.into();
        config.effects = Effects {
            viscosity: self.effects.viscosity,
            gravity: self.effects.gravity,
            shifting: self.effects.shifting.map(|s| Shifting {
                coefficient: s.coefficient,
                spacing: self.dx,
            }),
        };
        config
    }

    /// Parses and validates a scene; `name` is used in error messages.
    pub fn parse(name: &str, text: &str) -> Result<Self, CaseError> {
        let scene: Scene = toml::from_str(text).map_err(|e| CaseError::Parse {
            scene: name.to_string(),
            message: e.to_string(),
        })?;
        scene.validate(name)?;
        Ok(scene)
    }

    /// The scene with the quick-preset overrides applied.
    pub fn quick(&self) -> Scene {
        let mut s = self.clone();
        if let Some(q) = &self.quick {
            if let Some(dx) = q.dx {
                s.dx = dx;
            }
            if let Some(t) = q.t_end {
                s.t_end = t;
            }
            if let Some(dt) = q.dt {
                s.dt = dt;
            }
            if let (Some(c), Some(g)) = (s.cavity.as_mut(), q.check_ghia) {
                c.check_ghia = Some(g);
            }
        }
        s
    }

    /// Range and consistency checks; errors name the key.
    pub fn validate(&self, name: &str) -> Result<(), CaseError> {
        let bad = |field: &'static str, message: String| {
            Err(CaseError::Invalid {
                scene: name.to_string(),
                field,
                message,
            })
        };
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !self.case.supports_dim(self.dim) {
            return bad(
                "dim",
                format!(
                    "is {}, but {} is a {}D case",
                    self.dim,
                    self.case.name(),
                    self.case.dim()
                ),
            );
        }
        if !positive(self.dx) {
            return bad("dx", format!("must be a positive number, got {}", self.dx));
        }
        if !(self.h_over_dx.is_finite() && (1.0..=3.0).contains(&self.h_over_dx)) {
            return bad(
                "h_over_dx",
                format!("must be in [1, 3], got {}", self.h_over_dx),
            );
        }
        if !positive(self.dt) {
            return bad("dt", format!("must be a positive number, got {}", self.dt));
        }
        if !positive(self.t_end) {
            return bad(
                "t_end",
                format!("must be a positive number, got {}", self.t_end),
            );
        }
        if self.t_end / self.dt > 1e7 {
            return bad(
                "t_end",
                format!(
                    "needs {:.1e} steps of dt = {}",
                    self.t_end / self.dt,
                    self.dt
                ),
            );
        }
        if self.schemes.is_empty() {
            return bad("schemes", "must name at least one scheme".into());
        }
        if let Some(fs) = self.free_surface {
            let d = self.dim as f64;
            if !(fs.div_r_threshold.is_finite()
                && fs.div_r_threshold > 0.0
                && fs.div_r_threshold < d)
            {
                return bad(
                    "free_surface.div_r_threshold",
                    format!("must be in (0, {d}), got {}", fs.div_r_threshold),
                );
            }
        }
        if self
            .solver_tolerance
            .is_some_and(|t| !(t.is_finite() && t > 0.0 && t < 1.0))
        {
            return bad("solver_tolerance", "must be in (0, 1)".into());
        }
        let cavity = self.case == CaseKind::LidDrivenCavity;
        match (&self.cavity, cavity) {
            (None, true) => {
                return bad("cavity", "section is required by lid_driven_cavity".into());
            }
            (Some(_), false) => {
                return bad(
                    "cavity",
                    format!(
                        "section is only valid for lid_driven_cavity, not {}",
                        self.case.name()
                    ),
                );
            }
            (Some(c), true) => {
                if !positive(c.reynolds) {
                    return bad(
                        "cavity.reynolds",
                        format!("must be positive, got {}", c.reynolds),
                    );
                }
                if !c.lid_speed.is_finite() || c.lid_speed == 0.0 {
                    return bad(
                        "cavity.lid_speed",
                        format!("must be finite and non-zero, got {}", c.lid_speed),
                    );
                }
                if c.wall_layers.is_some_and(|l| !(1..=10).contains(&l)) {
                    return bad("cavity.wall_layers", "must be in 1..=10".into());
                }
                if c.probe_spacing.is_some_and(|v| !positive(v) || v > 0.5) {
                    return bad("cavity.probe_spacing", "must be in (0, 0.5]".into());
                }
                if c.snapshots.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
                    return bad("cavity.snapshots", "must be non-negative times".into());
                }
                if c.sample_every == Some(0) {
                    return bad("cavity.sample_every", "must be at least 1".into());
                }
                if c.ghia_tolerance
                    .is_some_and(|[a, b]| !(positive(a) && positive(b)))
                {
                    return bad(
                        "cavity.ghia_tolerance",
                        "must be two positive numbers".into(),
                    );
                }
                let cells = 1.0 / self.dx;
                if (cells - cells.round()).abs() > 1e-6 * cells {
                    return bad(
                        "dx",
                        format!(
                            "must divide the unit cavity, got {} (1/dx = {cells})",
                            self.dx
                        ),
                    );
                }
                if self.free_surface.is_some() {
                    return bad("free_surface", "a closed cavity has no free surface".into());
                }
                if self.effects.viscosity.is_some() {
                    return bad(
                        "effects.viscosity",
                        "is set by cavity.reynolds in a cavity".into(),
                    );
                }
            }
            (None, false) => {}
        }
        if let Some(v) = self.effects.viscosity
            && !(v.nu.is_finite() && v.nu >= 0.0)
        {
            return bad("effects.viscosity.nu", format!("must be ≥ 0, got {}", v.nu));
        }
        if let Some(g) = self.effects.gravity
            && g.iter().any(|v| !v.is_finite())
        {
            return bad("effects.gravity", "must be finite".into());
        }
        if let Some(sh) = self.effects.shifting
            && !positive(sh.coefficient)
        {
            return bad("effects.shifting.coefficient", "must be positive".into());
        }
        if let Some(q) = &self.quick {
            if q.dx.is_some_and(|v| !positive(v)) {
                return bad("quick.dx", "must be a positive number".into());
            }
            if q.dt.is_some_and(|v| !positive(v)) {
                return bad("quick.dt", "must be a positive number".into());
            }
            if q.t_end.is_some_and(|v| !positive(v)) {
                return bad("quick.t_end", "must be a positive number".into());
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
case = "elliptical_drop"
dim = 2
dx = 0.025
dt = 2e-4
t_end = 0.003
schemes = ["euler", "dg"]
[free_surface]
div_r_threshold = 1.5
"#;

    #[test]
    fn parses_with_defaults() {
        let s = Scene::parse("t", GOOD).unwrap();
        assert_eq!(s.h_over_dx, 1.3);
        assert_eq!(s.kernel, KernelKind::QuinticSpline);
        assert_eq!(s.schemes, vec![SchemeKind::Euler, SchemeKind::Dg]);
        assert_eq!(s.quick(), s);
    }

    #[test]
    fn unknown_key_is_an_error_naming_it() {
        let e = Scene::parse("t", &format!("{GOOD}\nviscosity = 1.0"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("viscosity"), "{e}");
        let e = Scene::parse("t", &GOOD.replace("div_r_threshold", "threshold"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("threshold"), "{e}");
        let e = Scene::parse("t", &GOOD.replace("\"dg\"", "\"dgx\""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("dgx"), "{e}");
    }

    #[test]
    fn bad_values_name_the_key() {
        for (from, to, key) in [
            ("dx = 0.025", "dx = -0.025", "`dx`"),
            ("dt = 2e-4", "dt = 0.0", "`dt`"),
            ("dim = 2", "dim = 3", "`dim`"),
            (
                "div_r_threshold = 1.5",
                "div_r_threshold = 2.5",
                "div_r_threshold",
            ),
            ("schemes = [\"euler\", \"dg\"]", "schemes = []", "`schemes`"),
        ] {
            let e = Scene::parse("scene.toml", &GOOD.replace(from, to))
                .unwrap_err()
                .to_string();
            assert!(e.contains(key) && e.contains("scene.toml"), "{from} -> {e}");
        }
        let e = Scene::parse("t", "case = \"elliptical_drop\"\ndim = ")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line"), "{e}");
    }

    const CAVITY: &str = r#"
case = "lid_driven_cavity"
dim = 2
dx = 0.05
dt = 0.01
t_end = 1.0
schemes = ["dg"]
[cavity]
reynolds = 100
[effects]
shifting = { coefficient = 2.0 }
"#;

    #[test]
    fn cavity_scene_declares_its_effects() {
        let s = Scene::parse("c", CAVITY).unwrap();
        let c = s.sim_config();
        assert!(c.effects.shifting.is_some() && c.effects.gravity.is_none());
        // Viscosity comes from the Reynolds number (added by the case), not from the scene.
        assert!(c.effects.viscosity.is_none());
        assert!(Scene::parse("d", GOOD).unwrap().sim_config().effects == Default::default());
        assert!(Scene::parse("c", &CAVITY.replace("dim = 2", "dim = 3")).is_ok());
    }

    #[test]
    fn bad_cavity_values_name_the_key() {
        for (from, to, key) in [
            ("reynolds = 100", "reynolds = -1", "cavity.reynolds"),
            ("dx = 0.05", "dx = 0.03", "`dx`"),
            (
                "coefficient = 2.0",
                "coefficient = 0.0",
                "effects.shifting.coefficient",
            ),
            (
                "[cavity]",
                "[free_surface]\ndiv_r_threshold = 1.5\n[cavity]",
                "free_surface",
            ),
            (
                "[effects]",
                "[effects]\nviscosity = { nu = 0.01 }",
                "effects.viscosity",
            ),
            ("dim = 2", "dim = 4", "`dim`"),
        ] {
            let e = Scene::parse("cav.toml", &CAVITY.replace(from, to))
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{from} -> {e}");
        }
        let e = Scene::parse("c", &CAVITY.replace("[cavity]\nreynolds = 100\n", ""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("cavity"), "{e}");
        let e = Scene::parse("c", &format!("{CAVITY}\nlid = 2"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lid"), "{e}");
        let e = Scene::parse("d", &format!("{GOOD}\n[cavity]\nreynolds = 1"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("only valid"), "{e}");
    }
}
