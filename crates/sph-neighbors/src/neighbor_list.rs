/// Compressed sparse row neighbour lists: row `i` is `indices[offsets[i]..offsets[i + 1]]`,
/// sorted ascending.
///
/// The buffers (and per-chunk scratch) are kept between queries, so rebuilding a list of similar
/// size every step does not allocate.
#[derive(Clone, Debug, Default)]
pub struct NeighborList {
    pub(crate) offsets: Vec<usize>,
    pub(crate) indices: Vec<u32>,
    /// Per-chunk scratch reused across queries.
    pub(crate) chunks: Vec<Chunk>,
}

/// One parallel work item's rows while a query fills them, kept between queries.
#[derive(Clone, Debug, Default)]
pub(crate) struct Chunk {
    /// The rows' indices, back to back.
    pub(crate) indices: Vec<u32>,
    /// Their squared distances, for a query with distances (empty otherwise).
    pub(crate) distances: Vec<f64>,
    /// Scratch for sorting a row with its distances.
    pub(crate) pairs: Vec<(u32, f64)>,
}

impl NeighborList {
    /// An empty list.
    pub fn new() -> Self {
        Self {
            offsets: vec![0],
            ..Default::default()
        }
    }

    /// Builds a list from explicit rows (tests and small tools). Rows are sorted.
    pub fn from_rows(rows: &[Vec<u32>]) -> Self {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        let mut indices = Vec::new();
        offsets.push(0);
        for r in rows {
            let start = indices.len();
            indices.extend_from_slice(r);
            indices[start..].sort_unstable();
            offsets.push(indices.len());
        }
        Self {
            offsets,
            indices,
            chunks: Vec::new(),
        }
    }

    /// Puts `count` empty rows before the first, so row `i` becomes row `count + i`: lists
    /// queried for the tail `points[count..]` of a point set can then be read with the whole
    /// set's indices (the fluid rows empty, the wall rows filled, say).
    pub fn prepend_empty_rows(&mut self, count: usize) {
        self.offsets.splice(0..0, std::iter::repeat_n(0, count));
    }

    /// Number of rows (query points).
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True if there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Total number of stored pairs (the number of non-zeros of a matrix with this pattern).
    pub fn nnz(&self) -> usize {
        self.indices.len()
    }

    /// Neighbours of query point `i`, sorted ascending.
    #[inline(always)]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.indices[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Row offsets, `len() + 1` entries.
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// Column indices of all rows, concatenated.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Length of the longest row.
    pub fn max_row_len(&self) -> usize {
        self.offsets
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(0)
    }

    /// Mean row length.
    pub fn mean_row_len(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            self.nnz() as f64 / self.len() as f64
        }
    }

    /// True if both lists hold the same rows (scratch buffers are ignored).
    pub fn same_rows(&self, other: &NeighborList) -> bool {
        self.offsets == other.offsets && self.indices == other.indices
    }
}

/// Rows per rayon work item of [`for_each_row_mut`].
const ROW_CHUNK: usize = 256;

/// Calls `f(row, row_values)` for every row of a CSR pattern with row `offsets` (e.g.
/// [`NeighborList::offsets`]), in parallel, giving each call the mutable slice of `values`
/// that belongs to its own row: for arrays with one entry per neighbour-list entry (matrix
/// values, per-pair kernel factors). Recursive splitting; no allocation, deterministic.
pub fn for_each_row_mut<T: Send, F>(offsets: &[usize], values: &mut [T], f: &F)
where
    F: Fn(usize, &mut [T]) + Sync,
{
    // The two-array walk with a zero-sized second array (a `Vec<()>` does not allocate).
    let mut none = vec![(); values.len()];
    for_each_row_mut2(offsets, values, &mut none, &|i, row, _| f(i, row));
}

/// [`for_each_row_mut`] over two arrays of the same pattern: `f(row, a_row, b_row)`.
pub fn for_each_row_mut2<T: Send, U: Send, F>(offsets: &[usize], a: &mut [T], b: &mut [U], f: &F)
where
    F: Fn(usize, &mut [T], &mut [U]) + Sync,
{
    fn rec<T: Send, U: Send, F: Fn(usize, &mut [T], &mut [U]) + Sync>(
        rows: std::ops::Range<usize>,
        offsets: &[usize],
        a: &mut [T],
        b: &mut [U],
        f: &F,
    ) {
        if rows.len() <= ROW_CHUNK {
            let base = offsets[rows.start];
            for i in rows {
                let (s, e) = (offsets[i] - base, offsets[i + 1] - base);
                f(i, &mut a[s..e], &mut b[s..e]);
            }
            return;
        }
        let mid = rows.start + rows.len() / 2;
        let split = offsets[mid] - offsets[rows.start];
        let (alo, ahi) = a.split_at_mut(split);
        let (blo, bhi) = b.split_at_mut(split);
        rayon::join(
            || rec(rows.start..mid, offsets, alo, blo, f),
            || rec(mid..rows.end, offsets, ahi, bhi, f),
        );
    }
    let n = offsets.len() - 1;
    rec(0..n, offsets, a, b, f);
}
