//! # sph-cases
//!
//! Validation cases of dgsph and the pass/fail [`Check`]s that compare them with exact or
//! published data. Scenes are TOML files under the repository's top-level `cases/` directory
//! ([`Scene`]); case code generates geometry and declares checks. Reference data is embedded at
//! compile time from `cases/reference/` ([`reference`]). The library does no I/O: the `xtask`
//! binary reads scenes, runs cases and writes reports, receiving records through callbacks.
//!
//! | case | module | effects | reference |
//! |---|---|---|---|
//! | kernels, operators | [`foundation`] | — | exact |
//! | `prescribed_ellipse` / `prescribed_ellipsoid` | [`prescribed`] | none (prescribed u) | exact slopes |
//! | `elliptical_drop` / `spheroid_drop` | [`drop`] | free surface | exact drop solution |
//!
//! Start with [`Scene::parse`] and [`drop::run`].

pub mod cavity;
mod check;
pub mod drop;
mod error;
pub mod foundation;
pub mod geometry;
pub mod measure;
pub mod prescribed;
pub mod reference;
mod scene;

pub use check::Check;
pub use error::CaseError;
pub use scene::{
    CaseKind, CavitySpec, DgHessianChoice, EffectsSpec, QuickOverrides, Scene, ShiftingSpec,
};
