//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel & Brezina 1996, Computing 56:179),
//! used as the preconditioner of [`BiCgStab`](super::BiCgStab): one V-cycle per application.
//!
//! Setup, for the matrix `A` of one solve:
//!
//! 1. **Row scaling.** The hierarchy is built for `Â = D⁻¹A` (unit diagonal), so the
//!    `O(1/dx²)` Laplacian rows of fluid particles and the `O(1)` extrapolation rows of wall
//!    particles are on one footing; applying the preconditioner to `r` is a V-cycle on `D⁻¹r`.
//! 2. **Strength.** `j` is a strong neighbour of `i` if `|â_ij| ≥ θ max_{k≠i} |â_ik|`
//!    (θ = [`STRENGTH`]). Rows far longer than the mean (the dense border row of
//!    [`MeanZeroGauge`](crate::MeanZeroGauge)) are *dense nodes*, decoupled before all this:
//!    level 0 keeps only their diagonal and drops their columns, so the hierarchy is that of
//!    the singular block `M`, and each application ends by restoring the coupling (a
//!    block lower-triangular preconditioner: remove the constant from the V-cycle's answer on
//!    the gauge rows, then solve each dense row for its unknown). Kept in the hierarchy (as
//!    singleton aggregates, the former design) the border made the iteration count grow
//!    16 → 36 → 47 → 115 from 10⁴ to 6.4·10⁵ unknowns; decoupled it is 9 → 10 → 9 → 11
//!    (`amg_compare`, docs/performance.md).
//! 3. **Aggregation** (the three passes of Vaněk et al.): seed aggregates from nodes whose
//!    strong neighbours are all free, attach the rest to a neighbouring aggregate, group any
//!    remainder. A node without strong neighbours (a Dirichlet row `p = 0`) has no aggregate:
//!    the smoother solves it.
//! 4. **Prolongation** `P = (I − ω Â) P₀`, `P₀` the piecewise-constant aggregate indicator (the
//!    constants — the Laplacian's near-null space — are exactly represented), `ω = 4/(3 ρ)`
//!    with `ρ` the Gershgorin bound of `Â`.
//! 5. **Galerkin coarse matrix** `A_c = Pᵀ Â P`, recursively, until at most [`COARSE_MAX`]
//!    unknowns are left; that level is solved by dense LU with partial pivoting (a pivot below
//!    [`ZERO_PIVOT`] — a singular pure-Neumann system — sets its unknown to 0).
//!
//! The cycle is a V-cycle on the fine level and, in hierarchies of four levels or more, a
//! W-cycle below it (each coarse level visited twice per visit of its parent, see
//! [`W_CYCLE_MIN_DEPTH`]). Each level is pre-smoothed by one damped Jacobi sweep from `x = 0`
//! (`ω_s = 5/(3ρ)`, [`SMOOTH_WEIGHT`]) and post-smoothed by a Chebyshev polynomial of degree
//! [`POST_DEGREE`] in `D⁻¹Â` ([`CHEB_CENTRE`], [`CHEB_HALF_WIDTH`]): a fixed linear operator, as
//! BiCGSTAB needs. The
//! hierarchy may be kept for the next solves, with only the fine level refreshed from the new
//! matrix (`setup` with `reuse`; the policy is in `PrecondState::setup`); its buffers are kept
//! between solves.

use crate::csr::{OwnedCsr, for_each_row_mut2};
use crate::solver::CsrSystem;
use crate::solver::bicgstab::tree_sum;
use rayon::prelude::*;

/// Fine-level filter: an off-diagonal entry of `Â` below `FILTER` times the largest of its row
/// is dropped from the matrix the hierarchy is built for and smoothed with, and added to the
/// diagonal (row sums, hence the constants, are kept). The Krylov method still multiplies by
/// the whole `A`; the preconditioner approximates it. SPH Laplacian rows are long (~45
/// entries in 2D with the quintic kernel at h = 1.3 dx) and their outer shell is weak:
/// at 0.1 the fine level keeps 64 % of the entries of a lattice disc with the same
/// iterations, and on the 100² cavity's DG systems the solve took 0.80× the time for 10.8
/// iterations per step instead of 9.5 (docs/performance.md); at 0.2, 47 % and no gain.
const FILTER: f64 = 0.1;
/// Strength-of-connection threshold θ.
const STRENGTH: f64 = 0.25;
/// Unknowns at or below which a level is solved directly.
const COARSE_MAX: usize = 300;
/// Pre-smoothing sweeps (the first from `x = 0`, without a product).
const SWEEPS: usize = 1;
/// Degree of the Chebyshev post-smoother (one product with `Â` per degree). On the 100² Re 100
/// cavity from rest (DG, tolerance 1e-6, one thread, to t = 0.5) the BiCGSTAB iterations per
/// step were 8.1 with the former two damped-Jacobi post-sweeps at 5/(3ρ), 7.1 with three, 6.4
/// with four; Chebyshev of degree 2 / 3 / 4 on the interval below 7.6 / 6.2 / 5.8. Degree 3
/// costs the fewest products per solve (docs/performance.md).
const POST_DEGREE: usize = 3;
/// Centre `θ` of the Chebyshev smoother's interval `[θ − δ, θ + δ]`, in units of the
/// Gershgorin bound `ρ` of `D⁻¹Â`. The smoother multiplies an error's eigencomponent λ by
/// `p(λ) = T_k((θ − λ)/δ) / T_k(θ/δ)` (`T_k` the Chebyshev polynomial of the first kind), and
/// `|p(λ)| ≤ 1` exactly for `0 ≤ λ ≤ 2θ`: with `θ = ρ/2` no mode below the bound is amplified,
/// whatever the true largest eigenvalue (no estimate of it is needed).
const CHEB_CENTRE: f64 = 0.5;
/// Half-width `δ` of the Chebyshev smoother's interval, in units of `ρ`: it damps
/// `[0.2ρ, 0.8ρ]` by `1/T_3(5/3) = 0.074` (the eigenvalues of `D⁻¹Â` measured reach
/// 0.55–0.86ρ, see [`SMOOTH_WEIGHT`]). On the cavity above, half-widths 0.25 / 0.3 / 0.35 /
/// 0.4 gave 6.4 / 6.2 / 6.5 / 7.2 iterations per step.
const CHEB_HALF_WIDTH: f64 = 0.3;
/// Damped-Jacobi smoothing weight times the Gershgorin bound `ρ` of `D⁻¹Â`: `ω_s = 5/(3ρ)`.
/// Every eigenvalue of `D⁻¹Â` lies below `ρ`, so `ω_s λ_max < 5/3 < 2`: the sweep converges on
/// any matrix. The largest eigenvalue sits well below the bound (ρ = 2.0 on every level
/// measured; 30 power iterations): 1.61 on the 2D Wendland cavity's fine level and 1.48–1.72
/// on its coarse levels, 1.55 on the 3D cube cavity, 1.61 on the dam break, 1.39 on
/// Taylor–Green, 1.25 / 1.11 on the disordered 2D / 3D quintic PPE of the solver tests. The
/// textbook `4/(3ρ)` therefore smoothed with `ω_s λ_max` 0.74–1.15, short of the 4/3 that best
/// damps the high modes; with 5/3 it is 0.93–1.43. The prolongation's smoother keeps `4/(3ρ)`.
/// Used by the pre-smoothing sweep (and the coarsest level's fallback sweeps).
const SMOOTH_WEIGHT: f64 = 5.0 / 3.0;
/// Hierarchies of at least this many levels run a W-cycle below the fine level: every coarse
/// level is visited twice per visit of its parent, the fine level once. The fine level's
/// coarse-grid correction is then close to the two-level one however deep the hierarchy: the
/// periodic Taylor–Green vortex's first DG steps (Wendland C2, tolerance 1e-6) took 6.3 / 7.0 /
/// 7.0 / 6.7 iterations per step at 10⁴ (three levels: a V-cycle) / 6.25·10⁴ / 2.5·10⁵ / 10⁶
/// unknowns, against 6.3 / 8.7 / 11.0 / 9.7 with the V-cycle everywhere, and the 10⁶ solve
/// 1.20 s per step against 1.56. Shallower hierarchies run a V-cycle: with one level between the
/// fine and the directly solved one the second visit cost more than it saved (the 100² cavity
/// from rest, one thread: 11.2 against 11.3 iterations per step, the solve 1.09× slower).
/// Docs/performance.md.
const W_CYCLE_MIN_DEPTH: usize = 4;
/// Stop coarsening when a level shrinks by less than this factor.
const MIN_COARSENING: f64 = 1.5;
/// A coarsest-level pivot at most this times the largest entry is zero: the level is singular
/// (a closed domain's Laplacian, constants in its null space). The Galerkin products leave
/// such a pivot at round-off well above machine ε: the last pivot measured 1.7e-13 … 1.7e-12
/// of the largest entry on the closed blocks of `amg_compare`, 0.43 … 0.58 with Dirichlet
/// rows. Read as non-zero (the former threshold 1e-13), it returned the incompatible part of
/// the coarse residual amplified by its inverse and the solve stalled.
const ZERO_PIVOT: f64 = 1e-9;
/// No aggregate.
const NONE: u32 = u32::MAX;

