//! Pressure rows of wall (dummy) particles and the gauge of closed domains.

use crate::SolveError;
use crate::csr::{CsrMatrix, for_each_row_mut};
use crate::error::PressureError;
use crate::solver::{Border, CsrSystem, LinearSolver, SolveInfo, SolveParams};
use rayon::prelude::*;
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;
use sph_operators::SphContext;

/// Overwrites the rows `first_wall..n` (the wall particles) with the pressure extrapolation of
/// Adami, Hu & Adams (2012), J. Comput. Phys. 231, 7057, Eq. (27):
///
/// ```text
/// p_w − Σ_f p_f W_wf / Σ_f W_wf = Σ_f ρ_f (g_w·(x_w − x_f)) W_wf / Σ_f W_wf
/// ```
///
/// (sums over the fluid neighbours `f < first_wall` of `w`), where `g_w = wall_gradient[w −
/// first_wall]` is the pressure gradient per density prescribed at the wall particle — Adami's
/// `g − a_w`, or the projection's Neumann data (see `sph_integrators::WallCondition`). The wall
/// pressures are unknowns of the same linear system, so the fluid rows' Laplacian (or DG
/// Hessian) reaches them through the ordinary neighbour pattern. A wall particle with no fluid
/// neighbour gets `p_w = 0`; it never influences a fluid particle, since it is further than one
/// support radius from all of them.
pub fn assemble_wall_rows<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    first_wall: usize,
    densities: &[f64],
    wall_gradient: &[D::Vector],
    matrix: &mut CsrMatrix,
    rhs: &mut [f64],
) -> Result<(), PressureError> {
    let nl = ctx.neighbors;
    check_wall_block(ctx, first_wall, densities, wall_gradient.len(), matrix, rhs);
    // Row w: −W_wf / Σ_f W_wf on the fluid neighbours f, 1 on the diagonal.
    for_each_row_mut(nl.offsets(), &mut matrix.values, &|w, row| {
        if w < first_wall {
            return;
        }
        let cols = nl.row(w);
        let xw = ctx.positions[w];
        let mut sum_w = 0.0;
        for (v, &j) in row.iter_mut().zip(cols) {
            let j = j as usize;
            *v = if j < first_wall {
                let wij = ctx.kernel.w(ctx.pair(xw, j).length());
                sum_w += wij;
                -wij
            } else {
                0.0
            };
        }
        if sum_w > 0.0 {
            for v in row.iter_mut() {
                *v /= sum_w;
            }
        }
        let diag = cols
            .binary_search(&(w as u32))
            .expect("neighbour rows contain the particle");
        row[diag] = 1.0;
    });
    // rhs_w = Σ_f a_wf ρ_f g_w·(x_w − x_f) with the row's weights a_wf = −(row value).
    let values = &matrix.values;
    rhs[first_wall..]
        .par_iter_mut()
        .zip(wall_gradient)
        .enumerate()
        .with_min_len(256)
        .for_each(|(k, (r, &g))| {
            let w = first_wall + k;
            *r = 0.0;
            if g != D::Vector::ZERO {
                let xw = ctx.positions[w];
                let a = &values[nl.offsets()[w]..nl.offsets()[w + 1]];
                for (&v, &j) in a.iter().zip(nl.row(w)) {
                    let j = j as usize;
                    if j < first_wall {
                        *r -= v * densities[j] * g.dot(ctx.pair(xw, j));
                    }
                }
            }
        });
    let bad = matrix.values[nl.offsets()[first_wall]..]
        .iter()
        .chain(&rhs[first_wall..])
        .any(|v| !v.is_finite());
    if bad {
        return Err(PressureError::NonFinite {
            what: "wall pressure row",
            row: first_wall,
        });
    }
    Ok(())
}

