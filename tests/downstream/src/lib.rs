//! A downstream crate with `sph-operators` as its only dependency: its test is the crate doc
//! example of `sph-operators`, compiled without access to `glam`, `sph-core`, `sph-kernels` or
//! `sph-neighbors` other than through the re-exports.
