use sph_pressure::SolveInfo;

/// min / mean / max of `det F` over the step's non-free-surface particles, where `F` is the
/// renormalised SPH deformation gradient of the step's displacement `xⁿ⁺¹ − xⁿ` (paper Eq. 26).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DetFStats {
    /// Minimum.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// Maximum.
    pub max: f64,
}

/// What one time step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Step number (0-based).
    pub step: usize,
    /// Time at the end of the step.
    pub t: f64,
    /// Step size used.
    pub dt: f64,
    /// Pressure solve statistics.
    pub solve: SolveInfo,
    /// max |∇·uⁿ⁺¹| over non-free-surface particles, at the configuration the projection used.
    pub max_div_u: f64,
    /// det F of the step (if diagnostics are on).
    pub det_f: Option<DetFStats>,
    /// Number of free-surface (Dirichlet) particles.
    pub free_surface_particles: usize,
    /// Particles whose renormalisation matrix was singular (identity used instead).
    pub correction_fallbacks: usize,
    /// Rows where the quadratic-fit Hessian fell back to Eq. 25 (DG only).
    pub hessian_fallbacks: usize,
    /// Multiplier of the mean-zero pressure gauge (closed domains; 0 otherwise): the
    /// right-hand-side part incompatible with a constant pressure null space.
    pub gauge_multiplier: f64,
    /// Fluid particles outside the wall container after the step (0 without walls).
    pub wall_penetrations: usize,
    /// Wall time of the whole step in seconds.
    pub seconds: f64,
}
