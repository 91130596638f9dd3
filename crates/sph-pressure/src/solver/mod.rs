//! Linear solvers for the pressure equations. Dimension-free: they see CSR slices only.

mod amg;
mod bicgstab;
mod direct;
mod gmres;
mod precond;

pub use bicgstab::BiCgStab;
pub use direct::SparseLu;
pub use gmres::{GMRES_RESTART, Gmres};
pub use precond::Preconditioner;

use crate::SolveError;
use precond::PrecondState;
use rayon::prelude::*;
use std::time::Instant;

/// Stopping criteria of iterative solvers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveParams {
    /// Converged when the true relative residual `‖b − Ax‖₂ / ‖b‖₂` is at most this. Default 1e-9.
    pub rel_tolerance: f64,
    /// Iteration limit. Default 2000.
    pub max_iterations: usize,
}

impl Default for SolveParams {
    fn default() -> Self {
        Self {
            rel_tolerance: 1e-9,
            max_iterations: 2000,
        }
    }
}

/// Statistics of one solve, returned every step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveInfo {
    /// Iterations (0 for a direct solve or a zero right-hand side).
    pub iterations: usize,
    /// True relative residual `‖b − Ax‖₂ / ‖b‖₂`, recomputed after the solve.
    pub rel_residual: f64,
    /// Wall time of the solve in seconds (setup included).
    pub seconds: f64,
    /// Of which the preconditioner's set-up (factorisation, multigrid hierarchy).
    pub setup_seconds: f64,
}

/// A square system `A x = b` with `A` in CSR form (`offsets`, sorted `cols`, `values`),
/// optionally bordered by one more unknown (see [`Border`]).
#[derive(Clone, Copy, Debug)]
pub struct CsrSystem<'a> {
    /// Row offsets (`n_body + 1`; they need not start at 0).
    pub offsets: &'a [usize],
    /// Column indices, sorted within each row.
    pub cols: &'a [u32],
    /// Values aligned with `cols`.
    pub values: &'a [f64],
    /// Right-hand side (`n`, the border's entry last).
    pub rhs: &'a [f64],
    /// The border, if any: one more unknown and row beside the CSR body, kept out of it so
    /// that a gauge does not copy the matrix (see [`MeanZeroGauge`](crate::MeanZeroGauge)).
    pub border: Option<Border<'a>>,
}

/// A border of a [`CsrSystem`] whose CSR body `M` has `m` rows: unknown `m` (the last) enters
/// each of the first `rows` rows with coefficient `column`, and row `m` is `row` (`m + 1`
/// values: the coefficients of unknowns `0 … m − 1`, then of unknown `m`):
///
/// ```text
/// [ M          column·1_rows ] [p]   [b_body]
/// [ row[..m]   row[m]        ] [λ] = [b_m   ]
/// ```
///
/// The bordered system is the CSR matrix whose row `i < rows` is `M`'s row followed by the
/// entry `(m, column)` and whose row `m` holds every column; solvers treat it so to the last
/// bit (the products sum each row's terms in that matrix's order), without building it.
#[derive(Clone, Copy, Debug)]
pub struct Border<'a> {
    /// Rows of the body coupled to the border's unknown (the first `rows`).
    pub rows: usize,
    /// Their coefficient of the border's unknown.
    pub column: f64,
    /// The border row: `m + 1` coefficients, the border unknown's own last.
    pub row: &'a [f64],
}