/// Folds the columns of mirror ghosts (particles `first_wall..n`, see
/// `sph_integrators::Ghosts`) onto their sources': a ghost `g` of the fluid particle
/// `s = sources[g − first_wall]` carries `p_g = p_s + c_g`, `c_g = ρ_s grad·(x_g − x_s)` with
/// `grad` the prescribed `∇p/ρ` (Szewc, Pozorski & Minier 2012: the mirror particle has its
/// source's pressure; gravity adds the hydrostatic slope), so in a fluid row
///
/// ```text
/// Σ_j a_ij p_j = b_i   becomes   Σ_{j fluid} a_ij p_j + Σ_g a_ig p_{s(g)} = b_i − Σ_g a_ig c_g.
/// ```
///
/// The source is in every row its ghost is in: mirrored across the faces of a box, `x_g` is
/// at least as far from a fluid particle as `x_s` along every axis. (A row where it is not —
/// a particle already past a wall — keeps the ghost's column, whose pressure the solve then
/// takes as 0.) The ghost rows become `p_g = 0`; the caller sets `p_g = p_s + c_g` after the
/// solve. A parked slot (`sources[k] = u32::MAX`) is never a fluid particle's neighbour; its
/// row is `p = 0` too.
pub fn fold_ghost_columns<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    first_wall: usize,
    sources: &[u32],
    densities: &[f64],
    grad: D::Vector,
    matrix: &mut CsrMatrix,
    rhs: &mut [f64],
) -> Result<(), PressureError> {
    let nl = ctx.neighbors;
    check_wall_block(ctx, first_wall, densities, sources.len(), matrix, rhs);
    let offsets = nl.offsets();
    // The right-hand side first, from the coefficients before they move: b_i −= Σ_g a_ig c_g.
    if grad != D::Vector::ZERO {
        let values = &matrix.values;
        rhs[..first_wall]
            .par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, r)| {
                let (start, cols) = (offsets[i], nl.row(i));
                for (pos, &j) in cols.iter().enumerate() {
                    let j = j as usize;
                    if j < first_wall {
                        continue;
                    }
                    let s = sources[j - first_wall];
                    if s == u32::MAX || cols.binary_search(&s).is_err() {
                        continue;
                    }
                    let s = s as usize;
                    let c = densities[s] * grad.dot(ctx.positions[j] - ctx.positions[s]);
                    *r -= values[start + pos] * c;
                }
            });
    }
    let (fluid_values, wall_values) = matrix.values.split_at_mut(offsets[first_wall]);
    // Fluid rows: a_{i s(g)} += a_ig, a_ig = 0 (each row touches only its own entries).
    crate::csr::for_each_row_mut(&offsets[..=first_wall], fluid_values, &|i, row| {
        let cols = nl.row(i);
        for pos in 0..row.len() {
            let j = cols[pos] as usize;
            if j < first_wall || row[pos] == 0.0 {
                continue;
            }
            let s = sources[j - first_wall];
            if s == u32::MAX {
                continue;
            }
            if let Ok(at) = cols.binary_search(&s) {
                row[at] += row[pos];
                row[pos] = 0.0;
            }
        }
    });
    let base = offsets[first_wall];
    // Ghost and parked rows: p = 0.
    for (k, r) in rhs[first_wall..].iter_mut().enumerate() {
        *r = 0.0;
        let w = first_wall + k;
        let row = &mut wall_values[offsets[w] - base..offsets[w + 1] - base];
        row.fill(0.0);
        let diag = nl
            .row(w)
            .binary_search(&(w as u32))
            .expect("neighbour rows contain the particle");
        row[diag] = 1.0;
    }
    if let Some(row) = rhs[..first_wall].iter().position(|v| !v.is_finite()) {
        return Err(PressureError::NonFinite {
            what: "ghost-folded right-hand side",
            row,
        });
    }
    Ok(())
}

/// The shape every assembler of the wall block expects: particles `first_wall..n` are the walls
/// (`per_wall` entries, one per wall particle), one density and right-hand side per particle,
/// the matrix on the neighbour pattern.
fn check_wall_block<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    first_wall: usize,
    densities: &[f64],
    per_wall: usize,
    matrix: &CsrMatrix,
    rhs: &[f64],
) {
    let n = ctx.len();
    assert!(first_wall <= n && densities.len() == n && rhs.len() == n);
    assert_eq!(per_wall, n - first_wall);
    assert_eq!(matrix.values.len(), ctx.neighbors.nnz());
}

