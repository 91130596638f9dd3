use rayon::prelude::*;
use sph_core::{Dim, Periodic, VectorOps};
use sph_kernels::Kernel;
use sph_neighbors::NeighborList;

/// What every operator reads: particle positions and volumes, the neighbour lists and the kernel.
///
/// `neighbors` must be the self-join of `positions` with radius ≥ the kernel support (each row
/// may include the particle itself; zero-distance pairs contribute nothing to derivatives).
#[derive(Clone, Copy, Debug)]
pub struct SphContext<'a, D: Dim, K: Kernel<D>> {
    /// Positions `x_i`.
    pub positions: &'a [D::Vector],
    /// Volumes `V_i = m_i / ρ_i`.
    pub volumes: &'a [f64],
    /// Neighbour lists (CSR), one row per particle.
    pub neighbors: &'a NeighborList,
    /// Smoothing kernel.
    pub kernel: &'a K,
    /// Periodic axes, if any: pair vectors are then minimum images (see [`SphContext::pair`]).
    pub periodic: Option<Periodic<D>>,
    /// Kernel-gradient factors `s_ij = (dW/dr)/r` of every neighbour-list entry, if computed
    /// once for the step's passes ([`grad_factors`], attached by
    /// [`SphContext::with_grad_factors`]); `None`: each pass evaluates the kernel itself.
    /// Both give the same bits.
    pub grad_factors: Option<&'a [f64]>,
    /// Kernel values `W_ij` of every neighbour-list entry, if computed once for the step
    /// ([`grad_factors_and_values`], attached by [`SphContext::with_kernel_values`]); read
    /// by [`SphContext::w_of`]. Same bits as evaluating the kernel.
    pub kernel_values: Option<&'a [f64]>,
}

/// One neighbour of particle `i` as the pair loops see it.
#[derive(Clone, Copy, Debug)]
pub struct Pair<V> {
    /// Position of the entry in the neighbour list's row `i` (the column of a matrix built on
    /// the list's pattern).
    pub k: usize,
    /// Position of the entry in the whole list (index into per-entry arrays).
    pub e: usize,
    /// The neighbour's index `j`.
    pub j: usize,
    /// `x_ij = x_i − x_j` (minimum image on periodic axes).
    pub x_ij: V,
    /// `∇_i W(x_ij)`.
    pub grad_w: V,
    /// The kernel's gradient factor `s_ij = W'(r_ij)/r_ij` (`grad_w = s_ij x_ij`; 0 at
    /// `r = 0`), for passes that need `x_ij·∇W_ij = s_ij r_ij²` without forming it.
    pub grad_factor: f64,
}

impl<'a, D: Dim, K: Kernel<D>> SphContext<'a, D, K> {
    /// Bundles the inputs; panics if the slices and neighbour list disagree on the particle count
    /// (a programming error, not a data error).
    pub fn new(
        positions: &'a [D::Vector],
        volumes: &'a [f64],
        neighbors: &'a NeighborList,
        kernel: &'a K,
    ) -> Self {
        assert_eq!(positions.len(), volumes.len(), "one volume per particle");
        assert_eq!(
            positions.len(),
            neighbors.len(),
            "one neighbour row per particle"
        );
        Self {
            positions,
            volumes,
            neighbors,
            kernel,
            periodic: None,
            grad_factors: None,
            kernel_values: None,
        }
    }

    /// The same context reading the kernel-gradient factors `factors` (from [`grad_factors`]
    /// on the same positions, neighbour lists, kernel and periodic axes) instead of evaluating
    /// the kernel in every pass. Panics if `factors` does not have one entry per neighbour-list
    /// entry (a programming error).
    pub fn with_grad_factors(mut self, factors: &'a [f64]) -> Self {
        self.grad_factors = Some(self.per_entry(factors, "kernel-gradient factor"));
        self
    }

