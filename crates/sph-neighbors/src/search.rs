use crate::neighbor_list::Chunk;
use crate::{NeighborError, NeighborList};
use rayon::prelude::*;
use sph_core::{Dim, Periodic, VectorOps};

/// A fixed-radius neighbour search over an indexed point set.
pub trait NeighborSearch<D: Dim>: Send + Sync {
    /// Indexes `points` for queries of radius `radius`. The points are copied; later changes to
    /// the caller's slice need a new `build`.
    fn build(&mut self, points: &[D::Vector], radius: f64) -> Result<(), NeighborError>;

    /// For every query point, the indexed points `j` with `|x_q − x_j|² ≤ radius²`, sorted
    /// ascending, written to `out` (previous contents are replaced, buffers reused).
    ///
    /// Querying with the indexed points themselves gives the self-join (each row holds its own
    /// index). Query points may lie anywhere, e.g. probe points for density sampling.
    fn query(&self, points: &[D::Vector], out: &mut NeighborList);

    /// The radius given to the last `build`.
    fn radius(&self) -> f64;

    /// Makes the search periodic along the axes of `periodic` (or not, with `None`): the next
    /// `build` requires the points inside the periodic box and a radius below half of every
    /// period, and queries then find neighbours across the periodic faces (by the images of the
    /// query point, see [`Periodic::for_each_image`]). Row indices are those of the indexed
    /// points; the caller takes pair vectors as minimum images.
    fn set_periodic(&mut self, periodic: Option<Periodic<D>>);
}

pub(crate) fn validate<D: Dim>(
    points: &[D::Vector],
    radius: f64,
    periodic: Option<&Periodic<D>>,
) -> Result<(), NeighborError> {
    if !(radius.is_finite() && radius > 0.0) {
        return Err(NeighborError::InvalidRadius(radius));
    }
    if let Some(p) = periodic {
        p.check_radius(radius)
            .map_err(|e| NeighborError::Periodic(e.to_string()))?;
        let outside = points.iter().position(|x| {
            (0..D::DIM).any(|k| {
                let (l, lo) = (p.period().get(k), p.lo().get(k));
                l > 0.0 && !(x.get(k) >= lo && x.get(k) < lo + l)
            })
        });
        if let Some(index) = outside {
            return Err(NeighborError::Periodic(format!(
                "point {index} lies outside the periodic box along a periodic axis"
            )));
        }
    }
    if points.len() >= u32::MAX as usize {
        return Err(NeighborError::TooManyPoints(points.len()));
    }
    if let Some(index) = points.iter().position(|p| !p.is_finite()) {
        return Err(NeighborError::NonFinitePoint { index });
    }
    Ok(())
}

/// Query points per parallel work item. Fixed, so the work split (and hence the output) never
/// depends on the number of threads.
pub(crate) const CHUNK: usize = 256;

/// Fills `out` by calling `collect(q, buf)` for every query point, in parallel chunks of
/// [`CHUNK`] points. `collect` appends the neighbours of point `q` to `buf`; rows are then sorted
/// and concatenated in query order.
pub(crate) fn fill_rows<V, F>(queries: &[V], out: &mut NeighborList, collect: F)
where
    V: Sync,
    F: Fn(&V, &mut Vec<u32>) + Sync,
{
    fill::<false, V, _>(queries, out, &mut Vec::new(), |q, buf, _| collect(q, buf));
}

/// Chunks filled in parallel before their rows are copied into the list: the chunks' scratch
/// then holds at most this many chunks' rows (with `CHUNK` = 256 queries and ~22 entries per
/// row, 4.5 MB in 2D with distances) however many particles there are, instead of a second
/// copy of the whole list (12 bytes per entry with distances, ≈ 0.27 KiB per particle). The
/// chunks, and so the list, do not depend on it; at least four chunks per thread keep every
/// thread busy within a batch.
const BATCH_CHUNKS: usize = 64;

/// [`fill_rows`]' work; with `DIST`, `collect(q, buf, dist)` also appends each neighbour's
/// squared distance to `dist`, and the distances are permuted with their rows' sort and
/// concatenated into `dist`, aligned with `out.indices` (untouched without `DIST`).
///
/// The queries are taken in batches of chunks: each batch's chunks are filled in parallel,
/// then appended to the list in order.
pub(crate) fn fill<const DIST: bool, V, F>(
    queries: &[V],
    out: &mut NeighborList,
    dist: &mut Vec<f64>,
    collect: F,
) where
    V: Sync,
    F: Fn(&V, &mut Vec<u32>, &mut Vec<f64>) + Sync,
{
    let batch = BATCH_CHUNKS.max(4 * rayon::current_num_threads()) * CHUNK;
    fill_in_batches::<DIST, V, F>(queries, out, dist, batch, collect);
}