/// Gauge of a pressure equation without Dirichlet rows (a closed domain: the pressure is defined
/// up to a constant). The system `M p = b` is bordered with the constraint `Σ_{i∈G} p_i = 0`
/// over the gauge rows `G` (the fluid particles) and a Lagrange multiplier `λ` added to those
/// rows:
///
/// ```text
/// [ M    s·1_G ] [p]   [b]
/// [ s·1_Gᵀ  0  ] [λ] = [0]
/// ```
///
/// `s` (the mean diagonal of the gauge rows) only scales the border; the sum of the gauge rows is
/// added to the border row (an equivalent system) so its diagonal is `s·|G|`, not 0, and
/// Jacobi and ILU(0) apply unchanged. The bordered matrix is
/// regular when the singular `M` has the constants as its null space; `λ = (yᵀb)/(s yᵀ1_G)` is
/// the part of `b` incompatible with the constants (`yᵀM = 0`), which the border spreads
/// uniformly over the gauge rows instead of letting it drift the pressure level. No noise and no
/// diagonal shift is added. The border is passed beside `M` ([`Border`]), so `M` is not
/// copied; the buffers (the border row, the right-hand side and the unknowns, `n + 1` each)
/// are reused between steps.
#[derive(Clone, Debug, Default)]
pub struct MeanZeroGauge {
    row: Vec<f64>,
    rhs: Vec<f64>,
    x: Vec<f64>,
    diag: Vec<f64>,
    /// Multiplier `λ` of the last solve (in units of the right-hand side, i.e. `s·λ`).
    pub last_multiplier: f64,
}

impl MeanZeroGauge {
    /// Solves `system` (n unknowns, no border of its own) under the gauge
    /// `Σ_{i < gauge_rows} p_i = 0`; the gauge rows are the first `gauge_rows` unknowns. `x`
    /// holds the warm start and receives the solution.
    pub fn solve<S: LinearSolver + ?Sized>(
        &mut self,
        solver: &mut S,
        system: &CsrSystem<'_>,
        gauge_rows: usize,
        x: &mut [f64],
        params: &SolveParams,
    ) -> Result<SolveInfo, SolveError> {
        let n = system.n();
        assert!(system.border.is_none() && gauge_rows <= n && x.len() == n);
        // The diagonals found in parallel (a search and a cache miss per row), summed in row
        // order (the same sum for any number of threads).
        self.diag.clear();
        self.diag.resize(gauge_rows, 0.0);
        self.diag
            .par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(i, d)| {
                *d = system
                    .diagonal_position(i)
                    .map_or(0.0, |k| system.values[k].abs());
            });
        let diag_mean = self.diag.iter().sum::<f64>() / gauge_rows.max(1) as f64;
        let s = if diag_mean > 0.0 { diag_mean } else { 1.0 };
        // Border row: the constraint s·Σ_G p_i = 0 plus the sum of the gauge rows (an
        // equivalent system) so that its diagonal, s·|G|, is non-zero for Jacobi and ILU(0):
        //   Σ_j (s·[j∈G] + Σ_{i∈G} M_ij) p_j + s|G| λ = Σ_{i∈G} b_i.
        self.row.clear();
        self.row.resize(n, 0.0);
        for i in 0..gauge_rows {
            for k in system.offsets[i]..system.offsets[i + 1] {
                self.row[system.cols[k] as usize] += system.values[k];
            }
        }
        for c in &mut self.row[..gauge_rows] {
            *c += s;
        }
        self.row.push(s * gauge_rows as f64);
        self.rhs.clear();
        self.rhs.extend_from_slice(system.rhs);
        self.rhs.push(system.rhs[..gauge_rows].iter().sum());
        // Warm start: the previous pressure with its mean removed, λ = 0.
        let mean = x[..gauge_rows].iter().sum::<f64>() / gauge_rows.max(1) as f64;
        self.x.clear();
        self.x.extend(x.iter().map(|v| v - mean));
        self.x.push(0.0);
        let bordered = CsrSystem {
            rhs: &self.rhs,
            border: Some(Border {
                rows: gauge_rows,
                column: s,
                row: &self.row,
            }),
            ..*system
        };
        let info = solver.solve(&bordered, &mut self.x, params)?;
        x.copy_from_slice(&self.x[..n]);
        self.last_multiplier = s * self.x[n];
        Ok(info)
    }
}

