//! Row-parallel assembly of the pressure equations on the neighbour-list pattern.

use crate::csr::{CsrMatrix, for_each_row_mut};
use crate::error::PressureError;
use rayon::prelude::*;
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;
use sph_operators::{
    CutLattice, SphContext, hessian_stencil_eq25_contracted, hessian_stencil_fit,
    laplacian_regulariser,
};

/// Discrete Hessian used in the DG equation.
pub use sph_operators::HessianForm as DgHessian;

/// Inputs of the right-hand side, per particle.
#[derive(Clone, Copy, Debug)]
pub enum PressureRhs<'a> {
    /// PPE: `∇·u*` per particle.
    DivergenceOfIntermediateVelocity(&'a [f64]),
    /// DG: `det A − 1` per particle, `A = I + ∇(Δt u*)`.
    DetAMinusOne(&'a [f64]),
}

/// Assembles the pressure Poisson equation (paper Eq. 3) with the Cummins & Rudman (1999)
/// Laplacian, rows negated so the diagonal is positive:
///
/// ```text
/// Σ_j c_ij (p_j − p_i) = −∇·u*_i / Δt,      c_ij = −m_j · 8/(ρ_i + ρ_j)² · F_ij ≥ 0
/// ```
///
/// (`2 Σ_j V_j (p_i − p_j) F_ij / ρ` for uniform density). Rows of `dirichlet` particles become
/// `p_i = 0`, and their columns are dropped from the other rows, so the matrix is symmetric.
///
/// With `consistent` (the renormalisation matrices `L_i`), the stencil is made exact for linear
/// fields on any particle arrangement (`linear_consistent`, below); the matrix is then no longer
/// symmetric.
///
/// Only rows `0..rows` are assembled (`rows = ctx.len()`: all); the matrix entries and
/// right-hand side of the others are left as they are, for rows another equation writes (the
/// walls', [`assemble_wall_rows`](crate::assemble_wall_rows)). Columns of every Dirichlet
/// particle are dropped from the assembled rows.
pub fn assemble_ppe<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    densities: &[f64],
    div_u_star: &[f64],
    dt: f64,
    dirichlet: &[bool],
    consistent: Option<&[D::Matrix]>,
    rows: usize,
    matrix: &mut CsrMatrix,
    rhs: &mut [f64],
) -> Result<(), PressureError> {
    let n = ctx.len();
    assert!(masses.len() == n && densities.len() == n && div_u_star.len() == n);
    assert!(dirichlet.len() == n && rhs.len() == n && rows <= n);
    let nl = ctx.neighbors;
    matrix.resize(nl.nnz());
    let (offsets, values) = assembled_rows(nl.offsets(), &mut matrix.values, rows);
    let eta2 = laplacian_regulariser(ctx.kernel.h());
    let any_dirichlet = dirichlet.iter().any(|d| *d);
    for_each_row_mut(offsets, values, &|i, row| {
        let Some((cols, diag)) = begin_row(nl.row(i), i, dirichlet, row) else {
            return;
        };
        let mut sum = 0.0;
        ctx.for_each_pair(i, |p| {
            let j = p.j;
            if j == i {
                return;
            }
            // −8 m_j F_ij / (ρ_i + ρ_j)² with F_ij = s_ij r² / (r² + η²): one division.
            let rho = densities[i] + densities[j];
            let r2 = p.x_ij.length_squared();
            let c = -masses[j] * 8.0 * p.grad_factor * r2 / (rho * rho * (r2 + eta2));
            sum += c;
            row[p.k] = -c;
        });
        if let Some(l) = consistent {
            sum += linear_consistent(ctx, i, cols, diag, &l[i], row);
        }
        if any_dirichlet {
            for (k, &j) in cols.iter().enumerate() {
                if dirichlet[j as usize] {
                    row[k] = 0.0;
                }
            }
        }
        row[diag] = sum;
    });
    fill_rhs(&mut rhs[..rows], dirichlet, |i| -div_u_star[i] / dt);
    check_finite(values, offsets, &rhs[..rows])
}

