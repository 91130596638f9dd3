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

/// `Σ_k v_k x[c_k]` of one row. Four independent partial sums: a single running sum is bound
/// by the latency of its additions (rows hold ~45 entries in 2D, ~250 in 3D); the summation
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
}
