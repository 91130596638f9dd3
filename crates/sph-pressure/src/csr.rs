use crate::solver::{Border, CsrSystem};
use rayon::prelude::*;
pub(crate) use sph_neighbors::{for_each_row_mut, for_each_row_mut2};

/// A square sparse matrix in compressed sparse row form whose pattern is borrowed from a
/// neighbour list (row offsets and sorted column indices) and whose values it owns.
#[derive(Clone, Debug, Default)]
pub struct CsrMatrix {
    /// Values aligned with the pattern's column indices.
    pub values: Vec<f64>,
}

/// Rows per rayon work item in matrix loops.
pub(crate) const ROW_CHUNK: usize = 256;

impl CsrMatrix {
    /// Resizes the value array to the pattern's number of non-zeros (keeps the allocation).
    pub fn resize(&mut self, nnz: usize) {
        self.values.resize(nnz, 0.0);
    }

    /// `y = A x`, in parallel over rows.
    pub fn matvec(&self, offsets: &[usize], cols: &[u32], x: &[f64], y: &mut [f64]) {
        matvec(offsets, cols, &self.values, x, y);
    }
}

/// `y = A x` for a CSR matrix given as slices.
pub fn matvec(offsets: &[usize], cols: &[u32], values: &[f64], x: &[f64], y: &mut [f64]) {
    y.par_iter_mut()
        .enumerate()
        .with_min_len(ROW_CHUNK)
        .for_each(|(i, yi)| {
            let (a, b) = (offsets[i], offsets[i + 1]);
            *yi = row_dot(&values[a..b], &cols[a..b], x);
        });
}

/// True if every column index is below `bound`.
fn columns_below(cols: &[u32], bound: usize) -> bool {
    // A maximum over the whole slice (vectorised, no early exit, exact in any order), in
    // parallel blocks.
    let max = cols
        .par_chunks(1 << 14)
        .map(|c| c.iter().fold(0u32, |m, &c| m.max(c)))
        .reduce(|| 0, u32::max);
    cols.is_empty() || max < u32::try_from(bound).unwrap_or(u32::MAX)
}

/// `y = A x` for a pattern whose every column index was checked once to lie below `bound`, with
/// `x.len() ≥ bound` checked here: the products then read `x[c]` without a bounds check per
/// entry. Such a check costs the in-cache products of a pressure solve 12–16 % of their time
/// (a compare and a branch beside each load and multiply-add; checking each row's largest
/// column first costs as much), while the structure of a solve's matrices is fixed across its
/// dozens of products and can be checked once (a stream over the column indices, a third of a
/// product's bytes). A pattern that fails its check, or a short `x`, takes the checked path.
#[allow(unsafe_code)]
fn matvec_checked_once(
    offsets: &[usize],
    cols: &[u32],
    values: &[f64],
    in_range: bool,
    bound: usize,
    x: &[f64],
    y: &mut [f64],
) {
    if in_range && x.len() >= bound {
        y.par_iter_mut()
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, yi)| {
                let (a, b) = (offsets[i], offsets[i + 1]);
                // SAFETY: the row's columns are entries of `cols`, all of which lie below
                // `bound` (`in_range`: checked by `columns_below` while the caller has held
                // `cols` unchanged, see `Pattern` and `OwnedCsr`), and `bound ≤ x.len()`
                // (checked above).
                *yi = unsafe { row_dot_in_range(&values[a..b], &cols[a..b], x) };
            });
    } else {
        matvec(offsets, cols, values, x, y);
    }
}

/// A borrowed CSR pattern (row offsets, column indices) whose column indices have been
/// checked once against a bound, for many products with the same structure (a Krylov solve's
/// products with its matrix). The borrow keeps the indices unchanged while the check holds.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pattern<'a> {
    offsets: &'a [usize],
    cols: &'a [u32],
    bound: usize,
    in_range: bool,
}

impl<'a> Pattern<'a> {
    /// Checks `cols` against `bound` (the number of columns).
    pub(crate) fn new(offsets: &'a [usize], cols: &'a [u32], bound: usize) -> Self {
        Self {
            offsets,
            cols,
            bound,
            in_range: columns_below(cols, bound),
        }
    }

