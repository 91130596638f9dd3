//! Uniform cell grid with counting sort.
//!
//! Points are binned into cubic cells of edge `R` (the search radius) and stored in cell order
//! (x fastest), so the three x-adjacent cells of a row are one contiguous run of memory. A query
//! scans `3^(D−1)` such runs: 3 in 2D, 9 in 3D. 2D and 3D share this code; the only difference is
//! the number of cell axes, a compile-time constant.

use crate::search::{collect_images, fill, fill_rows, validate};
use crate::{NeighborError, NeighborList, NeighborSearch};
use rayon::prelude::*;
use sph_core::{Dim, Periodic, VectorOps};

/// Cells along each axis are addressed with `i64`; refuse spans above this many radii.
const MAX_SPAN: f64 = (1u64 << 50) as f64;

/// Uniform-grid neighbour search (see the module docs). The default search of dgsph.
#[derive(Clone, Debug, Default)]
pub struct CellGrid<D: Dim> {
    radius: f64,
    origin: [f64; 3],
    inv_cell: f64,
    /// Number of cells along each axis (unused axes 1).
    dims: [i64; 3],
    /// Point indices in cell order.
    sorted_idx: Vec<u32>,
    /// Point coordinates in cell order (a copy, so runs are read contiguously).
    sorted_pts: Vec<D::Vector>,
    cells: CellIndex,
    periodic: Option<Periodic<D>>,
}

/// Where each cell's points start in the sorted arrays.
#[derive(Clone, Debug, Default)]
enum CellIndex {
    #[default]
    Empty,
    /// One entry per cell of the bounding box (+1): `start[c]..start[c + 1]`.
    Dense { start: Vec<u32> },
    /// Occupied cells only, sorted by (z, y, x); `start[k]..start[k + 1]` for `keys[k]`.
    Sparse {
        keys: Vec<[i64; 3]>,
        start: Vec<u32>,
    },
}

impl<D: Dim> CellGrid<D> {
    /// An empty grid; call [`NeighborSearch::build`] before querying.
    pub fn new() -> Self {
        Self {
            radius: 0.0,
            origin: [0.0; 3],
            inv_cell: 0.0,
            dims: [1; 3],
            sorted_idx: Vec::new(),
            sorted_pts: Vec::new(),
            cells: CellIndex::Empty,
            periodic: None,
        }
    }

    /// Point indices in cell order (x fastest). Reordering particles by this permutation makes
    /// every later neighbour loop walk memory nearly in order.
    pub fn cell_order(&self) -> &[u32] {
        &self.sorted_idx
    }

    /// [`NeighborSearch::query`], also writing to `dist` the squared distance
    /// `|x_j − x_q|²` of every entry of `out` (aligned with [`NeighborList::indices`]): the
    /// number the search measured to keep the entry, so a pass that needs each pair's distance
    /// (the kernel's gradient factors) need not gather the positions again. Bitwise the
    /// square of `(x_q − x_j).length()`. Only without periodic axes, where an entry's distance
    /// is measured to the query point itself (with them, to one of its images, which may
    /// differ from the minimum image at round-off): then it returns `false`, leaving `dist`
    /// untouched after a plain query.
    pub fn query_with_squared_distances(
        &self,
        points: &[D::Vector],
        out: &mut NeighborList,
        dist: &mut Vec<f64>,
    ) -> bool {
        if self.periodic.is_some() {
            self.query(points, out);
            return false;
        }
        fill::<true, _, _>(points, out, dist, |q, buf, d| {
            self.collect::<true>(q, buf, d)
        });
        true
    }

    /// True if the grid uses the sparse (occupied cells only) index.
    pub fn is_sparse(&self) -> bool {
        matches!(self.cells, CellIndex::Sparse { .. })
    }

    #[inline(always)]
    fn cell_of(&self, p: &D::Vector) -> [i64; 3] {
        let mut c = [0i64; 3];
        for (k, ck) in c.iter_mut().enumerate().take(D::DIM) {
            // Saturating float-to-int conversion: far-away query points land outside the grid.
            *ck = floor_i64((p.get(k) - self.origin[k]) * self.inv_cell);
        }
        c
    }