/// An owned CSR matrix (possibly rectangular), sealed for its products once built.
type Csr = OwnedCsr;

/// One level: its matrix (the fine level's is the scaled copy of `A`), the prolongation to it
/// from the next coarser level and the restriction `R = Pᵀ`, and its work vectors.
#[derive(Clone, Debug, Default)]
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    /// Smoothing weight `ω_s = SMOOTH_WEIGHT / ρ`.
    omega: f64,
    /// Gershgorin bound `ρ = max_i Σ_j |â_ij| / |â_ii|` of the eigenvalues of `D⁻¹Â`.
    rho: f64,
    p: Csr,
    r: Csr,
    x: Vec<f64>,
    b: Vec<f64>,
    res: Vec<f64>,
    /// The first visit's answer while a W-cycle visits the level again.
    first: Vec<f64>,
    /// The Chebyshev smoother's last update.
    dir: Vec<f64>,
}

/// Dense LU factors of the coarsest level (row-major, partial pivoting).
#[derive(Clone, Debug, Default)]
struct DenseLu {
    n: usize,
    lu: Vec<f64>,
    perm: Vec<usize>,
    /// Pivots below round-off: their unknowns are set to 0.
    zero_pivot: Vec<bool>,
}

impl DenseLu {
    /// Factors `a`, or `a + α 1 1ᵀ` with `α = tr(a)/n²` if `singular` (its null space is the
    /// constants: the rank-one term makes it regular, and for a compatible right-hand side the
    /// solution is the one with zero sum; a 1×1 or small singular level has no pivot that
    /// round-off would reveal).
    fn factor(&mut self, a: &Csr, singular: bool) {
        let n = a.nrows();
        self.n = n;
        self.lu.clear();
        self.lu.resize(n * n, 0.0);
        let mut trace = 0.0;
        for i in 0..n {
            for k in a.offsets()[i]..a.offsets()[i + 1] {
                self.lu[i * n + a.cols()[k] as usize] += a.values()[k];
                if a.cols()[k] as usize == i {
                    trace += a.values()[k];
                }
            }
        }
        if singular && n > 0 {
            let alpha = trace / (n * n) as f64;
            for v in &mut self.lu {
                *v += alpha;
            }
        }
        self.perm.clear();
        self.perm.extend(0..n);
        self.zero_pivot.clear();
        self.zero_pivot.resize(n, false);
        let scale = self.lu.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let lu = &mut self.lu;
        for k in 0..n {
            let (mut piv, mut best) = (k, lu[k * n + k].abs());
            for i in k + 1..n {
                if lu[i * n + k].abs() > best {
                    (piv, best) = (i, lu[i * n + k].abs());
                }
            }
            if best <= ZERO_PIVOT * scale {
                self.zero_pivot[k] = true;
                continue;
            }
            if piv != k {
                for j in 0..n {
                    lu.swap(k * n + j, piv * n + j);
                }
                self.perm.swap(k, piv);
            }
            let d = lu[k * n + k];
            for i in k + 1..n {
                let l = lu[i * n + k] / d;
                lu[i * n + k] = l;
                if l != 0.0 {
                    for j in k + 1..n {
                        lu[i * n + j] -= l * lu[k * n + j];
                    }
                }
            }
        }
    }

    fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let mut s = b[self.perm[i]];
            for j in 0..i {
                s -= self.lu[i * n + j] * x[j];
            }
            x[i] = s;
        }
        for i in (0..n).rev() {
            if self.zero_pivot[i] {
                x[i] = 0.0;
                continue;
            }
            let mut s = x[i];
            for j in i + 1..n {
                s -= self.lu[i * n + j] * x[j];
            }
            x[i] = s / self.lu[i * n + i];
        }
    }
}