    /// `y = A x` with `values` aligned with the pattern's columns.
    pub(crate) fn matvec(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        matvec_checked_once(
            self.offsets,
            self.cols,
            values,
            self.in_range,
            self.bound,
            x,
            y,
        );
    }
}

/// The products of a solve with its system (a [`CsrSystem`], bordered or not): the body's
/// columns checked once (as [`Pattern`]), and a border added term for term as the
/// written-out matrix would sum it (see [`Border`]): the border column's term is its row's
/// last, the border row a dense row of `m + 1` entries — the same bits, without the copy.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Operator<'a> {
    pattern: Pattern<'a>,
    values: &'a [f64],
    border: Option<Border<'a>>,
}

impl<'a> Operator<'a> {
    /// The operator of `a` (its body's columns checked here).
    pub(crate) fn new(a: &CsrSystem<'a>) -> Self {
        Self {
            pattern: Pattern::new(a.offsets, a.cols, a.body_rows()),
            values: a.values,
            border: a.border,
        }
    }

    /// `y = A x`.
    #[allow(unsafe_code)]
    pub(crate) fn matvec(&self, x: &[f64], y: &mut [f64]) {
        let Some(b) = self.border else {
            return self.pattern.matvec(self.values, x, y);
        };
        let p = &self.pattern;
        let m = p.offsets.len() - 1;
        let (body, last) = y.split_at_mut(m);
        // The border column's term, `column · x_m`, as the written-out row multiplies it.
        let t = b.column * x[m];
        // The rows meeting the border column, the rest (the plain product), and the border row,
        // each a loop of its own, so each row loop is the plain product's or one like it (a
        // first version chose per row; profiles of the two did not separate them).
        let rows = b.rows.min(m);
        let (gauge, rest) = body.split_at_mut(rows);
        let (offsets, cols, values) = (p.offsets, p.cols, self.values);
        let row = |i: usize| {
            let (s, e) = (offsets[i], offsets[i + 1]);
            (&values[s..e], &cols[s..e])
        };
        let gauge_rows = || {
            let rows = gauge.par_iter_mut().enumerate().with_min_len(ROW_CHUNK);
            if p.in_range && x.len() >= p.bound {
                rows.for_each(|(i, yi)| {
                    let (v, c) = row(i);
                    // SAFETY: as in `matvec_checked_once`: every column is below `bound`
                    // ≤ `x.len()`.
                    *yi = unsafe { row_dot_in_range_then(v, c, x, t) };
                });
            } else {
                rows.for_each(|(i, yi)| {
                    let (v, c) = row(i);
                    *yi = row_dot_then(v, c, x, t);
                });
            }
        };
        let rest_rows =
            || matvec_checked_once(&offsets[rows..], cols, values, p.in_range, p.bound, x, rest);
        rayon::join(
            || rayon::join(gauge_rows, rest_rows),
            || last[0] = dense_row_dot(&b.row[..=m], &x[..=m]),
        );
    }
}

