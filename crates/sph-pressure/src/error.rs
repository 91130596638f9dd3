use thiserror::Error;

/// Errors of the linear solvers.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolveError {
    /// The iteration limit was reached, or the iteration stalled (an inner product vanished),
    /// before the tolerance.
    #[error(
        "{solver} did not converge: relative residual {rel_residual:.3e} after {iterations} iterations (tolerance {tolerance:.1e}){}",
        .stalled.map_or(String::new(), |why| format!("; the iteration stalled: {why}"))
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
        /// Why the iteration stopped before its limit, if it did: an inner product vanished or
        /// overflowed, which happens when the residual has stagnated at round-off.
        stalled: Option<&'static str>,
    },
    /// The iteration produced a non-finite value (BiCGSTAB: its iterate; GMRES: its residual
    /// or Arnoldi vector) or a singular Hessenberg matrix (GMRES).
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
