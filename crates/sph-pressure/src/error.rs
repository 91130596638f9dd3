use thiserror::Error;

/// Errors of the linear solvers.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolveError {
    /// The iteration limit was reached before the tolerance.
    #[error(
        "{solver} did not converge: relative residual {rel_residual:.3e} after {iterations} iterations (tolerance {tolerance:.1e})"
    )]
    NoConvergence {
        /// Solver name.
        solver: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// True relative residual ‖b − Ax‖/‖b‖ at exit.
        rel_residual: f64,
        /// Requested tolerance.
        tolerance: f64,
    },
    /// The iteration broke down (a zero inner product) or produced a non-finite value.
    #[error("{solver} broke down after {iterations} iterations: {reason}")]
    Breakdown {
        /// Solver name.
        solver: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// What happened.
        reason: &'static str,
    },
    /// The matrix has a zero (or non-finite) diagonal entry or pivot.
    #[error("matrix row {row} has a zero or non-finite pivot ({value:e})")]
    SingularPivot {
        /// Offending row.
        row: usize,
        /// Its pivot value.
        value: f64,
    },
    /// The direct solver failed.
    #[error("sparse LU failed: {0}")]
    Direct(String),
}

/// Errors of pressure-equation assembly.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PressureError {
    /// A right-hand side or matrix entry is not finite.
    #[error("non-finite {what} in row {row} of the pressure equation")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
        /// Row (particle index).
        row: usize,
    },
}