    /// `values`, checked to hold one `what` per neighbour-list entry (a programming error if not).
    fn per_entry(&self, values: &'a [f64], what: &str) -> &'a [f64] {
        assert_eq!(
            values.len(),
            self.neighbors.nnz(),
            "one {what} per neighbour-list entry"
        );
        values
    }

    /// The same context on a periodic domain (`None`: not periodic).
    pub fn with_periodic(mut self, periodic: Option<Periodic<D>>) -> Self {
        self.periodic = periodic;
        self
    }

    /// The pair vector `x_ij = x_i − x_j` from `x_i` to neighbour `j`, as the minimum image
    /// across periodic axes when the domain has any.
    #[inline(always)]
    pub fn pair(&self, xi: D::Vector, j: usize) -> D::Vector {
        let d = xi - self.positions[j];
        match &self.periodic {
            None => d,
            Some(p) => p.minimum_image(d),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True if there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Calls `f` for every neighbour of particle `i`, in the order of the neighbour list, with
    /// its pair vector and kernel gradient `∇_i W_ij = s_ij x_ij`: `s_ij` read from the
    /// attached factors, or, when there are none, evaluated ([`Kernel::grad_factor`]) for up to
    /// [`PAIR_BLOCK`] entries at a time into a stack buffer. Either way `f` has a single call
    /// site in one loop without branches on the cache (so it is inlined and the loop stays
    /// straight-line code), and the bits are the same.
    #[inline(always)]
    pub fn for_each_pair(&self, i: usize, mut f: impl FnMut(Pair<D::Vector>)) {
        let xi = self.positions[i];
        let (a, b) = (self.neighbors.offsets()[i], self.neighbors.offsets()[i + 1]);
        let indices = self.neighbors.indices();
        let mut start = a;
        while start < b {
            let end = b.min(start + PAIR_BLOCK);
            let row = &indices[start..end];
            // Initialised only where used: zeroing it for every row of every pass (a 512-byte
            // `memset` call) cost more than the pass's use of attached factors.
            let buf: [f64; PAIR_BLOCK];
            let factors: &[f64] = match self.grad_factors {
                Some(all) => &all[start..end],
                None => {
                    buf = std::array::from_fn(|k| {
                        row.get(k)
                            .map_or(0.0, |&j| self.kernel.grad_factor(self.pair(xi, j as usize)))
                    });
                    &buf[..row.len()]
                }
            };
            for (k, (&j, &s)) in row.iter().zip(factors).enumerate() {
                let j = j as usize;
                let x_ij = self.pair(xi, j);
                f(Pair {
                    k: start - a + k,
                    e: start + k,
                    j,
                    x_ij,
                    grad_w: x_ij * s,
                    grad_factor: s,
                });
            }
            start = end;
        }
    }

    /// The same context reading the kernel values `values` (from [`grad_factors_and_values`]
    /// on the same positions, neighbour lists, kernel and periodic axes) in [`SphContext::w_of`].
    /// Panics if `values` does not have one entry per neighbour-list entry.
    pub fn with_kernel_values(mut self, values: &'a [f64]) -> Self {
        self.kernel_values = Some(self.per_entry(values, "kernel value"));
        self
    }

    /// `W(|x_ij|)` of a pair from [`SphContext::for_each_pair`]: read from the attached values,
    /// or evaluated.
    #[inline(always)]
    pub fn w_of(&self, p: &Pair<D::Vector>) -> f64 {
        match self.kernel_values {
            Some(v) => v[p.e],
            None => self.kernel.w(p.x_ij.length()),
        }
    }

    /// Neighbours of particle `i` as `usize` indices.
    #[inline(always)]
    pub fn neighbors_of(&self, i: usize) -> impl Iterator<Item = usize> + 'a {
        self.neighbors.row(i).iter().map(|&j| j as usize)
    }
}

/// The regulariser `η² = (0.01 h)²` of `F_ij = x_ij·∇W_ij / (r² + η²)` (paper, below Eq. 26).
#[inline(always)]
pub fn laplacian_regulariser(h: f64) -> f64 {
    (0.01 * h) * (0.01 * h)
}

/// `F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²)` (paper, below Eq. 26): the scalar kernel factor of
/// the Morris Laplacian and the Eq. 25 Hessian. `F_ij ≤ 0`; zero for `x_ij = 0`.
#[inline(always)]
pub fn pair_f<D: Dim, K: Kernel<D>>(kernel: &K, x_ij: D::Vector) -> f64 {
    pair_f_of::<D>(x_ij, kernel.grad_w(x_ij), kernel.h())
}

/// [`pair_f`] from the pair's kernel gradient `grad_w = ∇_i W(x_ij)` (as a
/// [`Pair`] carries it) and the smoothing length `h`.
#[inline(always)]
pub fn pair_f_of<D: Dim>(x_ij: D::Vector, grad_w: D::Vector, h: f64) -> f64 {
    use sph_core::VectorOps;
    x_ij.dot(grad_w) / (x_ij.length_squared() + laplacian_regulariser(h))
}

/// `out[e] = s_ij = (dW/dr)(r_ij) / r_ij` for every entry `e` of the neighbour lists of `ctx`
/// (0 for `r = 0`), computed once so the step's passes share it through
/// [`SphContext::with_grad_factors`] instead of each evaluating the kernel (a square root, a
/// division and the kernel polynomial per pair and pass). `out` is resized to the number of
/// entries (no allocation once it has reached it).
pub fn grad_factors<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, out: &mut Vec<f64>) {
    out.resize(ctx.neighbors.nnz(), 0.0);
    sph_neighbors::for_each_row_mut(ctx.neighbors.offsets(), out, &|i, row| {
        let xi = ctx.positions[i];
        for (s, &j) in row.iter_mut().zip(ctx.neighbors.row(i)) {
            *s = ctx.kernel.grad_factor(ctx.pair(xi, j as usize));
        }
    });
}

/// [`grad_factors`] and, in `values`, the kernel values `W(r_ij)` of every entry, from one
/// square root per pair (for a step whose passes also read `W` per pair: particle shifting's
/// concentration term). Both are resized to the number of entries.
pub fn grad_factors_and_values<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    factors: &mut Vec<f64>,
    values: &mut Vec<f64>,
) {
    factors.resize(ctx.neighbors.nnz(), 0.0);
    values.resize(ctx.neighbors.nnz(), 0.0);
    sph_neighbors::for_each_row_mut2(ctx.neighbors.offsets(), factors, values, &|i, fr, vr| {
        let xi = ctx.positions[i];
        for ((s, w), &j) in fr.iter_mut().zip(vr.iter_mut()).zip(ctx.neighbors.row(i)) {
            let r = ctx.pair(xi, j as usize).length();
            *s = ctx.kernel.grad_factor_at(r);
            *w = ctx.kernel.w(r);
        }
    });
}

