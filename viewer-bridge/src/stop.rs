//! Clean stops: a first SIGINT (Ctrl-C) or SIGTERM (Slurm at a time limit or on
//! preemption) asks the run to stop after the round in progress, so that it keeps everything
//! it played; a second one ends the process at once.
//!
//! The `smartteams` binary installs the handlers ([`install`]); the library only asks
//! whether a stop was requested ([`requested`]), so runs of a program that installs none
//! (tests, user binaries that handle signals their own way) never stop early.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use anyhow::{Context, Result};
use signal_hook::consts::{SIGINT, SIGTERM};

/// Set by the first stop signal.
static STOPPING: AtomicBool = AtomicBool::new(false);
/// The signal that asked for the stop (0: none).
static SIGNAL: AtomicUsize = AtomicUsize::new(0);

/// A signal that stops a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT (Ctrl-C).
    Interrupt,
    /// SIGTERM (a scheduler's time limit or preemption).
    Terminate,
}

impl Signal {
    /// The exit status of a process stopped by this signal: 128 + its number (130, 143).
    pub fn exit_status(self) -> u8 {
        match self {
            Signal::Interrupt => 130,
            Signal::Terminate => 143,
        }
    }

    /// Its usual name.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Interrupt => "SIGINT",
            Signal::Terminate => "SIGTERM",
        }
    }
}

/// Make SIGINT and SIGTERM ask for a clean stop, and a second one of either end the process
/// at once with 130 or 143.
pub fn install() -> Result<()> {
    for (signal, status) in [(SIGINT, 130), (SIGTERM, 143)] {
        // The exit comes first: it fires only once `STOPPING` is set, by an earlier signal.
        signal_hook::flag::register_conditional_shutdown(signal, status, &STOPPING)
            .and_then(|_| signal_hook::flag::register_usize(signal, &SIGNAL, signal as usize))
            .and_then(|_| signal_hook::flag::register(signal, &STOPPING))
            .context("cannot install the handlers of SIGINT and SIGTERM")?;
    }
    Ok(())
}

/// The signal that asked for a stop, if one did.
pub fn requested() -> Option<Signal> {
    if !STOPPING.load(Ordering::Relaxed) {
        return None;
    }
    match i32::try_from(SIGNAL.load(Ordering::Relaxed)) {
        Ok(SIGTERM) => Some(Signal::Terminate),
        _ => Some(Signal::Interrupt),
    }
}
