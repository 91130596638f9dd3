use sph_core::CoreError;
use sph_integrators::StepError;
use thiserror::Error;

/// Errors of scene handling and case runs.
#[derive(Debug, Error)]
pub enum CaseError {
    /// The scene text is not valid TOML or does not match the schema (unknown key, wrong type).
    #[error("scene {scene}: {message}")]
    Parse {
        /// Scene name or path, as given by the caller.
        scene: String,
        /// The parser's message (with line and column).
        message: String,
    },
    /// A scene value is out of range or inconsistent.
    #[error("scene {scene}: `{field}` {message}")]
    Invalid {
        /// Scene name or path.
        scene: String,
        /// Offending key (`dx`, `fluid[1].radius`, ...).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A reference table is malformed.
    #[error("reference {file}, line {line}: {message}")]
    Reference {
        /// File name (in `cases/reference/`).
        file: String,
        /// 1-based line (0: the whole file).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A checkpoint does not fit the scene.
    #[error("resuming: {0}")]
    Resume(String),
    /// A step of the initial settling (`[start] settle_steps`) failed.
    #[error("settling the initial state ([start] settle_steps): {0}")]
    Settle(String),
    /// The initial particle set is invalid.
    #[error("case setup: {0}")]
    Setup(#[from] CoreError),
    /// The walls of a case are inconsistent.
    #[error("case walls: {0}")]
    Walls(String),
    /// A measurement of the case could not be taken (e.g. probes on a state that has blown up).
    #[error("measuring {what}: {message}")]
    Measure {
        /// Which measurement.
        what: &'static str,
        /// Why.
        message: String,
    },
    /// A time step failed.
    #[error("{scheme}: {source}")]
    Step {
        /// Scheme that was running.
        scheme: &'static str,
        /// What failed.
        source: StepError,
    },
    /// The observer (e.g. a CSV writer) failed; the run stops.
    #[error("writing results: {0}")]
    Output(#[from] std::io::Error),
}