/// [`grad_factors`] (and, with `values`, [`grad_factors_and_values`]' kernel values) from the
/// squared pair distances `r_ij²` the neighbour search measured
/// ([`CellGrid::query_with_squared_distances`](sph_neighbors::CellGrid::query_with_squared_distances)):
/// `factors` holds `r_ij²` of every entry on entry and `s_ij = (dW/dr)(r_ij)/r_ij` on exit,
/// `r_ij = √(r_ij²)`; `values` is resized to the number of entries and filled with `W(r_ij)`.
/// A stream over the entries, without gathering the positions again: bitwise the numbers of
/// the passes above when the distances are those of `ctx.pair` (a search without periodic
/// axes).
pub fn grad_factors_from_squared_distances<D: Dim, K: Kernel<D>>(
    kernel: &K,
    factors: &mut [f64],
    values: Option<&mut Vec<f64>>,
) {
    const BLOCK: usize = 4096;
    match values {
        Some(values) => {
            values.resize(factors.len(), 0.0);
            factors
                .par_chunks_mut(BLOCK)
                .zip(values.par_chunks_mut(BLOCK))
                .for_each(|(f, w)| {
                    for (s, w) in f.iter_mut().zip(w) {
                        let r = s.sqrt();
                        *s = kernel.grad_factor_at(r);
                        *w = kernel.w(r);
                    }
                });
        }
        None => factors.par_chunks_mut(BLOCK).for_each(|f| {
            for s in f {
                *s = kernel.grad_factor_at(s.sqrt());
            }
        }),
    }
}

/// Neighbour-list entries whose kernel-gradient factors [`SphContext::for_each_pair`]
/// evaluates at a time when no factors are attached.
pub const PAIR_BLOCK: usize = 64;

/// Particles per rayon work item.
pub(crate) const MIN_LEN: usize = 256;

/// Sets `out[i] = f(i)` for every particle, in parallel.
#[inline]
pub(crate) fn gather<T: Send>(out: &mut [T], f: impl Fn(usize) -> T + Sync + Send) {
    out.par_iter_mut()
        .enumerate()
        .with_min_len(MIN_LEN)
        .for_each(|(i, o)| *o = f(i));
}