impl CsrSystem<'_> {
    /// Number of unknowns (the body's rows, plus one with a border).
    pub fn n(&self) -> usize {
        self.body_rows() + usize::from(self.border.is_some())
    }

    /// Rows of the CSR body.
    pub fn body_rows(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Index into `cols`/`values` of body row `i`'s diagonal entry, if the row has one
    /// (columns sorted, so a binary search).
    pub fn diagonal_position(&self, i: usize) -> Option<usize> {
        let a = self.offsets[i];
        self.cols[a..self.offsets[i + 1]]
            .binary_search(&(i as u32))
            .ok()
            .map(|k| a + k)
    }

    /// Row `i`'s diagonal entry, if it has one (the border row always has).
    pub fn diagonal(&self, i: usize) -> Option<f64> {
        match self.border {
            Some(b) if i == self.body_rows() => Some(b.row[i]),
            _ => self.diagonal_position(i).map(|k| self.values[k]),
        }
    }

    /// `y = A x` (the border included).
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        crate::csr::Operator::new(self).matvec(x, y);
    }

    /// Backward error of `x`, `‖b − A x‖₂ / (‖ |A| |x| ‖₂ + ‖b‖₂)`: the residual against the size
    /// of the terms it is the sum of. Each row's residual `b_i − Σ_k a_ik x_k` computed in floating
    /// point is wrong by up to a few ε `Σ_k |a_ik| |x_k|` (Higham 2002, §3.5), so the round-off floor
    /// of a solve is a modest multiple of machine precision in this measure, at any size. Unlike
    /// the residual relative to `‖b‖` it does not depend on how small `b` is against `A x`: a
    /// warm-started solve of a nearly hydrostatic state, whose right-hand side is a small
    /// remainder of large pressures, stagnates at a relative residual of 1e-8–1e-7 at a backward
    /// error near 1e-15. Unlike the normwise form `‖b − A x‖ / (‖A‖_F ‖x‖ + ‖b‖)` (Rigal & Gaches
    /// 1967), which it bounds from above (Cauchy–Schwarz row by row), it does not grow lenient
    /// with the number of unknowns: `‖A‖_F ‖x‖` grows as `N` where the residual grows as `√N`.
    ///
    /// The norms are computed scaled by their largest entry, so an iterate too large for its
    /// squares (a run-away iteration) is measured, not read as `‖ |A| |x| ‖₂ = ∞` and a backward
    /// error of 0; a measure that is still not finite is infinite.
    pub fn backward_error(&self, x: &[f64], scratch: &mut [f64]) -> f64 {
        self.matvec(x, scratch);
        let r = scaled_norm(scratch.iter().zip(self.rhs).map(|(ax, b)| b - ax));
        let b = scaled_norm(self.rhs.iter().copied());
        let m = self.body_rows();
        let (offsets, cols, values) = (self.offsets, self.cols, self.values);
        let coupled = self
            .border
            .map_or((0, 0.0, 0.0), |bd| (bd.rows, bd.column.abs(), x[m].abs()));
        scratch[..m]
            .par_iter_mut()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(i, s)| {
                let (lo, hi) = (offsets[i], offsets[i + 1]);
                let mut sum: f64 = values[lo..hi]
                    .iter()
                    .zip(&cols[lo..hi])
                    .map(|(a, &c)| (a * x[c as usize]).abs())
                    .sum();
                if i < coupled.0 {
                    sum += coupled.1 * coupled.2;
                }
                *s = sum;
            });
        if let Some(border) = self.border {
            scratch[m] = border.row.iter().zip(x).map(|(a, v)| (a * v).abs()).sum();
        }
        let scale = scaled_norm(scratch[..self.n()].iter().copied()) + b;
        if !(r.is_finite() && scale.is_finite()) {
            f64::INFINITY
        } else if scale > 0.0 {
            r / scale
        } else {
            r
        }
    }

    /// Whether a solve that ended with `x` met `tolerance`: the true relative residual within
    /// 10 times it (room for the recurrence's drift from the true residual), or, where that is
    /// not attainable in floating point, the backward error within it (see
    /// [`backward_error`](Self::backward_error)) — for an `x` that is at least better than
    /// `x = 0` (relative residual below 1): the round-off floor lies below `‖b‖`, and an
    /// iteration that ran away along a nearly singular direction can reach a small backward
    /// error with a residual many times `‖b‖`.
    pub fn accepts(
        &self,
        x: &[f64],
        rel_residual: f64,
        tolerance: f64,
        scratch: &mut [f64],
    ) -> bool {
        rel_residual <= 10.0 * tolerance
            || (rel_residual < 1.0 && self.backward_error(x, scratch) <= tolerance)
    }

    /// `(‖b − A x‖², ‖b‖²)`, `A x` computed into `scratch`.
    fn residual_squares(&self, x: &[f64], scratch: &mut [f64]) -> (f64, f64) {
        self.matvec(x, scratch);
        let r: f64 = scratch
            .iter()
            .zip(self.rhs)
            .map(|(ax, b)| (b - ax) * (b - ax))
            .sum();
        (r, self.rhs.iter().map(|b| b * b).sum())
    }

    /// True relative residual of `x`.
    pub fn rel_residual(&self, x: &[f64], scratch: &mut [f64]) -> f64 {
        let (r, b) = self.residual_squares(x, scratch);
        if b == 0.0 { r.sqrt() } else { (r / b).sqrt() }
    }
}