/// Assembles the deformation-gradient pressure equation of DG-ISPH, paper Eqs. (23)–(24) for
/// any dimension, divided by `Δt²` and negated so the diagonal is positive:
///
/// ```text
/// (1/ρ_i) cof(A_i) : (∇∇p)_i = (det A_i − 1) / Δt²,     (∇∇p)_i = Σ_j C_ij (p_j − p_i)
/// ```
///
/// with `A_i = I + ∇(Δt u*)_i` and `C_ij` the Hessian stencil of `hessian` (Eq. 25 with
/// coefficient `d + 2`, or the exact-for-quadratics fit). For `A = I` the row reduces to the
/// PPE row, a check the tests make. See the crate docs for the sign. Returns the number of rows
/// where the quadratic fit fell back to Eq. 25.
///
/// With `consistent`, the stencil is made exact for linear fields (`linear_consistent`, below).
///
/// Only rows `0..rows` are assembled (`rows = ctx.len()`: all); the matrix entries and
/// right-hand side of the others are left as they are, for rows another equation writes (the
/// walls', [`assemble_wall_rows`](crate::assemble_wall_rows)). Columns of every Dirichlet
/// particle are dropped from the assembled rows.
pub fn assemble_dg<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    densities: &[f64],
    a: &[D::Matrix],
    det_a_minus_one: &[f64],
    dt: f64,
    hessian: DgHessian,
    dirichlet: &[bool],
    consistent: Option<&[D::Matrix]>,
    rows: usize,
    matrix: &mut CsrMatrix,
    rhs: &mut [f64],
) -> Result<usize, PressureError> {
    let n = ctx.len();
    assert!(densities.len() == n && a.len() == n && det_a_minus_one.len() == n);
    assert!(dirichlet.len() == n && rhs.len() == n && rows <= n);
    let nl = ctx.neighbors;
    matrix.resize(nl.nnz());
    let (offsets, values) = assembled_rows(nl.offsets(), &mut matrix.values, rows);
    // Without a Dirichlet row no column is zeroed: the per-row pass over the columns is skipped.
    let any_dirichlet = dirichlet.iter().any(|d| *d);
    let fallbacks = std::sync::atomic::AtomicUsize::new(0);
    for_each_row_mut(offsets, values, &|i, row| {
        let Some((cols, diag)) = begin_row(nl.row(i), i, dirichlet, row) else {
            return;
        };
        let cof = a[i].cofactor();
        let inv_rho = 1.0 / densities[i];
        let mut sum = 0.0;
        // Negated row: −s_ij on p_j, +Σ s_ij on p_i, with
        // s_ij = cof(A):C_ij / ρ_i = (cof(A) / ρ_i):C_ij.
        match hessian {
            DgHessian::Eq25 => hessian_stencil_eq25_contracted(ctx, i, &(cof * inv_rho), |k, s| {
                sum += s;
                row[k] -= s;
            }),
            DgHessian::QuadraticFit => {
                let emit = |k: usize, c: D::Matrix| {
                    let s = cof.contract(&c) * inv_rho;
                    sum += s;
                    row[k] -= s;
                };
                if !hessian_stencil_fit(ctx, i, emit) {
                    fallbacks.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            }
        }
        if let Some(l) = consistent {
            sum += linear_consistent(ctx, i, cols, diag, &l[i], row);
        }
        if any_dirichlet {
            for (k, &j) in cols.iter().enumerate() {
                if k != diag && dirichlet[j as usize] {
                    row[k] = 0.0;
                }
            }
        }
        row[diag] += sum;
    });
    fill_rhs(&mut rhs[..rows], dirichlet, |i| {
        -det_a_minus_one[i] / (dt * dt)
    });
    check_finite(values, offsets, &rhs[..rows])?;
    Ok(fallbacks.into_inner())
}

/// Completes the fluid rows `0..rows` of an assembled pressure equation (after [`assemble_ppe`]
/// or [`assemble_dg`]; the wall rows are another equation's) with the term
/// the symmetric pressure gradient adds to the projection, so the equation solved is the one the
/// velocity correction applies, for any pressure level:
///
/// ```text
/// G_i p = Σ_j V_j (p_i + p_j) ∇W_ij = Σ_j V_j (p_j − p_i) ∇W_ij + p_i c_i,   c_i = 2 Σ_j V_j ∇W_ij
/// ∇·(∇p/ρ)_i  ≈  L_i p + Σ_{j fluid} V_j (p_j c_j/ρ_j − p_i c_i/ρ_i)·∇W_ij
/// ```
///
/// `L_i p` is the assembled row (Morris's Laplacian, or DG's Hessian contracted with
/// `cof(A)/ρ`), which matches the divergence of the *difference* part of `G`; the second sum is
/// the flow divergence of the constant-pressure part `p c/ρ`. `c_i` (`level`, one vector per
/// fluid particle, the symmetric gradient of `p = 1`; a caller may set it to 0 where the term
/// is not wanted, as the flow scenes do in a free surface's band) vanishes where the support is full and
/// the particles are a lattice, and is first order in the disorder elsewhere; without this term
/// the projection of a field whose pressure is large compared with its variation over a support
/// (the bottom of a deep pool, a corner under a run-up) overshoots wherever `c` is not small,
/// and the per-step map `u* → uⁿ⁺¹` can amplify (its eigenvalue near −1: the pressure flips sign
/// every step). Rows are negated like the assembled ones (`−` on `p_j`, `+` on `p_i`). Dirichlet
/// rows are left alone and Dirichlet columns stay 0 (their `p_j = 0`); wall columns get nothing
/// (the walls' velocities are not corrected by the projection). The matrix is no longer
/// symmetric.
pub fn add_level_term<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    level: &[D::Vector],
    densities: &[f64],
    dirichlet: &[bool],
    rows: usize,
    matrix: &mut CsrMatrix,
) -> Result<(), PressureError> {
    assert!(level.len() >= rows && densities.len() == ctx.len() && dirichlet.len() == ctx.len());
    let nl = ctx.neighbors;
    let (offsets, values) = assembled_rows(nl.offsets(), &mut matrix.values, rows);
    for_each_row_mut(offsets, values, &|i, row| {
        if dirichlet[i] {
            return;
        }
        let mut sigma = D::Vector::ZERO;
        let mut diag = None;
        ctx.for_each_pair(i, |p| {
            let j = p.j;
            if j == i {
                diag = Some(p.k);
                return;
            }
            if j >= rows {
                return;
            }
            let vw = p.grad_w * ctx.volumes[j];
            sigma += vw;
            if !dirichlet[j] {
                row[p.k] -= level[j].dot(vw) / densities[j];
            }
        });
        let diag = diag.expect("neighbour rows contain the particle");
        row[diag] += level[i].dot(sigma) / densities[i];
    });
    check_finite(values, offsets, &[])
}