/// The multigrid hierarchy, rebuilt by [`Amg::setup`] for each matrix.
#[derive(Clone, Debug, Default)]
pub(crate) struct Amg {
    levels: Vec<Level>,
    /// Levels in use (`levels` keeps spare buffers beyond).
    depth: usize,
    coarse: DenseLu,
    // Setup scratch.
    agg: Vec<u32>,
    /// The aggregates after the first pass (what the second pass attaches to).
    agg_pass1: Vec<u32>,
    /// Dense rows of the fine level (see [`Amg::setup`]): flags, indices, a copy of each
    /// row, and the gauge rows (those with an entry in a dense column).
    dense: Vec<bool>,
    dense_idx: Vec<usize>,
    dense_rows: Csr,
    /// Each dense row's diagonal entry (0 if it has none).
    dense_diag: Vec<f64>,
    in_gauge: Vec<bool>,
    /// How many rows are in the gauge.
    gauge_count: usize,
    /// Every coupled row of the fine level sums to zero: constants span the null space.
    singular: bool,
    /// The dense rows the coarse levels were built with.
    built_dense: Vec<usize>,
    strong: Vec<bool>,
    /// Per fine row, its largest kept off-diagonal magnitude (the filter's reference).
    row_big: Vec<f64>,
    marker: Vec<usize>,
    ap: Csr,
    /// A bordered system written out, for the borders the fine level does not take as they
    /// are (see [`Amg::setup`]).
    written: super::Materialised,
}

impl Amg {
    /// `(rows, non-zeros)` of each level of the last setup (for tests).
    #[cfg(test)]
    pub(crate) fn shape(&self) -> Vec<(usize, usize)> {
        self.levels[..self.depth]
            .iter()
            .map(|l| (l.a.nrows(), l.a.cols().len()))
            .collect()
    }

    /// Whether a bordered system has ever been written out here (for tests).
    #[cfg(test)]
    pub(crate) fn wrote_out(&self) -> bool {
        !self.written.is_empty()
    }

    /// The fine level's smoother as of the last setup (for tests): `Â`'s offsets, columns and
    /// values, the inverse of its diagonal and the weight `ω_s`.
    #[cfg(test)]
    pub(crate) fn fine_smoother(&self) -> (&[usize], &[u32], &[f64], &[f64], f64) {
        let l = &self.levels[0];
        (
            l.a.offsets(),
            l.a.cols(),
            l.a.values(),
            &l.inv_diag,
            l.omega,
        )
    }

    /// Builds the hierarchy for `a`, whose inverse diagonal (all finite) is `inv_diag`.
    ///
    /// With `reuse`, only the fine level is rebuilt from `a` if the coarse levels of the last
    /// full setup fit (same number of unknowns, same dense rows): the V-cycle then smooths with
    /// the new matrix and corrects with the old coarse spaces. Returns whether the whole
    /// hierarchy was built.
    ///
    /// A bordered system ([`Border`](super::Border)) is taken as its written-out matrix would
    /// be, to the bit: its border row is a dense row and the body's rows are read in place.
    /// A border row that would not count as dense (a system of at most [`COARSE_MAX`]
    /// unknowns), or a body row that would, is handled by writing the system out first.
    pub(crate) fn setup(&mut self, a: &CsrSystem<'_>, inv_diag: &[f64], reuse: bool) -> bool {
        let full = match self.build(a, inv_diag, reuse) {
            Some(full) => full,
            None => {
                let mut written = std::mem::take(&mut self.written);
                written.fill(a);
                let Some(full) = self.build(&written.system(a.rhs), inv_diag, reuse) else {
                    unreachable!("a system without a border is always taken");
                };
                self.written = written;
                full
            }
        };
        // The V-cycle's products gather without a check per entry once each matrix's columns
        // have been checked against its width (a matrix the rebuild left unchanged stays sealed).
        for l in &mut self.levels[..self.depth] {
            l.a.seal();
            l.p.seal();
            l.r.seal();
        }
        full
    }

    /// Marks the dense rows of `a` in `self.dense`: rows over 4× longer than the mean or full
    /// (a gauge's border row; SPH neighbour counts vary by about 2× between the bulk and a
    /// surface), their lengths those of the written-out matrix for a bordered system. Dense
    /// rows are decoupled from the hierarchy: level 0 drops their columns and keeps only their
    /// diagonal, so the multigrid sees the singular block M alone; `apply` restores the
    /// coupling. Returns
    /// whether the fine level takes `a` in place: always without a border; with one, when the
    /// border row is dense and no body row is.
    fn classify_dense(&mut self, a: &CsrSystem<'_>) -> bool {
        let n = a.n();
        let m = a.body_rows();
        let rows = a.border.map_or(0, |b| b.rows);
        let border_len = if a.border.is_some() { m + 1 } else { 0 };
        let nnz = a.offsets[m] - a.offsets[0] + rows + border_len;
        let mean_len = nnz as f64 / n.max(1) as f64;
        let is_dense =
            |len: usize| len as f64 > 4.0 * mean_len + 16.0 || (n > COARSE_MAX && len == n);
        self.dense.clear();
        self.dense.extend(
            (0..m).map(|i| is_dense(a.offsets[i + 1] - a.offsets[i] + usize::from(i < rows))),
        );
        if a.border.is_none() {
            return true;
        }
        self.dense.push(is_dense(border_len));
        self.dense[m] && !self.dense[..m].contains(&true)
    }