/// `‖v‖₂` without overflow or underflow of the squares: scaled by the largest `|v_i|` (summed in
/// order: the same bits on any number of threads). Not finite if an entry is not.
fn scaled_norm<I: Iterator<Item = f64> + Clone>(v: I) -> f64 {
    let m = v.clone().fold(0.0f64, |m, x| m.max(x.abs()));
    if !m.is_finite() || v.clone().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    if m == 0.0 {
        return 0.0;
    }
    m * v.map(|x| (x / m) * (x / m)).sum::<f64>().sqrt()
}

/// A bordered system written out as one CSR matrix (see [`Border`]), for the solvers that
/// factorise the matrix itself (ILU(0), sparse LU) and for tests. Buffers kept between uses.
#[derive(Clone, Debug, Default)]
pub(crate) struct Materialised {
    offsets: Vec<usize>,
    cols: Vec<u32>,
    values: Vec<f64>,
}

impl Materialised {
    /// Writes `a` (bordered or not) out as one CSR matrix with offsets from 0.
    pub(crate) fn fill(&mut self, a: &CsrSystem<'_>) {
        let m = a.body_rows();
        let (rows, column) = a.border.map_or((0, 0.0), |b| (b.rows, b.column));
        // Body row i starts min(i, rows) places further on: the border column is appended to
        // each of the first `rows` rows. Copied in parallel, row by row.
        let first = a.offsets[0];
        self.offsets.resize(m + 1, 0);
        self.offsets
            .par_iter_mut()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(i, o)| *o = a.offsets[i] - first + i.min(rows));
        let body = self.offsets[m];
        self.cols.resize(body, 0);
        self.values.resize(body, 0.0);
        crate::csr::for_each_row_mut2(
            &self.offsets,
            &mut self.cols,
            &mut self.values,
            &|i, cols, vals| {
                let (s, e) = (a.offsets[i], a.offsets[i + 1]);
                cols[..e - s].copy_from_slice(&a.cols[s..e]);
                vals[..e - s].copy_from_slice(&a.values[s..e]);
                if i < rows {
                    cols[e - s] = m as u32;
                    vals[e - s] = column;
                }
            },
        );
        if let Some(b) = a.border {
            self.cols.extend(0..=m as u32);
            self.values.extend_from_slice(&b.row[..=m]);
            self.offsets.push(self.cols.len());
        }
    }

    /// Whether nothing has been written yet.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.offsets.is_empty()
    }

    /// The written-out system, with `rhs`.
    pub(crate) fn system<'a>(&'a self, rhs: &'a [f64]) -> CsrSystem<'a> {
        CsrSystem {
            offsets: &self.offsets,
            cols: &self.cols,
            values: &self.values,
            rhs,
            border: None,
        }
    }
}

/// A linear solver. `x` holds the initial guess on entry (warm start: the previous pressure)
/// and the solution on exit.
pub trait LinearSolver: Send {
    /// Name for reports.
    fn name(&self) -> &'static str;
    /// Solves `A x = b`. A solver may keep set-up work between calls (BiCGSTAB + AMG keeps its
    /// hierarchy while it serves the systems of a run, which change slowly from step to step);
    /// the result then depends on the earlier calls since the last
    /// [`invalidate_setup`](Self::invalidate_setup).
    fn solve(
        &mut self,
        system: &CsrSystem<'_>,
        x: &mut [f64],
        params: &SolveParams,
    ) -> Result<SolveInfo, SolveError>;

    /// Forgets any set-up work kept from earlier solves: the next solve starts as a new
    /// solver's would. Called where a run is checkpointed, so a resumed run (a new solver)
    /// and the uninterrupted one solve alike.
    fn invalidate_setup(&mut self) {}