/// Overwrites the rows of the free-surface particles (`surface[i]`, `i < rows`) with a Robin
/// condition that puts `p = 0` a distance `depth[i]` outside the particle instead of at it:
///
/// ```text
/// p_i + δ_i n_i·(∇p)_i = 0,    (∇p)_i = L_i Σ_j V_j (p_j − p_i) ∇W_ij,
/// n_i = −ν_i/|ν_i|,   ν_i = L_i Σ_j V_j ∇W_ij
/// ```
///
/// (`L_i` the renormalisation matrices, so the gradient is exact for linear pressures however
/// truncated the support; `n_i` the outward normal of the truncated support; `δ_i = depth[i]`).
/// A particle of a lattice whose top row is at `y_s` represents fluid up to `y_s + Δx/2`: with
/// `δ_i = Δx/2` (what `sph_operators::surface_depths` measures there) a hydrostatic pressure `ρ g (y_s + Δx/2 − y)` solves these rows exactly, where the
/// Dirichlet row `p_i = 0` shifts the whole column's pressure by `ρ g Δx/2`. A particle with a
/// symmetric or empty neighbourhood (`ν_i = 0`) keeps `p_i = 0`. The surface pressures stay
/// unknowns, so the other rows must keep their columns (assemble them without Dirichlet
/// flags). The right-hand side of these rows is 0.
pub fn assemble_surface_rows<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    surface: &[bool],
    corrections: &[D::Matrix],
    depth: &[f64],
    rows: usize,
    matrix: &mut CsrMatrix,
    rhs: &mut [f64],
) -> Result<(), PressureError> {
    let nl = ctx.neighbors;
    let n = ctx.len();
    assert!(rows <= n && surface.len() >= rows && corrections.len() >= rows);
    assert!(depth.len() >= rows, "one depth per row");
    assert_eq!(matrix.values.len(), nl.nnz());
    let offsets = &nl.offsets()[..=rows];
    let values = &mut matrix.values[..offsets[rows]];
    for_each_row_mut(offsets, values, &|i, row| {
        if !surface[i] {
            return;
        }
        row.fill(0.0);
        let diag = nl
            .row(i)
            .binary_search(&(i as u32))
            .expect("neighbour rows contain the particle");
        let l = corrections[i];
        let mut nu = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| nu += p.grad_w * ctx.volumes[p.j]);
        let nu = l * nu;
        let len = nu.length();
        row[diag] = 1.0;
        if !(len > 0.0 && len.is_finite()) {
            return;
        }
        let n = nu * (-1.0 / len);
        let mut sum = 0.0;
        ctx.for_each_pair(i, |p| {
            if p.j != i {
                let a = depth[i] * ctx.volumes[p.j] * n.dot(l * p.grad_w);
                row[p.k] = a;
                sum += a;
            }
        });
        row[diag] = 1.0 - sum;
    });
    for (r, s) in rhs[..rows].iter_mut().zip(surface) {
        if *s {
            *r = 0.0;
        }
    }
    let finite = values
        .par_iter()
        .with_min_len(1 << 14)
        .all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        let k = values.iter().position(|v| !v.is_finite()).unwrap_or(0);
        Err(PressureError::NonFinite {
            what: "matrix entry",
            row: offsets.partition_point(|&o| o <= k) - 1,
        })
    }
}