    /// [`setup`](Self::setup)'s construction of the hierarchy; `None` (nothing built) for a
    /// bordered system the fine level does not take in place (see [`classify_dense`](Self::classify_dense)).
    fn build(&mut self, a: &CsrSystem<'_>, inv_diag: &[f64], reuse: bool) -> Option<bool> {
        let n = a.n();
        if self.levels.is_empty() {
            self.levels.push(Level::default());
        }
        let m = a.body_rows();
        let rows = a.border.map_or(0, |b| b.rows);
        if !self.classify_dense(a) {
            return None;
        }
        // The dense rows' copies and diagonals; the gauge rows (those meeting a dense column).
        self.dense_idx.clear();
        self.dense_rows.clear(n);
        self.dense_diag.clear();
        for i in (0..n).filter(|&i| self.dense[i]) {
            self.dense_idx.push(i);
            let (offsets, cols, values) = self.dense_rows.parts_mut();
            match a.border {
                // The border row (the only dense row of a bordered system): every column.
                Some(b) if i == m => {
                    cols.extend(0..=m as u32);
                    values.extend_from_slice(&b.row[..=m]);
                    self.dense_diag.push(b.row[m]);
                }
                _ => {
                    let row = a.offsets[i]..a.offsets[i + 1];
                    self.dense_diag.push(
                        row.clone()
                            .filter(|&k| a.cols[k] as usize == i)
                            .map(|k| a.values[k])
                            .sum(),
                    );
                    cols.extend_from_slice(&a.cols[row.clone()]);
                    values.extend_from_slice(&a.values[row]);
                }
            }
            offsets.push(cols.len());
        }
        self.in_gauge.clear();
        self.in_gauge.resize(n, false);
        // Fine level: Â = D⁻¹ A with the dense columns dropped and the weak entries lumped
        // (see [`FILTER`]). In parallel: each row's kept entries and whether it meets a dense
        // column, the offsets, then each row's columns and values filled in place.
        let l0 = &mut self.levels[0];
        // The fill below overwrites every entry: no pass zeroing the level at every step.
        l0.a.clear_rows(n);
        let dense = &self.dense;
        // A level solved directly is solved for the matrix itself.
        let filter = if n > COARSE_MAX { FILTER } else { 0.0 };
        // Whether row i keeps its entry (j, v), `big` its largest kept off-diagonal |a_ij|: a
        // dense row keeps only its diagonal, another row its diagonal and each entry of a
        // non-dense column with |a_ij| ≥ FILTER·big. Bitwise operations, no branches: about a
        // third of the entries are dropped, in no pattern a branch predictor could learn.
        let keep = |i: usize, j: usize, v: f64, big: f64| {
            (j == i) | (!dense[i] & !dense[j] & (v.abs() >= filter * big))
        };
        let (offsets, cols, values) = l0.a.parts_mut();
        offsets.resize(n + 1, 0);
        self.row_big.resize(n, 0.0);
        if a.border.is_some() {
            // The border row keeps its diagonal alone; it meets no dense column but its own.
            (self.in_gauge[m], offsets[m + 1], self.row_big[m]) = (false, 1, 0.0);
        }
        self.in_gauge[..m]
            .par_iter_mut()
            .zip(
                offsets[1..=m]
                    .par_iter_mut()
                    .zip(self.row_big[..m].par_iter_mut()),
            )
            .enumerate()
            .with_min_len(1024)
            .for_each(|(i, (g, (c, big)))| {
                // The largest off-diagonal |a_ij| over the columns the row keeps (the row
                // scaling does not change which entries are weak).
                // Four running maxima (a maximum is exact in any order): one would wait on
                // the latency of each comparison. Entries are finite (checked at assembly).
                let row = a.offsets[i]..a.offsets[i + 1];
                let (cols, vals) = (&a.cols[row.clone()], &a.values[row.clone()]);
                let (mut hits, mut m) = (false, [0.0f64; 4]);
                let q = cols.len() / 4 * 4;
                for (c4, v4) in cols[..q].chunks_exact(4).zip(vals[..q].chunks_exact(4)) {
                    for l in 0..4 {
                        let j = c4[l] as usize;
                        hits |= dense[j];
                        let v = if j != i && !dense[j] {
                            v4[l].abs()
                        } else {
                            0.0
                        };
                        m[l] = if v > m[l] { v } else { m[l] };
                    }
                }
                for (&j, v) in cols[q..].iter().zip(&vals[q..]) {
                    let j = j as usize;
                    hits |= dense[j];
                    if j != i && !dense[j] && v.abs() > m[0] {
                        m[0] = v.abs();
                    }
                }
                let b = m[0].max(m[1]).max(m[2].max(m[3]));
                // A bordered system's first `rows` rows meet the border's (dense) column.
                *g = !dense[i] && (hits || i < rows);
                *big = b;
                *c = cols
                    .iter()
                    .zip(vals)
                    .map(|(&j, &v)| usize::from(keep(i, j as usize, v, b)))
                    .sum();
            });
        self.gauge_count = self
            .in_gauge
            .par_iter()
            .with_min_len(4096)
            .filter(|g| **g)
            .count();
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let nnz = offsets[n];
        cols.resize(nnz, 0);
        values.resize(nnz, 0.0);
        let row_big = &self.row_big;
        let border = a.border;
        for_each_row_mut2(offsets, cols, values, &|i, cols, vals| {
            let (b, inv) = (row_big[i], inv_diag[i]);
            if let Some(border) = border.filter(|_| i == m) {
                // The border row: its diagonal alone (what the loop below keeps of a dense
                // row, with nothing lumped).
                (cols[0], vals[0]) = (i as u32, border.row[i] * inv);
                return;
            }
            let row = a.offsets[i]..a.offsets[i + 1];
            let (acols, avals) = (&a.cols[row.clone()], &a.values[row]);
            let (mut lumped, mut diag, mut w) = (0.0, 0, 0);
            // Each entry is written to the next free place and the place advanced only if
            // kept, so no branch depends on the entry; while w < cols.len() (the count
            // above) the write is in bounds. A dropped entry of a non-dense row and column
            // is lumped into the diagonal: the entry times 1 is added, times 0 for the others
            // (the same sum: entries and inverse diagonals are finite, checked before, and
            // the diagonal is non-zero, so a signed zero cannot show). A
            // product, not a choice: the compiler turns `if lump { x } else { 0.0 }` into a
            // branch, mispredicted on about half of the entries (with it, this filter took
            // 3.3–3.5 ms per set-up instead of 1.8–2.6 on the 100² cavity late in its run).
            for (&c, &v) in acols.iter().zip(avals) {
                let j = c as usize;
                let kept = keep(i, j, v, b);
                if w < cols.len() {
                    cols[w] = c;
                    vals[w] = v * inv;
                }
                diag = if j == i { w } else { diag };
                let lump = !kept & !dense[i] & !dense[j];
                lumped += v * inv * f64::from(u8::from(lump));
                w += usize::from(kept);
            }
            debug_assert_eq!(w, cols.len());
            vals[diag] += lumped;
        });
        // Reuse: keep the coarse levels (prolongations, Galerkin matrices, coarsest LU) of the
        // last full setup when they were built for the same unknowns and dense rows.
        if reuse
            && self.depth > 1
            && self.levels[0].p.nrows() == n
            && self.built_dense == self.dense_idx
        {
            Self::prepare_level(&mut self.levels[0]);
            return Some(false);
        }
        // Singular: every row with off-diagonal entries sums to zero (round-off aside); rows
        // without (Dirichlet, dense) have no aggregate and never reach the coarse levels. Only
        // the coarsest level's factorisation reads it, so a kept hierarchy skips the pass.
        {
            let l0 = &self.levels[0];
            self.singular = (0..n).into_par_iter().with_min_len(1024).all(|i| {
                let row = l0.a.offsets()[i]..l0.a.offsets()[i + 1];
                let (sum, abs) = l0.a.values()[row.clone()]
                    .iter()
                    .fold((0.0, 0.0), |(s, a), v| (s + v, a + v.abs()));
                row.len() <= 1 || sum.abs() <= 1e-8 * abs
            });
        }
        self.built_dense.clone_from(&self.dense_idx);
        let mut depth = 1;
        loop {
            let lvl = depth - 1;
            let nl = self.levels[lvl].a.nrows();
            Self::prepare_level(&mut self.levels[lvl]);
            if nl <= COARSE_MAX {
                break;
            }
            let nc = self.aggregate(lvl);
            if nc == 0 || (nl as f64) < MIN_COARSENING * nc as f64 {
                break;
            }
            if self.levels.len() <= depth {
                self.levels.push(Level::default());
            }
            self.build_prolongation(lvl, nc);
            self.galerkin(lvl);
            depth += 1;
        }
        self.depth = depth;
        let last = &self.levels[depth - 1];
        if last.a.nrows() <= 2 * COARSE_MAX {
            self.coarse.factor(&last.a, self.singular);
        } else {
            self.coarse.n = 0;
        }
        for l in &mut self.levels[..depth] {
            let m = l.a.nrows();
            l.x.resize(m, 0.0);
            l.b.resize(m, 0.0);
            l.res.resize(m, 0.0);
            l.first.resize(m, 0.0);
            l.dir.resize(m, 0.0);
        }
        Some(true)
    }

