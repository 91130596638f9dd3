use thiserror::Error;

/// Errors raised by particle storage.
#[derive(Debug, Error, PartialEq)]
pub enum CoreError {
    /// Two per-particle arrays that must have the same length do not.
    #[error("field `{field}` has {found} entries, expected {expected} (one per particle)")]
    LengthMismatch {
        /// Name of the offending field.
        field: &'static str,
        /// Length required (the number of particles).
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// The periodic description of the domain is invalid.
    #[error("periodic domain: {0}")]
    Periodic(#[from] crate::PeriodicError),
    /// A particle field holds a non-finite value.
    #[error("field `{field}` of particle {index} is not finite")]
    NonFinite {
        /// Name of the offending field.
        field: &'static str,
        /// Index of the first offending particle.
        index: usize,
    },
}