/// [`row_dot`] of a row followed by one more term `extra` (already multiplied), summed as
/// `row_dot` sums the row with that term appended: when the row's length is 3 mod 4 the term
/// completes the last group of four (lane 3), otherwise it follows the remainder in lane 0.
fn row_dot_then(values: &[f64], cols: &[u32], x: &[f64], extra: f64) -> f64 {
    let mut s = [0.0; 4];
    let (vq, vr) = values.split_at(values.len() / 4 * 4);
    let (cq, cr) = cols.split_at(vq.len());
    for (v, c) in vq.chunks_exact(4).zip(cq.chunks_exact(4)) {
        for l in 0..4 {
            s[l] += v[l] * x[c[l] as usize];
        }
    }
    if vr.len() == 3 {
        for l in 0..3 {
            s[l] += vr[l] * x[cr[l] as usize];
        }
        s[3] += extra;
    } else {
        for (v, &c) in vr.iter().zip(cr) {
            s[0] += v * x[c as usize];
        }
        s[0] += extra;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// [`row_dot_then`] without a bounds check on `x` (the same sums in the same order).
///
/// # Safety
/// Every entry of `cols` is below `x.len()`.
#[inline]
#[allow(unsafe_code)]
unsafe fn row_dot_in_range_then(values: &[f64], cols: &[u32], x: &[f64], extra: f64) -> f64 {
    let mut s = [0.0; 4];
    let (vq, vr) = values.split_at(values.len() / 4 * 4);
    let (cq, cr) = cols.split_at(vq.len());
    for (v, c) in vq.chunks_exact(4).zip(cq.chunks_exact(4)) {
        for l in 0..4 {
            // SAFETY: `c[l]` is an entry of `cols` (the caller's guarantee).
            s[l] += v[l] * unsafe { *x.get_unchecked(c[l] as usize) };
        }
    }
    if vr.len() == 3 {
        for l in 0..3 {
            // SAFETY: as above.
            s[l] += vr[l] * unsafe { *x.get_unchecked(cr[l] as usize) };
        }
        s[3] += extra;
    } else {
        for (v, &c) in vr.iter().zip(cr) {
            // SAFETY: as above.
            s[0] += v * unsafe { *x.get_unchecked(c as usize) };
        }
        s[0] += extra;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// [`row_dot`] of a dense row (`values[k]` the coefficient of `x[k]`), in the same order.
fn dense_row_dot(values: &[f64], x: &[f64]) -> f64 {
    let mut s = [0.0; 4];
    let (vq, vr) = values.split_at(values.len() / 4 * 4);
    let (xq, xr) = x[..values.len()].split_at(vq.len());
    for (v, x) in vq.chunks_exact(4).zip(xq.chunks_exact(4)) {
        for l in 0..4 {
            s[l] += v[l] * x[l];
        }
    }
    for (v, x) in vr.iter().zip(xr) {
        s[0] += v * x;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// An owned CSR matrix (possibly rectangular: `ncols` columns) whose products skip the bounds
/// check per entry once [`seal`](Self::seal) has checked its column indices; every mutable
/// access to its structure ([`parts_mut`](Self::parts_mut), [`clear`](Self::clear),
/// [`clear_rows`](Self::clear_rows)) undoes the seal. Values may change freely.
#[derive(Clone, Debug, Default)]
pub(crate) struct OwnedCsr {
    offsets: Vec<usize>,
    cols: Vec<u32>,
    values: Vec<f64>,
    ncols: usize,
    sealed: bool,
}

impl OwnedCsr {
    /// A matrix from its parts (not sealed).
    #[cfg(test)]
    pub(crate) fn from_parts(
        offsets: Vec<usize>,
        cols: Vec<u32>,
        values: Vec<f64>,
        ncols: usize,
    ) -> Self {
        Self {
            offsets,
            cols,
            values,
            ncols,
            sealed: false,
        }
    }
    pub(crate) fn nrows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    pub(crate) fn ncols(&self) -> usize {
        self.ncols
    }
    pub(crate) fn offsets(&self) -> &[usize] {
        &self.offsets
    }
    pub(crate) fn cols(&self) -> &[u32] {
        &self.cols
    }
    pub(crate) fn values(&self) -> &[f64] {
        &self.values
    }
    /// Offsets, columns and values for building the matrix; undoes the seal.
    pub(crate) fn parts_mut(&mut self) -> (&mut Vec<usize>, &mut Vec<u32>, &mut Vec<f64>) {
        self.sealed = false;
        (&mut self.offsets, &mut self.cols, &mut self.values)
    }
    /// No rows and no entries, `ncols` columns.
    pub(crate) fn clear(&mut self, ncols: usize) {
        self.clear_rows(ncols);
        self.cols.clear();
        self.values.clear();
    }
    /// No rows (`offsets = [0]`: a CSR's offsets start at 0), `ncols` columns; the entries keep
    /// their length for a caller that overwrites every one (resizing an emptied vector would
    /// zero it first).
    pub(crate) fn clear_rows(&mut self, ncols: usize) {
        self.sealed = false;
        self.offsets.clear();
        self.offsets.push(0);
        self.ncols = ncols;
    }
    /// Checks every column index against `ncols` (unless sealed already: the structure has not
    /// changed since); later products skip the check per entry while the structure stays as it
    /// is. Returns whether the check passed.
    pub(crate) fn seal(&mut self) -> bool {
        if !self.sealed {
            self.sealed = columns_below(&self.cols, self.ncols);
        }
        self.sealed
    }
    /// True while the last [`seal`](Self::seal)'s check holds.
    #[cfg(test)]
    pub(crate) fn is_sealed(&self) -> bool {
        self.sealed
    }
    /// `y = A x`.
    pub(crate) fn matvec(&self, x: &[f64], y: &mut [f64]) {
        matvec_checked_once(
            &self.offsets,
            &self.cols,
            &self.values,
            self.sealed,
            self.ncols,
            x,
            y,
        );
    }
}

/// `Σ_k v_k x[c_k]` of one row. Four independent partial sums: a single running sum is bound
/// by the latency of its additions (rows hold ~20–45 entries in 2D, ~250 in 3D); the summation
/// order is fixed, so the result does not depend on the thread count.
#[inline]
fn row_dot(values: &[f64], cols: &[u32], x: &[f64]) -> f64 {
    let mut s = [0.0; 4];
    let (vq, vr) = values.split_at(values.len() / 4 * 4);
    let (cq, cr) = cols.split_at(vq.len());
    for (v, c) in vq.chunks_exact(4).zip(cq.chunks_exact(4)) {
        for l in 0..4 {
            s[l] += v[l] * x[c[l] as usize];
        }
    }
    for (v, &c) in vr.iter().zip(cr) {
        s[0] += v * x[c as usize];
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// [`row_dot`] without a bounds check on `x` (the same sums in the same order). A copy of its
/// loop rather than one loop generic over the gather: with the gather passed as a closure the
/// solve ran 1.2× slower (two one-thread pairs on the 100² cavity), the closure's slice being
/// reloaded at each entry.
///
/// # Safety
/// Every entry of `cols` is below `x.len()`.
#[inline]
#[allow(unsafe_code)]
unsafe fn row_dot_in_range(values: &[f64], cols: &[u32], x: &[f64]) -> f64 {
    let mut s = [0.0; 4];
    let (vq, vr) = values.split_at(values.len() / 4 * 4);
    let (cq, cr) = cols.split_at(vq.len());
    for (v, c) in vq.chunks_exact(4).zip(cq.chunks_exact(4)) {
        for l in 0..4 {
            // SAFETY: `c[l]` is an entry of `cols` (the caller's guarantee).
            s[l] += v[l] * unsafe { *x.get_unchecked(c[l] as usize) };
        }
    }
    for (v, &c) in vr.iter().zip(cr) {
        // SAFETY: as above.
        s[0] += v * unsafe { *x.get_unchecked(c as usize) };
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `matvec` equals a plain left-to-right sum on rows of every length 0..=11 (so every
    /// remainder of the four-way split), to round-off. The solver tests build their right-hand
    /// sides with this same product, so they could not catch a product that drops terms.
    #[test]
    fn matvec_matches_a_plain_row_sum() {
        let n = 12;
        let mut offsets = vec![0];
        let mut cols = Vec::new();
        let mut values = Vec::new();
        for i in 0..n {
            for k in 0..i {
                cols.push(((i * 7 + k * 5) % n) as u32);
                values.push(1.0 + 0.1 * (i * n + k) as f64);
            }
            offsets.push(cols.len());
        }
        let x: Vec<f64> = (0..n).map(|j| 0.5 - 0.3 * j as f64).collect();
        let mut y = vec![f64::NAN; n];
        matvec(&offsets, &cols, &values, &x, &mut y);
        for i in 0..n {
            let plain: f64 = (offsets[i]..offsets[i + 1])
                .map(|k| values[k] * x[cols[k] as usize])
                .sum();
            assert!(
                (y[i] - plain).abs() <= 1e-13 * (1.0 + plain.abs()),
                "row {i} ({} entries): {} vs {plain}",
                offsets[i + 1] - offsets[i],
                y[i]
            );
        }
        assert_eq!(y[0], 0.0, "an empty row gives 0");
    }

    /// A product through a checked pattern or a sealed matrix equals the plain product
    /// bitwise (the same sums in the same order); mutable access to the structure undoes the
    /// seal; a column out of range fails the check, and the product then panics as indexing
    /// does instead of reading outside `x`.
    #[test]
    fn checked_products_equal_the_plain_one_and_refuse_out_of_range_columns() {
        let n = 9;
        let (mut offsets, mut cols, mut values) = (vec![0], Vec::new(), Vec::new());
        for i in 0..n {
            for k in 0..(i % 6) {
                cols.push(((i * 5 + k * 7) % n) as u32);
                values.push(0.3 - 0.07 * (i * n + k) as f64);
            }
            offsets.push(cols.len());
        }
        let x: Vec<f64> = (0..n).map(|j| 1.5 - 0.4 * j as f64).collect();
        let mut plain = vec![0.0; n];
        matvec(&offsets, &cols, &values, &x, &mut plain);

        let mut y = vec![f64::NAN; n];
        Pattern::new(&offsets, &cols, n).matvec(&values, &x, &mut y);
        assert_eq!(y, plain);

        let mut m = OwnedCsr::from_parts(offsets.clone(), cols.clone(), values.clone(), n);
        assert!(!m.is_sealed());
        assert!(m.seal());
        y.fill(f64::NAN);
        m.matvec(&x, &mut y);
        assert_eq!(y, plain);

        // A column out of range: the structure's change unseals, the check refuses it.
        m.parts_mut().1[4] = n as u32;
        assert!(!m.is_sealed());
        assert!(!m.seal());
        let owned = std::panic::catch_unwind(|| m.matvec(&x, &mut vec![0.0; n]));
        assert!(owned.is_err(), "an out-of-range column must panic");
        let mut bad = cols.clone();
        bad[4] = n as u32;
        let pattern = Pattern::new(&offsets, &bad, n);
        let borrowed = std::panic::catch_unwind(|| pattern.matvec(&values, &x, &mut vec![0.0; n]));
        assert!(borrowed.is_err(), "an out-of-range column must panic");
        // A vector shorter than the checked bound takes the checked path too.
        let short = std::panic::catch_unwind(|| {
            Pattern::new(&offsets, &cols, n).matvec(&values, &x[..n - 1], &mut vec![0.0; n])
        });
        assert!(short.is_err(), "a short x must panic");
    }

    /// A row followed by one more term sums, in both the checked and unchecked variant, to the
    /// bits `row_dot` gives the row with that term appended, for every row length 0..=12 (each
    /// remainder of the four-way split, the term completing a group or not); and a dense row to
    /// `row_dot` over the columns 0, 1, 2, ….
    /// The terms span sixteen orders of magnitude, so a term added in another lane or order
    /// changes the bits.
    #[test]
    #[allow(unsafe_code)]
    fn a_row_with_one_more_term_sums_as_the_appended_row() {
        let x: Vec<f64> = (0..16)
            .map(|j| 10f64.powi(j - 8) * (1.0 + 0.1 * j as f64))
            .collect();
        for len in 0..=12usize {
            let cols: Vec<u32> = (0..len).map(|k| ((k * 7 + 3) % 15) as u32).collect();
            let values: Vec<f64> = (0..len).map(|k| 1.0 / (1.0 + k as f64) - 0.3).collect();
            let (column, last) = (0.7, 15u32);
            let extra = column * x[last as usize];
            let mut vc = values.clone();
            vc.push(column);
            let mut cc = cols.clone();
            cc.push(last);
            let appended = row_dot(&vc, &cc, &x);
            assert_eq!(
                row_dot_then(&values, &cols, &x, extra).to_bits(),
                appended.to_bits(),
                "len {len}"
            );
            // SAFETY: every column is below 16 = x.len().
            let unchecked = unsafe { row_dot_in_range_then(&values, &cols, &x, extra) };
            assert_eq!(
                unchecked.to_bits(),
                appended.to_bits(),
                "len {len}, unchecked"
            );
            let iota: Vec<u32> = (0..len as u32).collect();
            assert_eq!(
                dense_row_dot(&values, &x).to_bits(),
                row_dot(&values, &iota, &x).to_bits(),
                "dense, len {len}"
            );
        }
    }
}