    /// Inverse diagonal and smoothing weight of a level.
    fn prepare_level(l: &mut Level) {
        let m = l.a.nrows();
        let a = &l.a;
        // In parallel; the maximum is exact in any order, so ω does not depend on the threads.
        l.inv_diag.resize(m, 0.0);
        let rho = l
            .inv_diag
            .par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .map(|(i, inv)| {
                let (s, e) = (a.offsets()[i], a.offsets()[i + 1]);
                let mut d = 0.0;
                let mut abs = 0.0;
                for k in s..e {
                    if a.cols()[k] as usize == i {
                        d += a.values()[k];
                    }
                    abs += a.values()[k].abs();
                }
                *inv = if d != 0.0 && d.is_finite() {
                    1.0 / d
                } else {
                    0.0
                };
                abs * inv.abs()
            })
            .reduce(|| 0.0f64, f64::max);
        l.rho = rho;
        l.omega = if rho > 0.0 { SMOOTH_WEIGHT / rho } else { 0.0 };
    }

    /// Aggregates the unknowns of level `lvl` into `self.agg`; returns the number of aggregates.
    fn aggregate(&mut self, lvl: usize) -> usize {
        let a = &self.levels[lvl].a;
        let m = a.nrows();
        // Strong connections, flagged per entry.
        self.strong.clear();
        self.strong.resize(a.cols().len(), false);
        for i in 0..m {
            let (s, e) = (a.offsets()[i], a.offsets()[i + 1]);
            let mut max = 0.0f64;
            for k in s..e {
                let j = a.cols()[k] as usize;
                if j != i {
                    max = max.max(a.values()[k].abs());
                }
            }
            if max == 0.0 {
                continue;
            }
            for k in s..e {
                let j = a.cols()[k] as usize;
                self.strong[k] = j != i && a.values()[k].abs() >= STRENGTH * max;
            }
        }
        let agg = &mut self.agg;
        agg.clear();
        agg.resize(m, NONE);
        let mut nc = 0u32;
        let has_strong = |i: usize| (a.offsets()[i]..a.offsets()[i + 1]).any(|k| self.strong[k]);
        // Pass 1: seeds whose strong neighbourhood is entirely free.
        for i in 0..m {
            if agg[i] != NONE || !has_strong(i) {
                continue;
            }
            let (s, e) = (a.offsets()[i], a.offsets()[i + 1]);
            if (s..e).any(|k| self.strong[k] && agg[a.cols()[k] as usize] != NONE) {
                continue;
            }
            agg[i] = nc;
            for k in s..e {
                if self.strong[k] {
                    agg[a.cols()[k] as usize] = nc;
                }
            }
            nc += 1;
        }
        // Pass 2: attach the rest to the aggregate of their strongest aggregated neighbour.
        let pass1 = &mut self.agg_pass1;
        pass1.clone_from(agg);
        for i in 0..m {
            if agg[i] != NONE {
                continue;
            }
            let (s, e) = (a.offsets()[i], a.offsets()[i + 1]);
            let mut best = (0.0, NONE);
            for k in s..e {
                let j = a.cols()[k] as usize;
                if self.strong[k] && pass1[j] != NONE && a.values()[k].abs() > best.0 {
                    best = (a.values()[k].abs(), pass1[j]);
                }
            }
            agg[i] = best.1;
        }
        // Pass 3: group what is left with its free strong neighbours.
        for i in 0..m {
            if agg[i] != NONE || !has_strong(i) {
                continue;
            }
            agg[i] = nc;
            for k in a.offsets()[i]..a.offsets()[i + 1] {
                let j = a.cols()[k] as usize;
                if self.strong[k] && agg[j] == NONE {
                    agg[j] = nc;
                }
            }
            nc += 1;
        }
        nc as usize
    }

