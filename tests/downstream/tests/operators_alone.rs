//! The `sph-operators` doc example, in a crate that depends on nothing else.

use sph_operators::core::{D2, D3, Dim, testing::lattice};
use sph_operators::glam::DVec2;
use sph_operators::kernels::{Kernel, QuinticSpline};
use sph_operators::neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, divergence};

#[test]
fn divergence_of_a_linear_field_through_the_reexports() {
    let dx = 0.05;
    let positions: Vec<DVec2> = lattice::<D2>(21, dx);
    let velocities: Vec<DVec2> = positions.iter().map(|x| DVec2::new(-x.x, x.y)).collect();
    let volumes = vec![dx * dx; positions.len()];
    let kernel = QuinticSpline::<D2>::new(1.3 * dx);
    let mut grid = CellGrid::<D2>::new();
    grid.build(&positions, kernel.support_radius()).unwrap();
    let mut neighbors = NeighborList::new();
    grid.query(&positions, &mut neighbors);
    let ctx = SphContext::new(&positions, &volumes, &neighbors, &kernel);
    let mut div = vec![0.0; positions.len()];
    divergence(&ctx, &velocities, None, &mut div);
    assert!(div[positions.len() / 2].abs() < 1e-10);
}

#[test]
fn the_same_in_3d() {
    let dx = 0.1;
    let positions = lattice::<D3>(9, dx);
    let g =
        sph_operators::glam::DMat3::from_diagonal(sph_operators::glam::DVec3::new(-1.0, 0.5, 0.5));
    let velocities: Vec<_> = positions.iter().map(|x| g * *x).collect();
    let volumes = vec![dx.powi(3); positions.len()];
    let kernel = QuinticSpline::<D3>::new(1.3 * dx);
    let mut grid = CellGrid::<D3>::new();
    grid.build(&positions, kernel.support_radius()).unwrap();
    let mut neighbors = NeighborList::new();
    grid.query(&positions, &mut neighbors);
    let ctx = SphContext::new(&positions, &volumes, &neighbors, &kernel);
    let mut div = vec![0.0; positions.len()];
    divergence(&ctx, &velocities, None, &mut div);
    let centre = positions.iter().position(|x| x.length() < 1e-12).unwrap();
    assert!(div[centre].abs() < 1e-10, "{}", div[centre]);
    assert_eq!(<D3 as Dim>::DIM, 3);
}
