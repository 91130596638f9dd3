use crate::context::{SphContext, gather};
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;
use sph_neighbors::NeighborList;

/// Density by summation, paper Eq. (31): `ρ_i = Σ_j m_j W(|x_i − x_j|, h)` (the sum includes
/// `j = i`).
pub fn density_summation<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    out: &mut [f64],
) {
    assert_eq!(masses.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    gather(out, |i| {
        let xi = ctx.positions[i];
        ctx.neighbors_of(i)
            .map(|j| masses[j] * ctx.kernel.w(ctx.pair(xi, j).length()))
            .sum()
    });
}

/// Density sampled at arbitrary probe points, paper Eq. (31): `ρ̂_a = Σ_b m_b W(|r_a − r_b|, h)`,
/// `a` a probe point and `b` the particles.
///
/// `probe_neighbors` must list, for each probe, the particles within the kernel support (from
/// [`NeighborSearch::query`](sph_neighbors::NeighborSearch::query) on the particle index). This is
/// the density-error measure of the paper's cavity study (uniform array of probe points).
pub fn density_at_points<D: Dim, K: Kernel<D>>(
    probes: &[D::Vector],
    probe_neighbors: &NeighborList,
    positions: &[D::Vector],
    masses: &[f64],
    kernel: &K,
    out: &mut [f64],
) {
    assert_eq!(probes.len(), probe_neighbors.len());
    assert_eq!(out.len(), probes.len());
    assert_eq!(masses.len(), positions.len());
    gather(out, |a| {
        let xa = probes[a];
        probe_neighbors
            .row(a)
            .iter()
            .map(|&b| masses[b as usize] * kernel.w((xa - positions[b as usize]).length()))
            .sum()
    });
}

/// The Shepard sum `Σ_k V W(|k| Δx, h)` of a particle inside an infinite perfect lattice of
/// spacing `Δx = V^{1/D}` (`k` over `ℤ^D`, the particle itself included): what
/// [`kernel_sum_excess`] measures against. Near 1; the difference is the kernel's lattice error
/// at `h/Δx`.
pub fn lattice_kernel_sum<D: Dim, K: Kernel<D>>(kernel: &K, volume: f64) -> f64 {
    over_lattice::<D, K>(kernel, volume, |x| kernel.w(x.length())) * volume
}

/// `Σ_k f(k Δx)` over the points of an infinite perfect lattice of spacing `Δx = V^{1/D}`
/// (`k` over `ℤ^D`, the origin included) within the kernel's support; `f` must vanish beyond it.
pub(crate) fn over_lattice<D: Dim, K: Kernel<D>>(
    kernel: &K,
    volume: f64,
    f: impl Fn(D::Vector) -> f64,
) -> f64 {
    let dx = volume.powf(1.0 / D::DIM as f64);
    let reach = (kernel.support_radius() / dx).ceil() as i64;
    let side = 2 * reach + 1;
    let points = side.pow(D::DIM as u32);
    (0..points)
        .map(|n| {
            let mut rest = n;
            let x = D::Vector::from_fn(|_| {
                let k = rest % side - reach;
                rest /= side;
                k as f64 * dx
            });
            f(x)
        })
        .sum::<f64>()
}

/// Relative excess of each particle's Shepard sum over a perfect lattice's,
/// `e_i = Σ_j V_j W_ij / S_lattice − 1` (`S_lattice` from [`lattice_kernel_sum`] at `volume`):
/// positive where the particles are packed closer than the lattice their volumes stand for, the
/// summation-density error `ρ̂_i/ρ̂_lattice − 1` of Eq. (31) for equal masses. `skip[i]`: write
/// 0 instead (particles whose support is cut by a free surface, where the sum measures the cut
/// and not the packing). Only the first `out.len()` particles are evaluated.
pub fn kernel_sum_excess<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    volume: f64,
    skip: &[bool],
    out: &mut [f64],
) {
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    assert!(skip.len() >= out.len());
    let lattice = lattice_kernel_sum(ctx.kernel, volume);
    gather(out, |i| {
        if skip[i] {
            return 0.0;
        }
        shepard_sum(ctx, i) / lattice - 1.0
    });
}