/// Completes the rows of the particles in a free surface's band (`band[i]`: a free-surface
/// particle in the support; rows `0..rows`, the surface particles' own, `surface[i]`, left
/// alone) with the part of their stencil the surface cuts off, read as air at `p = 0`: where the
/// assembled row (Morris's Laplacian, or DG's Eq. 25 Hessian contracted with `M_i = cof(A_i)/ρ_i`)
/// has no neighbours beyond the surface, it reads them as `p_j = p_i` (no flux into the air);
/// the completion adds, on the diagonal, what the neighbours a perfect lattice would have there
/// contribute at `p_j = 0`:
///
/// ```text
/// row_i += p_i Σ_{j beyond} M_i : C_ij = −p_i [(d + 2) M_i : Q_i − tr M_i · P_i],
/// Q_i = q_n n_i⊗n_i + q_t (I − n_i⊗n_i)
/// ```
///
/// with `C_ij = −V_j F_ij ((d + 2) x_ij⊗x_ij/r² − I)` the Eq. 25 stencil (whose trace is Morris's,
/// so `M = I/ρ` gives the PPE's `−2 P_i/ρ_i`), `(P, q_n, q_t)` the [`CutLattice`]'s missing
/// moments at the particle's truncation ratio `R_i = h |Σ_j V_j ∇W_ij| / Σ_j V_j W_ij` and `n_i`
/// the outward normal `−Σ_j V_j ∇W_ij / |…|`. On a perfect lattice with a flat face the
/// completed row is the whole lattice's row with the air's pressures 0, to round-off. Rows
/// whose support is cut more than a flat face cuts (`R_i` beyond the face row's), or not at all,
/// are left alone. `metric(i)` is `M_i`; rows are negated like the assembled ones.
pub fn complete_cut_rows<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    band: &[bool],
    surface: &[bool],
    cut: &CutLattice,
    metric: &(dyn Fn(usize) -> D::Matrix + Sync),
    rows: usize,
    matrix: &mut CsrMatrix,
) -> Result<(), PressureError> {
    assert!(band.len() >= rows && surface.len() >= rows && rows <= ctx.len());
    let nl = ctx.neighbors;
    let (offsets, values) = assembled_rows(nl.offsets(), &mut matrix.values, rows);
    let h = ctx.kernel.h();
    let d = D::DIM as f64;
    for_each_row_mut(offsets, values, &|i, row| {
        if !band[i] || surface[i] {
            return;
        }
        let (mut sum, mut nu, mut diag) = (0.0, D::Vector::ZERO, None);
        ctx.for_each_pair(i, |p| {
            if p.j == i {
                diag = Some(p.k);
            }
            sum += ctx.volumes[p.j] * ctx.w_of(&p);
            nu += p.grad_w * ctx.volumes[p.j];
        });
        let length = nu.length();
        if length == 0.0 || sum <= 0.0 {
            return;
        }
        let Some(m) = cut.missing_moments(h * length / sum) else {
            return;
        };
        let n = nu * (-1.0 / length);
        let metric = metric(i);
        let trace = metric.trace();
        let nmn = metric.quadratic_form(n);
        let mq = m.q_normal * nmn + m.q_tangential * (trace - nmn);
        let diag = diag.expect("neighbour rows contain the particle");
        row[diag] -= (d + 2.0) * mq - trace * m.p;
    });
    check_finite(values, offsets, &[])
}

