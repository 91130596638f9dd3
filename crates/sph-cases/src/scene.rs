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
use sph_integrators::{FreeSurface, SchemeKind};
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
}

impl CaseKind {
    /// The case name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            CaseKind::EllipticalDrop => "elliptical_drop",
            CaseKind::SpheroidDrop => "spheroid_drop",
            CaseKind::PrescribedEllipse => "prescribed_ellipse",
            CaseKind::PrescribedEllipsoid => "prescribed_ellipsoid",
        }
    }

    /// The dimension the case is defined in.
    pub fn dim(self) -> usize {
        match self {
            CaseKind::EllipticalDrop | CaseKind::PrescribedEllipse => 2,
            CaseKind::SpheroidDrop | CaseKind::PrescribedEllipsoid => 3,
        }
    }
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
    /// Hessian of the DG equation. Default `eq25`.
    #[serde(default)]
    pub dg_hessian: DgHessianChoice,
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
            dg_hessian: DgHessianChoice::default(),
            quick: None,
        }
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
        if self.dim != self.case.dim() {
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
        if let Some(q) = &self.quick {
            if q.dx.is_some_and(|v| !positive(v)) {
                return bad("quick.dx", "must be a positive number".into());
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
}
