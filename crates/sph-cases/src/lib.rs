//! # sph-cases
//!
//! Scenes and cases of dgsph: what a run simulates, measures and checks. A scene is a TOML file
//! ([`Scene`]; every key in `docs/scenes.md`) naming a case ([`CaseKind`]) and, for the general
//! `flow` case, its geometry: `[[fluid]]` blocks filled on the lattice, `[[wall]]` boxes
//! (containers with open faces, solid obstacles), periodic axes, declared effects. A case
//! ([`Case`]) supplies its initial state, its record columns, its results and checks; one run
//! loop ([`run::run_scheme`], dispatched by dimension in [`registry::run_scheme`]) owns
//! stepping, sampling, checkpoints, resume and blow-up handling for every case.
//!
//! | case | module | effects | reference |
//! |---|---|---|---|
//! | `flow` | [`flow`] | what the scene declares | the scene's `[[check]]`s |
//! | `dam_break` | [`dam_break`] | gravity, free surface, walls | Martin & Moyce (1952) |
//! | `elliptical_drop` / `spheroid_drop` | [`drop`](mod@drop) | free surface | exact drop solution |
//! | `prescribed_ellipse` / `prescribed_ellipsoid` | [`prescribed`] | none (prescribed u) | exact slopes |
//! | `lid_driven_cavity` | [`cavity`] | walls, lid, viscosity (+ shifting) | Ghia et al. (1982) |
//! | kernels, operators | [`foundation`] | — | exact |
//!
//! The library does no I/O: the `dgsph` binary reads scenes and writes results, receiving
//! everything through a [`run::RunSink`]. Reference data is embedded at compile time from
//! `cases/reference/` ([`reference`](mod@reference)).
//!
//! Start with [`registry::parse_scene`] and [`registry::run_scheme`].

pub mod blocks;
mod case;
pub mod cavity;
mod check;
pub mod dam_break;
pub mod drop;
mod error;
pub mod figures;
pub mod flow;
pub mod foundation;
pub mod geometry;
pub mod measure;
pub mod prescribed;
pub mod reference;
pub mod registry;
pub mod run;
mod scene;

pub use blocks::DEFAULT_MAX_SPEED_RATIO;
pub use case::{Case, Column, Finish, Results, Setup, Table};
pub use check::{Check, Criterion};
pub use error::CaseError;
pub use scene::{
    CaseKind, CavitySpec, CavityWallModel, DgHessianChoice, EffectsSpec, Estimate,
    FLOW_DENSITY_RELAXATION, FLOW_HYPERVISCOSITY, QuickOverrides, Scene, ShiftingSpec,
};