/// [`fill`] with `batch` queries (a multiple of [`CHUNK`]) per batch.
fn fill_in_batches<const DIST: bool, V, F>(
    queries: &[V],
    out: &mut NeighborList,
    dist: &mut Vec<f64>,
    batch: usize,
    collect: F,
) where
    V: Sync,
    F: Fn(&V, &mut Vec<u32>, &mut Vec<f64>) + Sync,
{
    debug_assert!(batch > 0 && batch.is_multiple_of(CHUNK));
    let nq = queries.len();
    out.chunks
        .resize_with(nq.min(batch).div_ceil(CHUNK), Default::default);
    out.offsets.clear();
    out.offsets.resize(nq + 1, 0);
    for (b, qs) in queries.chunks(batch).enumerate() {
        let first = b * batch;
        let nchunks = qs.len().div_ceil(CHUNK);
        out.chunks[..nchunks]
            .par_iter_mut()
            .zip(out.offsets[first + 1..first + 1 + qs.len()].par_chunks_mut(CHUNK))
            .zip(qs.par_chunks(CHUNK))
            .for_each(|((chunk, counts), qs)| {
                let Chunk {
                    indices: buf,
                    distances: dbuf,
                    pairs,
                } = chunk;
                buf.clear();
                dbuf.clear();
                for (q, count) in qs.iter().zip(counts.iter_mut()) {
                    let start = buf.len();
                    collect(q, buf, dbuf);
                    // Rows of particles numbered in cell order come out (nearly) sorted.
                    if !buf[start..].is_sorted() {
                        if DIST {
                            sort_pairs(&mut buf[start..], &mut dbuf[start..], pairs);
                        } else {
                            buf[start..].sort_unstable();
                        }
                    }
                    *count = buf.len() - start;
                }
            });
        for i in first + 1..=first + qs.len() {
            out.offsets[i] += out.offsets[i - 1];
        }
        let (start, end) = (out.offsets[first], out.offsets[first + qs.len()]);
        // Every entry is overwritten: the list keeps its length from the last query and only
        // zero-fills where it grows past it.
        if out.indices.len() < end {
            out.indices.resize(end, 0);
        }
        concat(&out.chunks[..nchunks], &mut out.indices[start..end], |c| {
            &c.indices
        });
        if DIST {
            if dist.len() < end {
                dist.resize(end, 0.0);
            }
            concat(&out.chunks[..nchunks], &mut dist[start..end], |c| {
                &c.distances
            });
        }
    }
    out.indices.truncate(out.offsets[nq]);
    if DIST {
        dist.truncate(out.offsets[nq]);
    }
}

/// Sorts `keys` ascending and applies the same permutation to `values`. The rows of particles
/// numbered in cell order are nearly sorted (a particle that crossed into another cell since the
/// last renumbering sits a few places from its slot), which insertion sort puts in order in
/// about linear time: 1.6 % of a one-thread step of the 100² cavity (perf) against 2.8 % for
/// the library's sort of (key, value) pairs. Past a budget of moves (a badly numbered row: a scene without renumbering) the row
/// is finished through `scratch` by pattern-defeating quicksort, `O(n log n)` on any row. The
/// keys of a row are distinct, so either way the order is the same.
fn sort_pairs(keys: &mut [u32], values: &mut [f64], scratch: &mut Vec<(u32, f64)>) {
    let budget = 8 * keys.len();
    let mut moved = 0;
    for i in 1..keys.len() {
        let (k, v) = (keys[i], values[i]);
        let mut j = i;
        while j > 0 && keys[j - 1] > k {
            keys[j] = keys[j - 1];
            values[j] = values[j - 1];
            j -= 1;
        }
        keys[j] = k;
        values[j] = v;
        moved += i - j;
        if moved > budget {
            scratch.clear();
            scratch.extend(keys.iter().copied().zip(values.iter().copied()));
            scratch.sort_unstable_by_key(|p| p.0);
            for ((k, v), p) in keys.iter_mut().zip(values.iter_mut()).zip(scratch.iter()) {
                (*k, *v) = *p;
            }
            return;
        }
    }
}

/// Copies the chunk buffers `part(chunk)` back to back into `dst`, splitting the work
/// recursively.
fn concat<T, C, P>(chunks: &[C], dst: &mut [T], part: P)
where
    T: Copy + Send + Sync,
    C: Sync,
    P: Fn(&C) -> &Vec<T> + Sync + Copy,
{
    if chunks.len() <= 16 {
        let mut at = 0;
        for c in chunks {
            let c = part(c);
            dst[at..at + c.len()].copy_from_slice(c);
            at += c.len();
        }
        return;
    }
    let mid = chunks.len() / 2;
    let left: usize = chunks[..mid].iter().map(|c| part(c).len()).sum();
    let (dl, dr) = dst.split_at_mut(left);
    rayon::join(
        || concat(&chunks[..mid], dl, part),
        || concat(&chunks[mid..], dr, part),
    );
}

/// O(n·m) reference search: the oracle the fast searches are tested against. With `periodic`,
/// distances are minimum images.
pub fn brute_force<D: Dim>(
    indexed: &[D::Vector],
    queries: &[D::Vector],
    radius: f64,
    periodic: Option<&Periodic<D>>,
    out: &mut NeighborList,
) {
    let r2 = radius * radius;
    fill_rows(queries, out, |q, buf| {
        for (j, x) in indexed.iter().enumerate() {
            let d = *x - *q;
            let d = periodic.map_or(d, |p| p.minimum_image(d));
            if d.length_squared() <= r2 {
                buf.push(j as u32);
            }
        }
    });
}