/// `Σ_j V_j W_ij` over particle `i`'s neighbours, itself included.
fn shepard_sum<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, i: usize) -> f64 {
    let xi = ctx.positions[i];
    ctx.neighbors_of(i)
        .map(|j| ctx.volumes[j] * ctx.kernel.w(ctx.pair(xi, j).length()))
        .sum()
}

/// Rows of a cut lattice [`CutLattice`] tabulates at most: kernel supports up to 15 spacings.
const MAX_CUT_ROWS: usize = 16;

/// A perfect lattice of spacing `Δx = V^{1/D}` cut by a flat face: for a particle `k` rows below
/// the face (`k = 0`: on it), its Shepard sum and the length of its truncation vector,
///
/// ```text
/// S(k) = Σ_{p ∈ ℤ^D, p_1 ≤ k} V W(|p| Δx),   N(k) = |Σ_{p ∈ ℤ^D, p_1 ≤ k} V ∇W(p Δx)|,
/// R(k) = h N(k) / S(k)
/// ```
///
/// (`k` = 0 … `⌈support/Δx⌉`, where `S` is the whole lattice's [`lattice_kernel_sum`], `N = 0`).
/// `R` falls from the face's row to 0 and does not depend on how densely the lattice is packed
/// (`S` and `N` scale alike), so a particle's own ratio `R_i = h |Σ_j V_j ∇W_ij| / Σ_j V_j W_ij`
/// says how deep below a flat face it stands and [`CutLattice::reference`] the Shepard sum it
/// would have there: what [`kernel_sum_excess_near_surface`] measures a cut support against.
///
/// It also tabulates, for the completion of a cut pressure row
/// ([`CutLattice::missing_moments`]), what the face cuts off the Laplacian's and the Eq. 25
/// Hessian's stencils: the moments of `F = x·∇W/(r² + η²)` (the Morris factor,
/// [`laplacian_regulariser`](crate::laplacian_regulariser) `η²`) over the lattice points beyond
/// the face,
///
/// ```text
/// P(k) = V Σ_{x_1 > k} F,   Q_n(k) = V Σ_{x_1 > k} F x_1²/r²,   Q_t(k) = V Σ_{x_1 > k} F x_2²/r²
/// ```
///
/// (`x_1 > k`: beyond the face, `(k + ½) Δx` above the particle; `Q_n + (D − 1) Q_t = P`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutLattice {
    rows: usize,
    sums: [f64; MAX_CUT_ROWS],
    ratios: [f64; MAX_CUT_ROWS],
    missing: [[f64; 3]; MAX_CUT_ROWS],
}

/// What a flat face cuts off a lattice particle's Laplacian and Hessian stencils
/// ([`CutLattice::missing_moments`]): `p = V Σ F`, `q_normal = V Σ F x_n²/r²` and
/// `q_tangential = V Σ F x_t²/r²` over the lattice points beyond the face (`x_n` along the
/// face's outward normal, `x_t` along one direction in the face). All `≤ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MissingMoments {
    /// `V Σ F` over the points beyond the face.
    pub p: f64,
    /// `V Σ F x_n²/r²`, the normal–normal second moment.
    pub q_normal: f64,
    /// `V Σ F x_t²/r²` for one tangential direction.
    pub q_tangential: f64,
}