    /// `P = (I − ω Â) P₀` and `R = Pᵀ`.
    fn build_prolongation(&mut self, lvl: usize, nc: usize) {
        let l = &mut self.levels[lvl];
        let a = &l.a;
        let m = a.nrows();
        let omega = if l.rho > 0.0 {
            4.0 / (3.0 * l.rho)
        } else {
            0.0
        };
        let p = &mut l.p;
        p.clear(nc);
        let (p_offsets, p_cols, p_values) = p.parts_mut();
        self.marker.clear();
        self.marker.resize(nc, usize::MAX);
        for i in 0..m {
            let row_start = p_cols.len();
            {
                let inv = l.inv_diag[i];
                for k in a.offsets()[i]..a.offsets()[i + 1] {
                    let j = a.cols()[k] as usize;
                    if self.agg[j] == NONE {
                        continue;
                    }
                    let c = if j == i { 1.0 } else { 0.0 } - omega * inv * a.values()[k];
                    let g = self.agg[j] as usize;
                    // Markers left by earlier rows point before this row's start.
                    if self.marker[g] == usize::MAX || self.marker[g] < row_start {
                        self.marker[g] = p_cols.len();
                        p_cols.push(g as u32);
                        p_values.push(c);
                    } else {
                        p_values[self.marker[g]] += c;
                    }
                }
                // Diagonal of Â not in its own aggregate (an isolated node): P₀ row is empty.
            }
            p_offsets.push(p_cols.len());
        }
        // R = Pᵀ by counting sort.
        let (p, r) = (&l.p, &mut l.r);
        r.clear(m);
        let (r_offsets, r_cols, r_values) = r.parts_mut();
        r_offsets.clear();
        r_offsets.resize(nc + 1, 0);
        for &g in p.cols() {
            r_offsets[g as usize + 1] += 1;
        }
        for g in 0..nc {
            r_offsets[g + 1] += r_offsets[g];
        }
        r_cols.resize(p.cols().len(), 0);
        r_values.resize(p.cols().len(), 0.0);
        let mut next = r_offsets.clone();
        for i in 0..m {
            for k in p.offsets()[i]..p.offsets()[i + 1] {
                let g = p.cols()[k] as usize;
                let dst = next[g];
                r_cols[dst] = i as u32;
                r_values[dst] = p.values()[k];
                next[g] += 1;
            }
        }
    }

    /// `A_{lvl+1} = R Â P`.
    fn galerkin(&mut self, lvl: usize) {
        let (fine, coarse) = self.levels.split_at_mut(lvl + 1);
        let l = &fine[lvl];
        spgemm(&l.a, &l.p, &mut self.ap, &mut self.marker);
        spgemm(&l.r, &self.ap, &mut coarse[0].a, &mut self.marker);
    }

    /// `z = M⁻¹ r`: one V-cycle on the scaled residual `D⁻¹ r` (`inv_diag` as in `setup`).
    pub(crate) fn apply(&mut self, inv: &[f64], r: &[f64], z: &mut [f64]) {
        let l0 = &mut self.levels[0];
        l0.b.par_iter_mut()
            .zip(r.par_iter().zip(inv.par_iter()))
            .with_min_len(4096)
            .for_each(|(b, (r, d))| *b = r * d);
        self.cycle(0);
        z.copy_from_slice(&self.levels[0].x);
        if !self.dense_idx.is_empty() {
            self.couple_dense(r, z);
        }
    }

    /// Restores the dense rows decoupled by `setup` (block lower-triangular preconditioning of
    /// the bordered gauge system `[M u; cᵀ δ]`): the V-cycle's answer `z_p` for the singular
    /// block is projected onto the gauge constraint — the constant equal to its mean over the
    /// gauge rows is removed from every non-dense unknown (the constants are M's null space,
    /// fluid and wall rows alike; without this, the part of the residual incompatible with M
    /// returns as a large constant that the border row then reads) — and each dense row is
    /// then solved exactly for its own unknown,
    /// `z_λ = (r_λ − Σ_{j≠λ} k_λj z_j) / k_λλ`. The sums over all unknowns are taken by
    /// [`tree_sum`] (in parallel, bitwise independent of the thread count); the dense rows one
    /// after the other, each reading the unknowns the earlier ones solved for.
    fn couple_dense(&mut self, r: &[f64], z: &mut [f64]) {
        let gauge = &self.in_gauge;
        let zr: &[f64] = z;
        let sum = tree_sum(0..zr.len(), &|i| if gauge[i] { zr[i] } else { 0.0 });
        let mean = sum / self.gauge_count.max(1) as f64;
        z.par_iter_mut()
            .zip(self.dense.par_iter())
            .with_min_len(4096)
            .for_each(|(zi, d)| {
                if !d {
                    *zi -= mean;
                }
            });
        for (d, &i) in self.dense_idx.iter().enumerate() {
            let row = self.dense_rows.offsets()[d]..self.dense_rows.offsets()[d + 1];
            let (cols, values) = (self.dense_rows.cols(), self.dense_rows.values());
            let zr: &[f64] = z;
            let off = tree_sum(row, &|k| {
                let j = cols[k] as usize;
                if j == i { 0.0 } else { values[k] * zr[j] }
            });
            let diag = self.dense_diag[d];
            z[i] = if diag != 0.0 {
                (r[i] - off) / diag
            } else {
                0.0
            };
        }
    }

    fn cycle(&mut self, lvl: usize) {
        if lvl + 1 == self.depth {
            let l = &mut self.levels[lvl];
            if self.coarse.n == l.a.nrows() && self.coarse.n > 0 {
                self.coarse.solve(&l.b, &mut l.x);
            } else {
                l.x.fill(0.0);
                for _ in 0..10 {
                    jacobi(l);
                }
            }
            return;
        }
        {
            let l = &mut self.levels[lvl];
            for sweep in 0..SWEEPS {
                if sweep == 0 {
                    // From x = 0: x = ω D⁻¹ b, the same numbers without the product A·0.
                    let w = l.omega;
                    l.x.par_iter_mut()
                        .zip(l.b.par_iter().zip(l.inv_diag.par_iter()))
                        .with_min_len(4096)
                        .for_each(|(x, (b, d))| *x = w * d * b);
                } else {
                    jacobi(l);
                }
            }
            // res = b − A x
            l.a.matvec(&l.x, &mut l.res);
            l.res
                .par_iter_mut()
                .zip(l.b.par_iter())
                .with_min_len(4096)
                .for_each(|(r, b)| *r = b - *r);
        }
        {
            let (fine, coarse) = self.levels.split_at_mut(lvl + 1);
            fine[lvl].r.matvec(&fine[lvl].res, &mut coarse[0].b);
        }
        self.cycle(lvl + 1);
        if self.depth >= W_CYCLE_MIN_DEPTH && lvl + 2 < self.depth {
            // W-cycle: visit the coarse level again for the residual of its first answer,
            // x_c += cycle(b_c − A_c x_c).
            {
                let c = &mut self.levels[lvl + 1];
                c.first.copy_from_slice(&c.x);
                c.a.matvec(&c.x, &mut c.res);
                c.b.par_iter_mut()
                    .zip(c.res.par_iter())
                    .with_min_len(4096)
                    .for_each(|(b, r)| *b -= r);
            }
            self.cycle(lvl + 1);
            let c = &mut self.levels[lvl + 1];
            c.x.par_iter_mut()
                .zip(c.first.par_iter())
                .with_min_len(4096)
                .for_each(|(x, f)| *x += f);
        }
        {
            let (fine, coarse) = self.levels.split_at_mut(lvl + 1);
            let l = &mut fine[lvl];
            // x += P x_c
            l.p.matvec(&coarse[0].x, &mut l.res);
            l.x.par_iter_mut()
                .zip(l.res.par_iter())
                .with_min_len(4096)
                .for_each(|(x, c)| *x += c);
            chebyshev(l, POST_DEGREE);
        }
    }
}