    #[inline(always)]
    fn dense_id(&self, c: [i64; 3]) -> usize {
        (c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])) as usize
    }

    /// Range in the sorted arrays of the cells `(x_lo..=x_hi, y, z)`.
    #[inline(always)]
    fn run(&self, x_lo: i64, x_hi: i64, y: i64, z: i64) -> std::ops::Range<usize> {
        match &self.cells {
            CellIndex::Empty => 0..0,
            CellIndex::Dense { start } => {
                let lo = self.dense_id([x_lo, y, z]);
                let hi = self.dense_id([x_hi, y, z]) + 1;
                start[lo] as usize..start[hi] as usize
            }
            CellIndex::Sparse { keys, start } => {
                let a = keys.partition_point(|k| cmp_zyx(k, &[x_lo, y, z]).is_lt());
                let b = a + keys[a..].partition_point(|k| cmp_zyx(k, &[x_hi, y, z]).is_le());
                start[a] as usize..start[b] as usize
            }
        }
    }

    /// Appends the points within the radius of `q` to `buf` and, if `DIST`, their squared
    /// distances `|x_j − q|²` to `dist` (the same entries; untouched otherwise).
    #[inline(always)]
    fn collect<const DIST: bool>(&self, q: &D::Vector, buf: &mut Vec<u32>, dist: &mut Vec<f64>) {
        let r2 = self.radius * self.radius;
        let c = self.cell_of(q);
        let x_lo = (c[0].saturating_sub(1)).max(0);
        let x_hi = (c[0].saturating_add(1)).min(self.dims[0] - 1);
        if x_lo > x_hi {
            return;
        }
        let span = |k: usize| -> (i64, i64) {
            if k < D::DIM {
                (
                    c[k].saturating_sub(1).max(0),
                    c[k].saturating_add(1).min(self.dims[k] - 1),
                )
            } else {
                (0, 0)
            }
        };
        let (y_lo, y_hi) = span(1);
        let (z_lo, z_hi) = span(2);
        for z in z_lo..=z_hi {
            for y in y_lo..=y_hi {
                let run = self.run(x_lo, x_hi, y, z);
                let pts = &self.sorted_pts[run.clone()];
                let ids = &self.sorted_idx[run];
                // Branch-free compaction: every candidate is written at the end of the list
                // and kept by advancing the end only if it lies within the radius (π/9 ≈ 35 %
                // of the scanned cells' area in 2D, 4π/81 ≈ 16 % in 3D, in no predictable
                // pattern, so a branch per candidate mispredicts often). The same rows as a
                // `push` under an `if`. Written into the lists' spare capacity: zero-filling
                // it first (a `resize`) cost a tenth of the neighbour phase.
                let n = ids.len();
                buf.reserve(n);
                let base = buf.len();
                let mut w = 0;
                let dbase = dist.len();
                if DIST {
                    dist.reserve(n);
                }
                {
                    let bs = &mut buf.spare_capacity_mut()[..n];
                    let ds = if DIST {
                        &mut dist.spare_capacity_mut()[..n]
                    } else {
                        &mut []
                    };
                    for (x, &j) in pts.iter().zip(ids) {
                        let d2 = (*x - *q).length_squared();
                        // w ≤ the candidates seen before this one < n: in bounds.
                        bs[w].write(j);
                        if DIST {
                            ds[w].write(d2);
                        }
                        w += usize::from(d2 <= r2);
                    }
                }
                // SAFETY: every place below `w` of the spare capacities was written — the
                // place `p` by the candidate that advanced `w` past `p` — and `w ≤ n` places
                // were reserved; `dist` (only with DIST) is counted from its own length.
                #[allow(unsafe_code)]
                unsafe {
                    buf.set_len(base + w);
                    if DIST {
                        dist.set_len(dbase + w);
                    }
                }
            }
        }
    }
}

/// `x.floor() as i64`, the same value for every `x` (NaN → 0, saturating beyond the range of
/// `i64`), without the call to libm's `floor` that `f64::floor` compiles to on x86-64 without
/// SSE4.1: a call per axis for every point binned and every query, 0.5 % of a one-thread
/// cavity step.
#[inline(always)]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[inline(always)]
fn cmp_zyx(a: &[i64; 3], b: &[i64; 3]) -> std::cmp::Ordering {
    (a[2], a[1], a[0]).cmp(&(b[2], b[1], b[0]))
}