impl CutLattice {
    /// The table for `kernel` and particle volume `volume`; `None` when the support spans more
    /// than 15 spacings.
    pub fn new<D: Dim, K: Kernel<D>>(kernel: &K, volume: f64) -> Option<Self> {
        let dx = volume.powf(1.0 / D::DIM as f64);
        let reach = (kernel.support_radius() / dx).ceil() as usize;
        if reach >= MAX_CUT_ROWS {
            return None;
        }
        let h = kernel.h();
        let mut sums = [0.0; MAX_CUT_ROWS];
        let mut ratios = [0.0; MAX_CUT_ROWS];
        let mut missing = [[0.0; 3]; MAX_CUT_ROWS];
        let eta2 = crate::laplacian_regulariser(h);
        for k in 0..=reach {
            // Lattice points are whole multiples of Δx: half a spacing decides the cut exactly.
            let below = |x: D::Vector| x.get(0) < (k as f64 + 0.5) * dx;
            let s = over_lattice::<D, K>(kernel, volume, |x| {
                if below(x) { kernel.w(x.length()) } else { 0.0 }
            }) * volume;
            let n = over_lattice::<D, K>(kernel, volume, |x| {
                let r = x.length();
                if below(x) && r > 0.0 {
                    kernel.dw_dr(r) * x.get(0) / r
                } else {
                    0.0
                }
            }) * volume;
            sums[k] = s;
            ratios[k] = if k == reach { 0.0 } else { h * n.abs() / s };
            // F x_l²/r² over the points beyond the face, l = normal (0) and tangential (1).
            let beyond = |l: Option<usize>| {
                over_lattice::<D, K>(kernel, volume, |x| {
                    let r2 = x.length_squared();
                    if below(x) || r2 == 0.0 {
                        return 0.0;
                    }
                    let r = r2.sqrt();
                    let f = kernel.dw_dr(r) * r / (r2 + eta2);
                    match l {
                        Some(l) => f * x.get(l) * x.get(l) / r2,
                        None => f,
                    }
                }) * volume
            };
            let tangential = if D::DIM > 1 { beyond(Some(1)) } else { 0.0 };
            missing[k] = [beyond(None), beyond(Some(0)), tangential];
        }
        Some(Self {
            rows: reach + 1,
            sums,
            ratios,
            missing,
        })
    }

    /// The row (`k`) a truncation ratio falls at and the fraction `f` of the way to row
    /// `k + 1` (linear in `R`); `None` beyond the face row's ratio by more than the fraction
    /// `slack` of it (a ratio within the slack is the face row's).
    fn locate(&self, ratio: f64, slack: f64) -> Option<(usize, f64)> {
        // Beyond the face row's ratio, or not a number: no flat face explains it.
        if ratio.is_nan() || ratio > self.ratios[0] * (1.0 + slack) {
            return None;
        }
        let ratio = ratio.min(self.ratios[0]);
        let last = self.rows - 1;
        let mut k = 0;
        while k < last && self.ratios[k + 1] >= ratio {
            k += 1;
        }
        if k == last {
            return Some((last, 0.0));
        }
        Some((
            k,
            (self.ratios[k] - ratio) / (self.ratios[k] - self.ratios[k + 1]),
        ))
    }

    /// What the face cuts off the stencils of a lattice particle whose truncation ratio is
    /// `ratio` ([`MissingMoments`]), linear in `R` between the rows like
    /// [`CutLattice::reference`]; zero in the bulk, `None` where `ratio` exceeds the face row's.
    /// A ratio above the face row's by round-off (1e-9 of it) is the face row's.
    pub fn missing_moments(&self, ratio: f64) -> Option<MissingMoments> {
        let (k, f) = self.locate(ratio, 1e-9)?;
        let at = |m: usize| {
            let next = self.missing[(k + 1).min(self.rows - 1)][m];
            (1.0 - f) * self.missing[k][m] + f * next
        };
        Some(MissingMoments {
            p: at(0),
            q_normal: at(1),
            q_tangential: at(2),
        })
    }

    /// How far below the face a lattice particle whose truncation ratio is `ratio` stands, in
    /// spacings: `k + ½` on row `k` (the face is half a spacing above the face row), linear in
    /// `R` between the rows like [`CutLattice::reference`]; `None` where `ratio` exceeds the
    /// face row's `R(0)` (a corner, a thin sheet or a particle standing out of its row).
    pub fn depth(&self, ratio: f64) -> Option<f64> {
        let (k, f) = self.locate(ratio, 0.0)?;
        Some(k as f64 + f + 0.5)
    }

    /// The Shepard sum of a lattice particle whose truncation ratio is `ratio` (`R_i` above),
    /// linear in `R` between the rows; `None` when `ratio` exceeds the face row's `R(0)` (a
    /// corner, a thin sheet or a jet: cut more than a flat face cuts).
    pub fn reference(&self, ratio: f64) -> Option<f64> {
        let (k, f) = self.locate(ratio, 0.0)?;
        let next = self.sums[(k + 1).min(self.rows - 1)];
        Some((1.0 - f) * self.sums[k] + f * next)
    }
}