/// Chebyshev smoothing of `Âx = b` (Saad 2003, *Iterative Methods for Sparse Linear Systems*,
/// 2nd ed., Algorithm 12.1; as a multigrid smoother: Adams, Brezina, Hu & Tuminaro 2003, J.
/// Comput. Phys. 188:593) on `[θ − δ, θ + δ]`, `θ = ` [`CHEB_CENTRE`]`·ρ`,
/// `δ = ` [`CHEB_HALF_WIDTH`]`·ρ`, `σ = θ/δ`, `ρ₀ = 1/σ`, `degree` products with `Â`:
///
/// ```text
/// d₀ = D⁻¹(b − Âx₀)/θ,                                   x₁ = x₀ + d₀
/// ρ_k = 1/(2σ − ρ_{k−1}),  d_k = ρ_k ρ_{k−1} d_{k−1} + (2ρ_k/δ) D⁻¹(b − Âx_k),  x_{k+1} = x_k + d_k
/// ```
///
/// The error `x − Â⁻¹b` is multiplied by `T_k((θ − D⁻¹Â)/δ) / T_k(σ)`. Uses `res` and `dir` as
/// scratch; element-wise passes only, so the result does not depend on the thread count.
fn chebyshev(l: &mut Level, degree: usize) {
    let theta = CHEB_CENTRE * l.rho;
    let delta = CHEB_HALF_WIDTH * l.rho;
    if delta <= 0.0 || !delta.is_finite() {
        return;
    }
    let sigma = theta / delta;
    let mut rho_prev = 1.0 / sigma;
    for k in 0..degree {
        l.a.matvec(&l.x, &mut l.res);
        let (c_dir, c_res) = if k == 0 {
            (0.0, 1.0 / theta)
        } else {
            let rho_k = 1.0 / (2.0 * sigma - rho_prev);
            let c = (rho_k * rho_prev, 2.0 * rho_k / delta);
            rho_prev = rho_k;
            c
        };
        l.x.par_iter_mut()
            .zip(l.dir.par_iter_mut())
            .zip(
                l.res
                    .par_iter()
                    .zip(l.b.par_iter().zip(l.inv_diag.par_iter())),
            )
            .with_min_len(4096)
            .for_each(|((x, d), (ax, (b, di)))| {
                let step = c_res * di * (b - ax);
                *d = if k == 0 { step } else { c_dir * *d + step };
                *x += *d;
            });
    }
}

/// One damped Jacobi sweep `x += ω D⁻¹ (b − A x)` (uses `res` as scratch).
fn jacobi(l: &mut Level) {
    l.a.matvec(&l.x, &mut l.res);
    let w = l.omega;
    l.x.par_iter_mut()
        .zip(
            l.res
                .par_iter()
                .zip(l.b.par_iter().zip(l.inv_diag.par_iter())),
        )
        .with_min_len(4096)
        .for_each(|(x, (ax, (b, d)))| *x += w * d * (b - ax));
}

/// `c = a · b` (sparse × sparse, Gustavson's row-by-row algorithm), in parallel over blocks of
/// rows, each with its own marker array; the blocks are concatenated in order, so the result
/// does not depend on the thread count.
fn spgemm(a: &Csr, b: &Csr, c: &mut Csr, marker: &mut Vec<usize>) {
    const BLOCK: usize = 2048;
    let n = a.nrows();
    c.clear(b.ncols());
    if n <= BLOCK {
        spgemm_rows(a, b, 0..n, c, marker);
        return;
    }
    let blocks: Vec<Csr> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|k| {
            let mut part = Csr::default();
            part.clear(b.ncols());
            let mut mk = Vec::new();
            spgemm_rows(
                a,
                b,
                k * BLOCK..((k + 1) * BLOCK).min(n),
                &mut part,
                &mut mk,
            );
            part
        })
        .collect();
    let (offsets, cols, values) = c.parts_mut();
    for part in &blocks {
        let base = cols.len();
        cols.extend_from_slice(part.cols());
        values.extend_from_slice(part.values());
        offsets.extend(part.offsets()[1..].iter().map(|o| o + base));
    }
}