    /// Whether the next solve starts as a new solver's would (nothing kept from earlier solves
    /// is used by it): a checkpoint taken now resumes to the same bits as the run that goes
    /// on. (Required, so that a wrapper cannot answer for what it wraps by default.)
    fn next_solve_is_fresh(&self) -> bool;
}

/// A preconditioned Krylov method: its iterations after the preconditioner's setup, and the
/// state [`krylov_solve`] shares between methods.
pub(crate) trait Krylov: LinearSolver {
    fn precond(&self) -> Preconditioner;
    /// The preconditioner state and the buffer for the warm start.
    fn parts(&mut self) -> (&mut PrecondState, &mut Vec<f64>);
    /// The iterations for `a` (right-hand side norm `bnorm`), after the preconditioner's
    /// setup (started at `t0`).
    fn iterate(
        &mut self,
        a: &CsrSystem<'_>,
        x: &mut [f64],
        params: &SolveParams,
        bnorm: f64,
        t0: Instant,
    ) -> Result<SolveInfo, SolveError>;
}

/// A Krylov solve around the preconditioner's life cycle: a zero right-hand side gives zero;
/// AMG keeps its hierarchy between solves (`PrecondState::setup`), and a solve that fails
/// with a kept hierarchy is repeated from the same warm start with a fresh one.
pub(crate) fn krylov_solve<K: Krylov>(
    k: &mut K,
    a: &CsrSystem<'_>,
    x: &mut [f64],
    params: &SolveParams,
) -> Result<SolveInfo, SolveError> {
    if a.border.is_some() && k.precond() == Preconditioner::Ilu0 {
        // ILU(0) factorises the matrix itself: the border is written out.
        let mut m = std::mem::take(&mut k.parts().0.materialised);
        m.fill(a);
        let result = krylov_solve(k, &m.system(a.rhs), x, params);
        k.parts().0.materialised = m;
        return result;
    }
    let t0 = Instant::now();
    assert_eq!(x.len(), a.n());
    let bnorm = bicgstab::dot(a.rhs, a.rhs).sqrt();
    if bnorm == 0.0 {
        x.fill(0.0);
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: 0.0,
            seconds: t0.elapsed().as_secs_f64(),
            setup_seconds: 0.0,
        });
    }
    let kind = k.precond();
    let amg = kind == Preconditioner::Amg;
    {
        let (state, x0) = k.parts();
        if amg {
            x0.clear();
            x0.extend_from_slice(x);
        }
        state.setup(kind, a, true)?;
    }
    let warm = x.iter().any(|v| *v != 0.0);
    let mut spent = 0;
    let mut result = k.iterate(a, x, params, bnorm, t0);
    if amg && result.is_err() && k.parts().0.reused() {
        spent += failed_iterations(&result);
        let (state, x0) = k.parts();
        x.copy_from_slice(x0);
        state.invalidate();
        state.setup(kind, a, false)?;
        result = k.iterate(a, x, params, bnorm, t0);
    }
    // A Krylov iteration can run away from a warm start although it converges from zero (a
    // 100² cavity's BiCGSTAB + AMG, ~10 iterations per step, once diverged to a relative
    // residual of 1e150 where the cold start took 14): a failed warm start is tried once more
    // from zero, and the result is judged as any other.
    if warm && result.is_err() {
        spent += failed_iterations(&result);
        x.fill(0.0);
        result = k.iterate(a, x, params, bnorm, t0);
    }
    match &mut result {
        Ok(info) => {
            info.iterations += spent;
            k.parts().0.record_iterations(info.iterations);
        }
        Err(
            SolveError::NoConvergence { iterations, .. } | SolveError::Breakdown { iterations, .. },
        ) => *iterations += spent,
        Err(_) => {}
    }
    result
}

/// Iterations a failed attempt spent (0 for a success or a failure before iterating).
fn failed_iterations(result: &Result<SolveInfo, SolveError>) -> usize {
    match result {
        Err(
            SolveError::NoConvergence { iterations, .. } | SolveError::Breakdown { iterations, .. },
        ) => *iterations,
        _ => 0,
    }
}