/// `collect(q', buf)` for the query point itself and, with `periodic`, each of its images
/// within `radius` of a periodic face.
#[inline(always)]
pub(crate) fn collect_images<D: Dim>(
    periodic: Option<&Periodic<D>>,
    radius: f64,
    q: &D::Vector,
    buf: &mut Vec<u32>,
    collect: impl Fn(&D::Vector, &mut Vec<u32>),
) {
    match periodic {
        None => collect(q, buf),
        Some(p) => p.for_each_image(*q, radius, |qi| collect(&qi, buf)),
    }
}

#[cfg(test)]
mod sort_tests {
    use super::{CHUNK, NeighborList, fill_in_batches, sort_pairs};
    use sph_core::testing::SplitMix64;

    /// The list (offsets, rows, their distances) does not depend on how many chunks a batch
    /// holds: one chunk, three, or all queries at once, each into a fresh list and into one
    /// kept from a longer and from a shorter query. The rows are exactly the collected ones
    /// (each query's own pseudo-random, unsorted indices of varying count), sorted with their
    /// distances.
    #[test]
    fn batches_build_the_same_list_as_one_pass() {
        let rows = |q: usize| -> Vec<(u32, f64)> {
            let mut rng = SplitMix64::new(q as u64 + 1);
            let len = (rng.next_u64() % 30) as usize;
            let mut row: Vec<u32> = (0..len).map(|k| (q * 7 + 13 * k) as u32 % 5000).collect();
            row.sort_unstable();
            row.dedup();
            for k in (1..row.len()).rev() {
                row.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            row.into_iter()
                .map(|j| (j, f64::from(j) * 0.25 + q as f64))
                .collect()
        };
        let build = |nq: usize, batch: usize, out: &mut NeighborList, dist: &mut Vec<f64>| {
            let queries: Vec<usize> = (0..nq).collect();
            fill_in_batches::<true, _, _>(&queries, out, dist, batch, |&q, buf, dbuf| {
                for (j, d) in rows(q) {
                    buf.push(j);
                    dbuf.push(d);
                }
            });
        };
        let nq = 5 * CHUNK + 17;
        let (mut one, mut one_d) = (NeighborList::new(), Vec::new());
        build(nq, nq.next_multiple_of(CHUNK), &mut one, &mut one_d);
        assert_eq!(one.len(), nq);
        for q in 0..nq {
            let mut want = rows(q);
            want.sort_unstable_by_key(|p| p.0);
            let (a, b) = (one.offsets[q], one.offsets[q + 1]);
            let got: Vec<(u32, f64)> = one.indices[a..b]
                .iter()
                .copied()
                .zip(one_d[a..b].iter().copied())
                .collect();
            assert_eq!(got, want, "row {q}");
        }
        for batch in [CHUNK, 3 * CHUNK] {
            for warm in [0, nq + 3 * CHUNK, nq / 2] {
                let (mut out, mut dist) = (NeighborList::new(), Vec::new());
                if warm > 0 {
                    build(warm, batch, &mut out, &mut dist);
                }
                build(nq, batch, &mut out, &mut dist);
                assert_eq!(out.offsets, one.offsets, "batch {batch}, warm {warm}");
                assert_eq!(out.indices, one.indices, "batch {batch}, warm {warm}");
                assert_eq!(dist, one_d, "batch {batch}, warm {warm}");
            }
        }
    }

    /// `sort_pairs` sorts every row with its values, by insertion (nearly sorted rows: a few
    /// entries displaced) and past the move budget (reversed and shuffled rows), on rows of
    /// every length up to 300.
    #[test]
    fn sort_pairs_sorts_any_row_with_its_values() {
        let mut rng = SplitMix64::new(5);
        let mut scratch = Vec::new();
        for len in (0..40).chain([100, 300]) {
            let sorted: Vec<u32> = (0..len as u32).map(|k| 3 * k + 1).collect();
            let mut nearly = sorted.clone();
            for _ in 0..len / 8 {
                let a = (rng.next_u64() % len as u64) as usize;
                let b = (a + 1 + (rng.next_u64() % 3) as usize).min(len - 1);
                nearly.swap(a, b);
            }
            let reversed: Vec<u32> = sorted.iter().rev().copied().collect();
            let mut shuffled = sorted.clone();
            for k in (1..len).rev() {
                shuffled.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            for mut keys in [nearly, reversed, shuffled] {
                let mut values: Vec<f64> = keys.iter().map(|&k| f64::from(k) * 0.5 - 7.0).collect();
                sort_pairs(&mut keys, &mut values, &mut scratch);
                assert_eq!(keys, sorted, "length {len}");
                for (k, v) in keys.iter().zip(&values) {
                    assert_eq!(
                        *v,
                        f64::from(*k) * 0.5 - 7.0,
                        "length {len}: value left behind"
                    );
                }
            }
        }
    }
}