/// [`kernel_sum_excess`] where a free surface cuts the support: a particle of the surface's
/// band (`band[i]`, a free-surface particle in its support) is measured against the Shepard sum
/// it would have at its depth below a flat face of a perfect lattice ([`CutLattice`]),
///
/// ```text
/// e_i = Σ_j V_j W_ij / S(R_i) − 1,   R_i = h |Σ_j V_j ∇W_ij| / Σ_j V_j W_ij
/// ```
///
/// and the others against the whole lattice's. Zero on the free-surface particles themselves
/// (`surface[i]`), where the cut is more than a flat face's (`R_i > R(0)`), and in the band when
/// the support spans more than 15 spacings. On a lattice with a flat face every `e_i` is 0 to
/// round-off; a band packed closer by a factor `s` per axis reads about `s^{−D} − 1`, as the
/// bulk does. Only the first `out.len()` particles are evaluated.
pub fn kernel_sum_excess_near_surface<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    volume: f64,
    surface: &[bool],
    band: &[bool],
    out: &mut [f64],
) {
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    assert!(surface.len() >= out.len() && band.len() >= out.len());
    let lattice = lattice_kernel_sum(ctx.kernel, volume);
    let cut = CutLattice::new::<D, K>(ctx.kernel, volume);
    let h = ctx.kernel.h();
    gather(out, |i| {
        if surface[i] {
            return 0.0;
        }
        if !band[i] {
            return shepard_sum(ctx, i) / lattice - 1.0;
        }
        let Some(cut) = &cut else { return 0.0 };
        let (mut sum, mut nu) = (0.0, D::Vector::ZERO);
        ctx.for_each_pair(i, |p| {
            sum += ctx.volumes[p.j] * ctx.w_of(&p);
            nu += p.grad_w * ctx.volumes[p.j];
        });
        match cut.reference(h * nu.length() / sum) {
            Some(reference) => sum / reference - 1.0,
            None => 0.0,
        }
    });
}

/// The deepest a [`surface_depths`] reading goes, in spacings: a flagged particle stands at the
/// surface, so a truncation that reads deeper than one spacing (a concave surface, a closing air
/// pocket) is held at one.
pub const MAX_SURFACE_DEPTH: f64 = 1.0;

/// Each free-surface particle's distance to the surface, as its truncation says
/// ([`CutLattice::depth`], at most [`MAX_SURFACE_DEPTH`] spacings): where a Robin row puts
/// `p = 0` (`sph_pressure::assemble_surface_rows`),
///
/// ```text
/// δ_i = Δx · min(depth(R_i), 1),   R_i = h |Σ_{j<fluid} V_j ∇W_ij| / Σ_{j<fluid} V_j W_ij
/// ```
///
/// (`Δx = V^{1/D}` of the table's volume), over the particle's fluid neighbours only: a wall
/// standing dry above the surface is no fluid's support, and counted it would put a particle
/// beside it deeper than it is. On a lattice with a flat face the top row reads `Δx/2`, where
/// its fluid ends; a particle sunk into the gaps of the row below reads deeper; one cut more
/// than a flat face cuts — standing out of its row, or beside a wall — `Δx/2`, and one without
/// fluid neighbours `fallback`. `out[i]` for the particles with `measure(i)`, `fallback` for
/// the others. Only the first `out.len()` particles are evaluated.
pub fn surface_depths<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    cut: &CutLattice,
    measure: impl Fn(usize) -> bool + Sync + Send,
    fluid: usize,
    fallback: f64,
    out: &mut [f64],
) {
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    let h = ctx.kernel.h();
    let dx = ctx.volumes[0].powf(1.0 / D::DIM as f64);
    gather(out, |i| {
        if !measure(i) {
            return fallback;
        }
        let (mut sum, mut nu) = (0.0, D::Vector::ZERO);
        ctx.for_each_pair(i, |p| {
            if p.j < fluid {
                sum += ctx.volumes[p.j] * ctx.w_of(&p);
                nu += p.grad_w * ctx.volumes[p.j];
            }
        });
        if sum <= 0.0 || !sum.is_finite() {
            return fallback;
        }
        cut.depth(h * nu.length() / sum)
            .map_or(0.5 * dx, |d| d.min(MAX_SURFACE_DEPTH) * dx)
    });
}
