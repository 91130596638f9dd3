//! # sph-cases
//!
//! Validation cases of dgsph and the pass/fail [`Check`]s that compare them with reference or
//! exact data. Scene data lives in TOML files under the repository's top-level `cases/`
//! directory; case code generates geometry and declares checks. The library does no I/O: the
//! `xtask` binary reads scenes, runs cases and writes reports.
//!
//! Start with [`foundation::checks`], the cheap checks of the kernel and operator layers that
//! every validation run starts with.

mod check;
pub mod foundation;

pub use check::Check;