impl<D: Dim> NeighborSearch<D> for CellGrid<D> {
    fn build(&mut self, points: &[D::Vector], radius: f64) -> Result<(), NeighborError> {
        validate::<D>(points, radius, self.periodic.as_ref())?;
        let n = points.len();
        self.radius = radius;
        self.inv_cell = 1.0 / radius;
        self.sorted_idx.clear();
        self.sorted_pts.clear();
        if n == 0 {
            self.cells = CellIndex::Empty;
            self.dims = [1; 3];
            return Ok(());
        }
        let (lo, hi) = points
            .par_iter()
            .fold(
                || (points[0], points[0]),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            )
            .reduce(
                || (points[0], points[0]),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        self.origin = lo.to_array3();
        self.dims = [1; 3];
        let mut total_cells: f64 = 1.0;
        for k in 0..D::DIM {
            let span = (hi.get(k) - lo.get(k)) * self.inv_cell;
            if span.is_nan() || span >= MAX_SPAN {
                return Err(NeighborError::DomainTooWide {
                    span_over_radius: span,
                });
            }
            self.dims[k] = span.floor() as i64 + 1;
            total_cells *= self.dims[k] as f64;
        }

        // Cell id of every point (dense linear id, or the (x, y, z) key for the sparse index).
        let keys: Vec<[i64; 3]> = points.par_iter().map(|p| self.cell_of(p)).collect();
        let dense = total_cells <= (4 * n + 1024) as f64;
        if dense {
            // Counting sort by linear cell id; stable, so each cell lists its points in index order.
            let ncell = total_cells as usize;
            let mut start = vec![0u32; ncell + 1];
            for k in &keys {
                start[self.dense_id(*k) + 1] += 1;
            }
            for c in 0..ncell {
                start[c + 1] += start[c];
            }
            let mut fill = start.clone();
            self.sorted_idx.resize(n, 0);
            for (i, k) in keys.iter().enumerate() {
                let c = self.dense_id(*k);
                self.sorted_idx[fill[c] as usize] = i as u32;
                fill[c] += 1;
            }
            self.cells = CellIndex::Dense { start };
        } else {
            self.sorted_idx.extend(0..n as u32);
            self.sorted_idx.par_sort_by(|&a, &b| {
                cmp_zyx(&keys[a as usize], &keys[b as usize]).then(a.cmp(&b))
            });
            let mut ukeys = Vec::new();
            let mut start = Vec::new();
            for (s, &i) in self.sorted_idx.iter().enumerate() {
                let k = keys[i as usize];
                if ukeys.last() != Some(&k) {
                    ukeys.push(k);
                    start.push(s as u32);
                }
            }
            start.push(n as u32);
            self.cells = CellIndex::Sparse { keys: ukeys, start };
        }
        self.sorted_pts
            .extend(self.sorted_idx.iter().map(|&i| points[i as usize]));
        Ok(())
    }

    fn query(&self, points: &[D::Vector], out: &mut NeighborList) {
        let p = self.periodic.as_ref();
        fill_rows(points, out, |q, buf| {
            collect_images(p, self.radius, q, buf, |q, buf| {
                self.collect::<false>(q, buf, &mut Vec::new())
            })
        });
    }

    fn radius(&self) -> f64 {
        self.radius
    }

    fn set_periodic(&mut self, periodic: Option<Periodic<D>>) {
        self.periodic = periodic;
    }
}

#[cfg(test)]
mod tests {
    use super::floor_i64;

    /// `floor_i64` is `floor() as i64` on integers, halves, values next to integers (either
    /// sign), the extremes of `i64` and beyond, infinities and NaN.
    #[test]
    fn floor_i64_is_floor_as_i64() {
        let mut xs = vec![
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
        ];
        for k in [
            0.0,
            1.0,
            2.0,
            7.0,
            1e6,
            2f64.powi(52),
            2f64.powi(53),
            2f64.powi(63),
            1e300,
        ] {
            for x in [k, k + 0.5, k.next_up(), k.next_down(), k + 1e-9] {
                xs.extend([x, -x]);
            }
        }
        xs.extend([f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 5e-324, -5e-324]);
        for x in xs {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x:e}");
        }
    }
}