/// Solver choice as written in a scene file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// BiCGSTAB with Jacobi preconditioning (no setup, parallel); its iterations grow with the
    /// resolution (175 per step in a 100² cavity, over 2 000 at 1000²).
    BicgstabJacobi,
    /// BiCGSTAB with ILU(0) preconditioning (4–5× fewer iterations, sequential setup).
    BicgstabIlu0,
    /// BiCGSTAB with smoothed-aggregation AMG preconditioning (iterations nearly independent
    /// of the resolution; the hierarchy is kept for up to 10 solves while it serves). The
    /// default: in the runs of `cargo xtask validate` it takes 4–6 iterations per step where
    /// Jacobi takes 23–61, and the runs are as fast or faster at every size measured, from the
    /// 20² cavity and the 2D drop (3.5k particles) to the 3D spheroid (16k particles, ~250
    /// neighbours per row) and the 100² cavity (3× faster) (docs/validation.md, "Linear solvers").
    #[default]
    BicgstabAmg,
    /// Restarted GMRES([`GMRES_RESTART`]) with the same AMG preconditioner: one
    /// preconditioner application per iteration where BiCGSTAB takes two, and convergence
    /// judged on the true residual.
    GmresAmg,
    /// faer sparse LU (direct). Small systems and tests only.
    SparseLu,
}

impl SolverKind {
    /// The name as written in scene files and outputs (`bicgstab_jacobi`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::BicgstabJacobi => "bicgstab_jacobi",
            SolverKind::BicgstabIlu0 => "bicgstab_ilu0",
            SolverKind::BicgstabAmg => "bicgstab_amg",
            SolverKind::GmresAmg => "gmres_amg",
            SolverKind::SparseLu => "sparse_lu",
        }
    }
}

/// A solver chosen at run time.
#[derive(Debug)]
pub enum AnySolver {
    /// See [`BiCgStab`] (boxed: it owns its work buffers).
    BiCgStab(Box<BiCgStab>),
    /// See [`Gmres`].
    Gmres(Box<Gmres>),
    /// See [`SparseLu`].
    SparseLu(SparseLu),
}

impl AnySolver {
    /// A new solver of the given kind.
    pub fn new(kind: SolverKind) -> Self {
        match kind {
            SolverKind::BicgstabJacobi => {
                AnySolver::BiCgStab(Box::new(BiCgStab::new(Preconditioner::Jacobi)))
            }
            SolverKind::BicgstabIlu0 => {
                AnySolver::BiCgStab(Box::new(BiCgStab::new(Preconditioner::Ilu0)))
            }
            SolverKind::BicgstabAmg => {
                AnySolver::BiCgStab(Box::new(BiCgStab::new(Preconditioner::Amg)))
            }
            SolverKind::GmresAmg => {
                AnySolver::Gmres(Box::new(Gmres::new(Preconditioner::Amg, GMRES_RESTART)))
            }
            SolverKind::SparseLu => AnySolver::SparseLu(SparseLu),
        }
    }
}

impl LinearSolver for AnySolver {
    fn name(&self) -> &'static str {
        match self {
            AnySolver::BiCgStab(s) => s.name(),
            AnySolver::Gmres(s) => s.name(),
            AnySolver::SparseLu(s) => s.name(),
        }
    }
    fn solve(
        &mut self,
        system: &CsrSystem<'_>,
        x: &mut [f64],
        params: &SolveParams,
    ) -> Result<SolveInfo, SolveError> {
        match self {
            AnySolver::BiCgStab(s) => s.solve(system, x, params),
            AnySolver::Gmres(s) => s.solve(system, x, params),
            AnySolver::SparseLu(s) => s.solve(system, x, params),
        }
    }
    fn invalidate_setup(&mut self) {
        match self {
            AnySolver::BiCgStab(s) => s.invalidate_setup(),
            AnySolver::Gmres(s) => s.invalidate_setup(),
            AnySolver::SparseLu(s) => s.invalidate_setup(),
        }
    }
    fn next_solve_is_fresh(&self) -> bool {
        match self {
            AnySolver::BiCgStab(s) => s.next_solve_is_fresh(),
            AnySolver::Gmres(s) => s.next_solve_is_fresh(),
            AnySolver::SparseLu(s) => s.next_solve_is_fresh(),
        }
    }
}

#[cfg(test)]
mod tests;
