//! Running a scene's scheme into memory.

use sph_cases::Scene;
use sph_cases::reference::References;
use sph_cases::registry;
use sph_cases::run::{MemorySink, RunControl, SchemeRun};
use sph_integrators::SchemeKind;

/// Runs `scheme` of `scene` with the embedded references; panics on a setup or sink error.
pub fn run(scene: &Scene, scheme: SchemeKind) -> (SchemeRun, MemorySink) {
    run_with(scene, scheme, RunControl::default())
}

/// [`run`] on a pool of `threads` threads (for the thread-count independence tests).
pub fn run_on_threads(
    scene: &Scene,
    scheme: SchemeKind,
    threads: usize,
) -> (SchemeRun, MemorySink) {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| run(scene, scheme))
}

/// [`run`] with a control (resume, checkpoints).
pub fn run_with(
    scene: &Scene,
    scheme: SchemeKind,
    control: RunControl<'_>,
) -> (SchemeRun, MemorySink) {
    let mut sink = MemorySink::default();
    let run = registry::run_scheme(scene, scheme, References::embedded(), control, &mut sink)
        .unwrap_or_else(|e| panic!("{}: {e}", scheme.name()));
    (run, sink)
}

/// A run's results as bit patterns, without the wall-clock ones (`*seconds*`).
pub fn untimed_results(r: &SchemeRun) -> Vec<(String, u64)> {
    r.results
        .iter()
        .filter(|(k, _)| !k.contains("seconds"))
        .map(|(k, v)| (k.clone(), v.to_bits()))
        .collect()
}