/// Makes a stencil `Σ_j a_ij (p_j − p_i)` (row `i` holding `−a_ij` off the diagonal) exact for
/// linear fields on any particle arrangement, by subtracting the linear part the renormalised
/// gradient `G_i p = Σ_k V_k (p_k − p_i) L_i∇W_ik` measures:
///
/// ```text
/// Σ_j a_ij (p_j − p_i − x_ji·G_i p) = Σ_k a'_ik (p_k − p_i),
/// a'_ik = a_ik + V_k s_i·(L_i ∇W_ik),   s_i = Σ_j a_ij x_ij
/// ```
///
/// (the Laplacian correction of Fatehi & Manzari 2011, Comput. Math. Appl. 61, 482, in its
/// one-ring form: the stencil keeps the neighbour pattern). For a linear field the bracket
/// vanishes, so a hydrostatic pressure is an exact discrete solution however disordered the
/// particles are; on a symmetric neighbourhood `s_i = 0` and the stencil is unchanged. Updates
/// the off-diagonal entries and returns `Σ_k (a'_ik − a_ik)` for the diagonal.
fn linear_consistent<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    cols: &[u32],
    diag: usize,
    l: &D::Matrix,
    row: &mut [f64],
) -> f64 {
    let xi = ctx.positions[i];
    let mut s_i = D::Vector::ZERO;
    for (k, &j) in cols.iter().enumerate() {
        if k != diag {
            s_i += ctx.pair(xi, j as usize) * (-row[k]);
        }
    }
    let mut added = 0.0;
    ctx.for_each_pair(i, |p| {
        if p.k == diag {
            return;
        }
        let g = *l * p.grad_w;
        let delta = ctx.volumes[p.j] * s_i.dot(g);
        row[p.k] -= delta;
        added += delta;
    });
    added
}

/// Clears `row` and returns its columns and diagonal position, or writes the Dirichlet row
/// `p_i = 0` and returns `None`.
#[inline]
fn begin_row<'a>(
    cols: &'a [u32],
    i: usize,
    dirichlet: &[bool],
    row: &mut [f64],
) -> Option<(&'a [u32], usize)> {
    row.fill(0.0);
    let diag = cols
        .binary_search(&(i as u32))
        .expect("neighbour rows contain the particle");
    if dirichlet[i] {
        row[diag] = 1.0;
        return None;
    }
    Some((cols, diag))
}

/// `rhs_i = value(i)`, or 0 on Dirichlet rows.
fn fill_rhs(rhs: &mut [f64], dirichlet: &[bool], value: impl Fn(usize) -> f64) {
    for (i, (r, d)) in rhs.iter_mut().zip(dirichlet).enumerate() {
        *r = if *d { 0.0 } else { value(i) };
    }
}

/// The offsets and values of rows `0..rows` of a matrix on the pattern `offsets`.
fn assembled_rows<'a>(
    offsets: &'a [usize],
    values: &'a mut [f64],
    rows: usize,
) -> (&'a [usize], &'a mut [f64]) {
    let offsets = &offsets[..=rows];
    (offsets, &mut values[..offsets[rows]])
}

/// Every entry of `values` (rows on the pattern `offsets`) and `rhs` finite, or the first row
/// holding one that is not.
fn check_finite(values: &[f64], offsets: &[usize], rhs: &[f64]) -> Result<(), PressureError> {
    // The common case, all finite, checked in parallel; the first culprit (the same for any
    // number of threads) is then searched for in order.
    let finite = |v: &[f64]| v.par_iter().with_min_len(1 << 14).all(|x| x.is_finite());
    if finite(rhs) && finite(values) {
        return Ok(());
    }
    if let Some(row) = rhs.iter().position(|v| !v.is_finite()) {
        return Err(PressureError::NonFinite {
            what: "right-hand side",
            row,
        });
    }
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        let row = offsets.partition_point(|&o| o <= k) - 1;
        return Err(PressureError::NonFinite {
            what: "matrix entry",
            row,
        });
    }
    Ok(())
}
