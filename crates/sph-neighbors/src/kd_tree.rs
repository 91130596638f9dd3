//! kiddo kd-tree backend.
//!
//! kiddo's dimension is a const generic that stable Rust cannot take from `D::DIM`, so the tree
//! is stored as a two-variant enum and the variant is picked by `D::DIM` (a compile-time
//! constant); the rest of dgsph stays free of a kiddo-specific bound.

use crate::search::{collect_images, fill_rows, validate};
use crate::{NeighborError, NeighborList, NeighborSearch};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use sph_core::{Dim, Periodic, VectorOps};
use std::marker::PhantomData;

enum Tree {
    Empty,
    D2(ImmutableKdTree<f64, 2>),
    D3(ImmutableKdTree<f64, 3>),
}

/// kd-tree neighbour search (kiddo `ImmutableKdTree`), producing the same lists as
/// [`CellGrid`](crate::CellGrid).
pub struct KdTree<D: Dim> {
    radius: f64,
    tree: Tree,
    periodic: Option<Periodic<D>>,
    _dim: PhantomData<D>,
}

impl<D: Dim> Default for KdTree<D> {
    fn default() -> Self {
        Self::new()
    }
}

impl<D: Dim> std::fmt::Debug for KdTree<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KdTree")
            .field("radius", &self.radius)
            .finish_non_exhaustive()
    }
}

impl<D: Dim> KdTree<D> {
    /// An empty tree; call [`NeighborSearch::build`] before querying.
    pub fn new() -> Self {
        Self {
            radius: 0.0,
            tree: Tree::Empty,
            periodic: None,
            _dim: PhantomData,
        }
    }
}

fn arr<const K: usize, V: VectorOps>(p: &V) -> [f64; K] {
    std::array::from_fn(|k| p.get(k))
}

impl<D: Dim> NeighborSearch<D> for KdTree<D> {
    fn build(&mut self, points: &[D::Vector], radius: f64) -> Result<(), NeighborError> {
        validate::<D>(points, radius, self.periodic.as_ref())?;
        self.radius = radius;
        let err = |e: kiddo::kd_tree::ConstructionError| NeighborError::KdTree(e.to_string());
        self.tree = if points.is_empty() {
            Tree::Empty
        } else if D::DIM == 2 {
            let pts: Vec<[f64; 2]> = points.iter().map(arr::<2, _>).collect();
            Tree::D2(ImmutableKdTree::new_from_slice_parallel(&pts).map_err(err)?)
        } else {
            let pts: Vec<[f64; 3]> = points.iter().map(arr::<3, _>).collect();
            Tree::D3(ImmutableKdTree::new_from_slice_parallel(&pts).map_err(err)?)
        };
        Ok(())
    }

    fn query(&self, points: &[D::Vector], out: &mut NeighborList) {
        let r2 = self.radius * self.radius;
        let one = |q: &D::Vector, buf: &mut Vec<u32>| match &self.tree {
            Tree::Empty => {}
            Tree::D2(t) => t
                .query(&arr::<2, _>(q))
                .within::<SquaredEuclidean<f64>>(r2)
                .unsorted()
                .visit(|it| buf.push(it.item)),
            Tree::D3(t) => t
                .query(&arr::<3, _>(q))
                .within::<SquaredEuclidean<f64>>(r2)
                .unsorted()
                .visit(|it| buf.push(it.item)),
        };
        let p = self.periodic.as_ref();
        fill_rows(points, out, |q, buf| {
            collect_images(p, self.radius, q, buf, one)
        });
    }

    fn radius(&self) -> f64 {
        self.radius
    }

    fn set_periodic(&mut self, periodic: Option<Periodic<D>>) {
        self.periodic = periodic;
    }
}
