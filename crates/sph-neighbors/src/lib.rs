//! # sph-neighbors
//!
//! Fixed-radius neighbour search producing compressed (CSR) neighbour lists.
//!
//! A [`NeighborList`] holds, for every query point, the indices of the indexed points within the
//! radius (`|x_q − x_j|² ≤ R²`), **sorted ascending and including the point itself** when the query
//! points are the indexed points. One list is built per time step and reused by every operator
//! pass and as the sparsity pattern of the pressure matrix.
//!
//! Two implementations of [`NeighborSearch`] produce identical lists:
//! * [`CellGrid`] (the default): particles counting-sorted into cells of edge `R`, each query scans
//!   `3^(D−1)` runs of three x-adjacent cells that are contiguous in memory. For clouds whose
//!   bounding box would need far more cells than particles it switches to a sorted list of the
//!   occupied cells (binary search), so memory stays `O(n)`.
//!   [`CellGrid::query_with_squared_distances`] also hands over each kept pair's squared
//!   distance, which the search measured anyway (the step's kernel factors are computed from it).
//! * [`KdTree`]: kiddo's immutable kd-tree, kept as a cross-check and for very irregular clouds.
//!
//! Both are parallel (rayon) and deterministic: the output does not depend on the thread count.
//! Start with [`NeighborSearch::build`] then [`NeighborSearch::query`]; or pick at run time with
//! [`SearchKind`] / [`AnySearch`].

mod any_search;
mod cell_grid;
mod error;
mod kd_tree;
mod neighbor_list;
mod search;

pub use any_search::{AnySearch, SearchKind};
pub use cell_grid::CellGrid;
pub use error::NeighborError;
pub use kd_tree::KdTree;
pub use neighbor_list::{NeighborList, for_each_row_mut, for_each_row_mut2};
pub use search::{NeighborSearch, brute_force};
#[cfg(test)]
mod tests;