/// Rows `rows` of `a · b`, appended to `c` (whose `offsets` already hold the start).
fn spgemm_rows(
    a: &Csr,
    b: &Csr,
    rows: std::ops::Range<usize>,
    c: &mut Csr,
    marker: &mut Vec<usize>,
) {
    marker.clear();
    marker.resize(b.ncols(), usize::MAX);
    let (c_offsets, c_cols, c_values) = c.parts_mut();
    for i in rows {
        let row_start = c_cols.len();
        for ka in a.offsets()[i]..a.offsets()[i + 1] {
            let k = a.cols()[ka] as usize;
            let av = a.values()[ka];
            for kb in b.offsets()[k]..b.offsets()[k + 1] {
                let j = b.cols()[kb] as usize;
                let v = av * b.values()[kb];
                let pos = marker[j];
                // Markers left by earlier rows point before this row's start.
                if pos == usize::MAX || pos < row_start {
                    marker[j] = c_cols.len();
                    c_cols.push(j as u32);
                    c_values.push(v);
                } else {
                    c_values[pos] += v;
                }
            }
        }
        c_offsets.push(c_cols.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fine level is `Â = D⁻¹A` filtered as [`FILTER`] says, checked against a plain
    /// reference on a bordered system (a full last row and column, as the gauge builds): each
    /// non-dense row keeps its diagonal and every entry of a non-dense column with
    /// `|a_ij| ≥ 0.1 · max_{j≠i, non-dense} |a_ij|`, in order, scaled by `1/a_ii`; the dropped
    /// entries of non-dense columns are added to its diagonal (so its row sum over the
    /// non-dense columns is that of `D⁻¹A`); the dense row keeps only its diagonal. Entry
    /// magnitudes are cubes of pseudo-random numbers, so entries are dropped in no regular
    /// pattern.
    #[test]
    fn fine_level_is_the_filtered_scaled_matrix() {
        let n = 401; // > COARSE_MAX: the filter applies
        let border = n - 1;
        let (mut offsets, mut cols, mut values) = (vec![0], Vec::new(), Vec::new());
        let mut seed = 12345u64;
        let mut rand = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..border {
            let mut row: Vec<(u32, f64)> = [-9i64, -3, -2, -1, 1, 2, 3, 9]
                .iter()
                .map(|d| i as i64 + d)
                .filter(|&j| j >= 0 && j < border as i64)
                .map(|j| (j as u32, -(0.01 + rand()).powi(3)))
                .collect();
            row.push((i as u32, 4.0 + rand()));
            row.push((border as u32, 0.5));
            row.sort_by_key(|e| e.0);
            for (j, v) in row {
                cols.push(j);
                values.push(v);
            }
            offsets.push(cols.len());
        }
        for j in 0..n {
            cols.push(j as u32);
            values.push(if j == border { 3.0 } else { 0.25 + rand() });
        }
        offsets.push(cols.len());
        let rhs = vec![1.0; n];
        let a = CsrSystem {
            offsets: &offsets,
            cols: &cols,
            values: &values,
            rhs: &rhs,
            border: None,
        };
        let inv_diag: Vec<f64> = (0..n)
            .map(|i| {
                let row = offsets[i]..offsets[i + 1];
                let k = row.clone().find(|&k| cols[k] as usize == i).unwrap();
                1.0 / values[k]
            })
            .collect();
        let mut amg = Amg::default();
        amg.setup(&a, &inv_diag, false);
        // Every level's products take the path checked once per setup (the fast path).
        assert!(
            amg.depth > 1,
            "a hierarchy of one level tests no coarse matrices"
        );
        for (k, l) in amg.levels[..amg.depth].iter().enumerate() {
            assert!(
                l.a.is_sealed() && l.p.is_sealed() && l.r.is_sealed(),
                "level {k} not sealed after setup"
            );
        }
        let (f_off, f_cols, f_vals, _, _) = amg.fine_smoother();
        let mut dropped = 0;
        for i in 0..n {
            let row = offsets[i]..offsets[i + 1];
            let inv = inv_diag[i];
            let mut want: Vec<(u32, f64)> = Vec::new();
            if i == border {
                want.push((i as u32, values[offsets[i + 1] - 1] * inv));
            } else {
                let big = row
                    .clone()
                    .filter(|&k| cols[k] as usize != i && cols[k] as usize != border)
                    .map(|k| values[k].abs())
                    .fold(0.0, f64::max);
                let mut lumped = 0.0;
                for k in row.clone() {
                    let j = cols[k] as usize;
                    if j == i || (j != border && values[k].abs() >= FILTER * big) {
                        want.push((cols[k], values[k] * inv));
                    } else if j != border {
                        lumped += values[k] * inv;
                        dropped += 1;
                    }
                }
                let d = want.iter_mut().find(|e| e.0 as usize == i).unwrap();
                d.1 += lumped;
                let sum_a: f64 = row
                    .clone()
                    .filter(|&k| cols[k] as usize != border)
                    .map(|k| values[k] * inv)
                    .sum();
                let sum_w: f64 = want.iter().map(|e| e.1).sum();
                assert!(
                    (sum_a - sum_w).abs() < 1e-12,
                    "row {i}: row sum {sum_w}, D⁻¹A's {sum_a}"
                );
            }
            let got: Vec<(u32, f64)> = (f_off[i]..f_off[i + 1])
                .map(|k| (f_cols[k], f_vals[k]))
                .collect();
            assert_eq!(got.len(), want.len(), "row {i}: {got:?} against {want:?}");
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g.0, w.0, "row {i}: {got:?} against {want:?}");
                assert!(
                    (g.1 - w.1).abs() <= 1e-14 * w.1.abs(),
                    "row {i}: {got:?} against {want:?}"
                );
            }
        }
        assert!(dropped > n / 2, "the filter dropped only {dropped} entries");
    }

    /// The smoother's recurrence is the Chebyshev polynomial it claims: on a level whose
    /// `D⁻¹Â` is `diag(λ_i)` (`Â = I`, `D⁻¹ = diag(λ_i)`), `b = 0` and `x = 1`, it leaves
    /// `x_i = p(λ_i) = T_3((θ − λ_i)/δ) / T_3(θ/δ)`, `T_3(s) = 4s³ − 3s`; `|p| ≤ 1` on `[0, ρ]`
    /// (nothing under the Gershgorin bound is amplified) and `max |p| = 1/T_3(5/3)` on
    /// `[0.2ρ, 0.8ρ]`. A wrong coefficient, sign or interval fails here.
    #[test]
    fn chebyshev_smoother_applies_its_polynomial() {
        let rho = 1.7;
        let m = 401;
        let lambda: Vec<f64> = (0..m).map(|i| rho * i as f64 / (m - 1) as f64).collect();
        let mut l = Level {
            a: Csr::from_parts((0..=m).collect(), (0..m as u32).collect(), vec![1.0; m], m),
            inv_diag: lambda.clone(),
            rho,
            x: vec![1.0; m],
            b: vec![0.0; m],
            res: vec![0.0; m],
            dir: vec![f64::NAN; m],
            ..Level::default()
        };
        chebyshev(&mut l, POST_DEGREE);
        assert_eq!(POST_DEGREE, 3, "the closed form below is T_3");
        let t3 = |s: f64| 4.0 * s * s * s - 3.0 * s;
        let (theta, delta) = (CHEB_CENTRE * rho, CHEB_HALF_WIDTH * rho);
        let mut band_max = 0.0f64;
        for (lam, p) in lambda.iter().zip(&l.x) {
            let exact = t3((theta - lam) / delta) / t3(theta / delta);
            assert!(
                (p - exact).abs() < 1e-12,
                "λ = {lam}: p = {p}, T_3 form {exact}"
            );
            assert!(p.abs() <= 1.0 + 1e-12, "λ = {lam}: |p| = {}", p.abs());
            if *lam >= 0.2 * rho - 1e-12 && *lam <= 0.8 * rho + 1e-12 {
                band_max = band_max.max(p.abs());
            }
        }
        assert!((l.x[0] - 1.0).abs() < 1e-12, "p(0) = {}", l.x[0]);
        let bound = 1.0 / t3(5.0 / 3.0);
        assert!(
            (band_max - bound).abs() < 1e-12,
            "max |p| on the band {band_max}, 1/T_3(5/3) = {bound}"
        );
    }
}
