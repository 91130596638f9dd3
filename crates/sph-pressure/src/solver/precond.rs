use crate::SolveError;
use crate::solver::CsrSystem;
use crate::solver::amg::Amg;
use rayon::prelude::*;

/// Preconditioner of the Krylov solvers ([`BiCgStab`](super::BiCgStab), [`Gmres`](super::Gmres)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preconditioner {
    /// `M = diag(A)`: parallel, no setup cost.
    Jacobi,
    /// Incomplete LU with zero fill on the matrix's own pattern (Saad 2003, Alg. 10.4).
    /// Sequential setup and triangular solves; cuts iterations several-fold on SPH Laplacians.
    Ilu0,
    /// Smoothed-aggregation algebraic multigrid, one cycle per application (see the
    /// `amg` module). Iterations nearly independent of resolution; hierarchy kept between
    /// solves while it serves.
    Amg,
}

/// Factorised preconditioner state, reused across solves (buffers only).
#[derive(Clone, Debug, Default)]
pub(crate) struct PrecondState {
    inv_diag: Vec<f64>,
    /// ILU(0) factors on the pattern of A: strict lower part is L (unit diagonal), the rest U.
    lu: Vec<f64>,
    /// Position of the diagonal entry in each row.
    diag_pos: Vec<usize>,
    amg: Amg,
    /// Hierarchy reuse (see [`AMG_REUSE_MAX_AGE`]): solves since the last full AMG setup,
    /// iterations of the first solve after it and of the last solve; `amg_valid` is false
    /// until a full setup and after [`PrecondState::invalidate`].
    amg_age: usize,
    amg_fresh_iterations: usize,
    amg_last_iterations: usize,
    amg_valid: bool,
    amg_fresh: bool,
    /// A bordered system written out for ILU(0) (see `krylov_solve`).
    pub(crate) materialised: super::Materialised,
}

/// Solves for which one AMG hierarchy is kept at most. Between full setups only the fine level
/// follows the matrix. Measured on the 100² Re 100 cavity (DG, one thread, 100 steps): keeping
/// the coarse levels for 10 / 20 / 50 solves gave 9.4 / 10.6 / 19.5 iterations per step
/// against 8.6 rebuilt every step, and 0.89 / 0.91 / 1.15× the step time.
pub(crate) const AMG_REUSE_MAX_AGE: usize = 10;

/// A kept hierarchy is rebuilt once the last solve needed more than this many times the
/// iterations of the first solve after its setup (plus one).
pub(crate) const AMG_REUSE_GROWTH: f64 = 1.25;

impl PrecondState {
    #[cfg(test)]
    pub(crate) fn amg_shape(&self) -> Vec<(usize, usize)> {
        self.amg.shape()
    }

    #[cfg(test)]
    pub(crate) fn amg_wrote_out(&self) -> bool {
        self.amg.wrote_out()
    }

    /// Forgets the AMG hierarchy: the next setup builds it whole.
    pub(crate) fn invalidate(&mut self) {
        self.amg_valid = false;
    }

    /// Records the iterations of the solve that followed the last `setup`.
    pub(crate) fn record_iterations(&mut self, iterations: usize) {
        if self.amg_fresh {
            self.amg_fresh_iterations = iterations;
        }
        self.amg_last_iterations = iterations;
    }

    /// Whether the next `setup` (with `reuse`) will build the preconditioner whole, as a new
    /// solver's would: nothing kept from earlier solves can then influence later ones.
    pub(crate) fn next_setup_is_fresh(&self, kind: Preconditioner) -> bool {
        kind != Preconditioner::Amg || !self.keeps(true)
    }

    /// Whether a `setup` with `reuse` keeps the AMG hierarchy (the reuse policy).
    fn keeps(&self, reuse: bool) -> bool {
        reuse
            && self.amg_valid
            && self.amg_age + 1 < AMG_REUSE_MAX_AGE
            && (self.amg_last_iterations as f64)
                <= AMG_REUSE_GROWTH * self.amg_fresh_iterations as f64 + 1.0
    }

    /// Whether the last `setup` reused a kept AMG hierarchy.
    pub(crate) fn reused(&self) -> bool {
        !self.amg_fresh
    }

