//! # sph-core
//!
//! The bottom layer of dgsph: the dimension abstraction every physics routine is generic over,
//! and plain structure-of-arrays particle storage.
//!
//! * [`Dim`] with the zero-sized markers [`D2`] and [`D3`] maps a dimension to glam's
//!   `DVec2`/`DMat2` or `DVec3`/`DMat3`. Physics is written once as `fn f<D: Dim>(..)`; the
//!   dimension is chosen at the edge of the program (a scene file's `dim = 2`).
//! * [`VectorOps`] and [`MatrixOps`] are the small common interface glam lacks (component access,
//!   outer products, cofactor matrices, invariants).
//! * [`ParticleSet`] is the structure-of-arrays storage (`positions`, `velocities`, ...).
//! * [`Periodic`] describes periodic axes of a box: minimum-image pair vectors and wrapping.
//! * [`testing`] holds a seeded RNG and lattice generators shared by the tests and benches of the
//!   crates above; it has no dependencies and does no I/O.
//!
//! Non-goals: no neighbour search, kernels or I/O here. Start with [`Dim`].

mod dim;
mod error;
mod particles;
mod periodic;
pub mod testing;

pub use dim::{D2, D3, Dim, MatrixOps, VectorOps};
pub use error::CoreError;
/// The linear-algebra crate behind [`D2`] and [`D3`].
pub use glam;
pub use particles::ParticleSet;
pub use periodic::{Periodic, PeriodicError};

/// Runs a dimension-generic test body for both [`D2`] and [`D3`].
///
/// `dim_tests! { fn name<D>() { body } }` expands to a module `name` holding the tests `d2` and
/// `d3`, so every dimension-generic test is reported once per dimension.
#[macro_export]
macro_rules! dim_tests {
    ($( $(#[$meta:meta])* fn $name:ident<$d:ident>() $body:block )*) => {
        $(
            #[allow(non_snake_case)]
            mod $name {
                #[allow(unused_imports)]
                use super::*;
                fn run<$d: $crate::Dim>() $body
                $(#[$meta])*
                #[test]
                fn d2() { run::<$crate::D2>() }
                $(#[$meta])*
                #[test]
                fn d3() { run::<$crate::D3>() }
            }
        )*
    };
}
