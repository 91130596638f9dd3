//! Stopping a run cleanly: SIGINT (Ctrl-C) and SIGTERM set a flag that the run loop reads after
//! each step ([`sph_cases::run::RunControl::stop`]); at the first step after which the linear
//! solver keeps nothing it would use (at once, or within 10 AMG solves) the run writes a
//! checkpoint and its
//! `run.json` (status `interrupted`) and the command exits with `128 +` the signal's number
//! (130 for SIGINT, 143 for SIGTERM), so `dgsph run … --resume` continues it. A second signal
//! ends the process at once with the same code. SIGXFSZ (a file-size limit) is caught so that
//! the write that hit the limit fails with an error the command reports (exit 4) instead of
//! killing it without a word.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// The stop flag and the signal that set it.
#[derive(Clone, Debug)]
pub struct Stop {
    /// Set by the first SIGINT or SIGTERM.
    pub flag: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl Stop {
    /// Installs the handlers (once per process; later calls install more of the same).
    pub fn install() -> std::io::Result<Self> {
        let flag = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM, SIGXFSZ};
            for sig in [SIGINT, SIGTERM] {
                // Registered first, so it sees the flag before this signal sets it: only a
                // second signal finds it set.
                signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, flag.clone())?;
                signal_hook::flag::register_usize(sig, signal.clone(), sig as usize)?;
                signal_hook::flag::register(sig, flag.clone())?;
            }
            signal_hook::flag::register(SIGXFSZ, Arc::new(AtomicBool::new(false)))?;
        }
        #[cfg(not(unix))]
        {
            use signal_hook::consts::SIGINT;
            signal_hook::flag::register_usize(SIGINT, signal.clone(), SIGINT as usize)?;
            signal_hook::flag::register(SIGINT, flag.clone())?;
        }
        Ok(Self { flag, signal })
    }

    /// Whether a stop was asked for.
    pub fn requested(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }

    /// The exit code of a run stopped by the signal: `128 +` its number.
    pub fn exit_code(&self) -> u8 {
        u8::try_from(128 + self.signal.load(Ordering::Relaxed).min(127)).unwrap_or(255)
    }

    /// The signal's name.
    pub fn signal_name(&self) -> &'static str {
        match self.signal.load(Ordering::Relaxed) {
            2 => "SIGINT",
            15 => "SIGTERM",
            _ => "a signal",
        }
    }
}

/// The process's [`Stop`], its handlers installed on the first call; `None` (runs cannot be
/// stopped cleanly, only killed) if the handlers could not be installed.
pub fn installed() -> Option<Stop> {
    static STOP: std::sync::OnceLock<Option<Stop>> = std::sync::OnceLock::new();
    STOP.get_or_init(|| match Stop::install() {
        Ok(s) => Some(s),
        Err(e) => {
            crate::warn!("warning: no SIGINT/SIGTERM handlers ({e}): a signal kills the run");
            None
        }
    })
    .clone()
}