    /// Prepares the preconditioner for `a`. AMG keeps its coarse levels from solve to solve
    /// (`reuse`) until [`AMG_REUSE_MAX_AGE`] solves have passed or the iterations have grown
    /// past [`AMG_REUSE_GROWTH`] times those after the last full setup; the decision depends only
    /// on iteration counts, so it is reproducible.
    pub(crate) fn setup(
        &mut self,
        kind: Preconditioner,
        a: &CsrSystem<'_>,
        reuse: bool,
    ) -> Result<(), SolveError> {
        let n = a.n();
        // Jacobi's M⁻¹ and AMG's row scaling, in parallel; a missing (taken as 0) or bad
        // diagonal is marked and the first such row reported, as a sequential loop would.
        self.inv_diag.resize(n, 0.0);
        self.inv_diag
            .par_iter_mut()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(i, inv)| *inv = 1.0 / a.diagonal(i).unwrap_or(0.0));
        if let Some(row) = self
            .inv_diag
            .par_iter()
            .position_first(|v| *v == 0.0 || !v.is_finite())
        {
            let value = a.diagonal(row).unwrap_or(0.0);
            return Err(SolveError::SingularPivot { row, value });
        }
        if kind == Preconditioner::Ilu0 {
            // A bordered system reaches ILU(0) written out (`krylov_solve`).
            debug_assert!(a.border.is_none(), "ILU(0) factorises a CSR matrix");
            self.diag_pos.resize(n, 0);
            self.diag_pos
                .par_iter_mut()
                .enumerate()
                .with_min_len(4096)
                .for_each(|(i, pos)| *pos = a.diagonal_position(i).unwrap_or(usize::MAX));
        }
        match kind {
            Preconditioner::Jacobi => {}
            Preconditioner::Amg => {
                let keep = self.keeps(reuse);
                self.amg_fresh = self.amg.setup(a, &self.inv_diag, keep);
                if self.amg_fresh {
                    self.amg_age = 0;
                    self.amg_valid = true;
                } else {
                    self.amg_age += 1;
                }
            }
            Preconditioner::Ilu0 => {
                self.lu.clear();
                self.lu.extend_from_slice(a.values);
                let (off, cols, lu) = (a.offsets, a.cols, &mut self.lu);
                for i in 0..n {
                    let (ra, rb) = (off[i], off[i + 1]);
                    for kk in ra..self.diag_pos[i] {
                        let k = cols[kk] as usize;
                        let pivot = lu[self.diag_pos[k]];
                        if pivot == 0.0 || !pivot.is_finite() {
                            return Err(SolveError::SingularPivot {
                                row: k,
                                value: pivot,
                            });
                        }
                        let lik = lu[kk] / pivot;
                        lu[kk] = lik;
                        // a_ij −= l_ik u_kj for j > k in both row i and row k (sorted merge).
                        let (mut p, mut q) = (kk + 1, self.diag_pos[k] + 1);
                        let qe = off[k + 1];
                        while p < rb && q < qe {
                            match cols[p].cmp(&cols[q]) {
                                std::cmp::Ordering::Less => p += 1,
                                std::cmp::Ordering::Greater => q += 1,
                                std::cmp::Ordering::Equal => {
                                    lu[p] -= lik * lu[q];
                                    p += 1;
                                    q += 1;
                                }
                            }
                        }
                    }
                    let d = lu[self.diag_pos[i]];
                    if d == 0.0 || !d.is_finite() {
                        return Err(SolveError::SingularPivot { row: i, value: d });
                    }
                }
            }
        }
        Ok(())
    }

    /// `z = M⁻¹ r`.
    pub(crate) fn apply(
        &mut self,
        kind: Preconditioner,
        a: &CsrSystem<'_>,
        r: &[f64],
        z: &mut [f64],
    ) {
        match kind {
            Preconditioner::Amg => self.amg.apply(&self.inv_diag, r, z),
            Preconditioner::Jacobi => {
                z.par_iter_mut()
                    .zip(r.par_iter().zip(self.inv_diag.par_iter()))
                    .with_min_len(4096)
                    .for_each(|(z, (r, d))| *z = r * d);
            }
            Preconditioner::Ilu0 => {
                let (off, cols, lu) = (a.offsets, a.cols, &self.lu);
                let n = a.n();
                // Forward: L y = r (unit diagonal).
                for i in 0..n {
                    let mut s = r[i];
                    for k in off[i]..self.diag_pos[i] {
                        s -= lu[k] * z[cols[k] as usize];
                    }
                    z[i] = s;
                }
                // Backward: U z = y.
                for i in (0..n).rev() {
                    let mut s = z[i];
                    for k in self.diag_pos[i] + 1..off[i + 1] {
                        s -= lu[k] * z[cols[k] as usize];
                    }
                    z[i] = s / lu[self.diag_pos[i]];
                }
            }
        }
    }
}
