//! The native module of the `smartteams` Python package: a thin layer over sim-core's public
//! API (and viewer-bridge's, for recordings), as the `smartteams` binary is.
//!
//! - `simulation`: `smartteams.Simulation`, a run driven round by round, its state as
//!   numpy arrays, checkpoints and recordings;
//! - `strategy`: strategies written in Python (`register_strategy`), the `Robot` they
//!   decide for and the actions they return;
//! - `env`: the core of the learning environments of `smartteams/env.py`: robots moved by
//!   the caller, observations and rewards in bulk;
//! - `grids`: windows of known maps and obstacles as cell arrays.

mod env;
mod grids;
mod simulation;
mod strategy;

use pyo3::prelude::*;

/// The allocator of the native module's own allocations (Python keeps its own): a round
/// allocates and frees messages, payloads and search buffers on every worker, which
/// mimalloc's per-thread heaps serve without glibc's trimming and refaulting of pages, as
/// in the `smartteams` binary. Results do not depend on it.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

pyo3::create_exception!(
    smartteams,
    SmartTeamsError,
    pyo3::exceptions::PyException,
    "A config, map, checkpoint or argument Smart Teams cannot use; the message is the one the \
     `smartteams` command prints (with file, line and column where there are some)."
);

/// An error of Smart Teams as a Python exception with the same message.
pub(crate) fn to_py(e: impl std::fmt::Display) -> PyErr {
    SmartTeamsError::new_err(e.to_string())
}

/// A whole number from Python as `T`, `name` what it is: out of `T`'s range (a negative
/// count, a seed past 2⁶⁴ − 1) is a `SmartTeamsError` naming it, where `PyO3`'s own
/// conversion would raise `OverflowError`.
pub(crate) fn whole<T: TryFrom<i128>>(name: &str, value: i128) -> PyResult<T> {
    T::try_from(value).map_err(|_| {
        if value < 0 {
            to_py(format!("{name} must not be negative, got {value}"))
        } else {
            to_py(format!("{name} {value} is too large"))
        }
    })
}

/// [`whole`] of an optional argument.
pub(crate) fn whole_or_none<T: TryFrom<i128>>(name: &str, value: Option<i128>) -> PyResult<Option<T>> {
    value.map(|v| whole(name, v)).transpose()
}

/// The `smartteams._native` module.
#[pymodule(name = "_native")]
fn native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Rerun reports a recording file it cannot write only as a `tracing` event; this
    // module's copy of `tracing` has no other subscriber.
    viewer_bridge::rerun_errors::watch();
    m.add("SmartTeamsError", m.py().get_type::<SmartTeamsError>())?;
    m.add_class::<simulation::Simulation>()?;
    m.add_class::<env::EnvCore>()?;
    strategy::add_to(m)?;
    Ok(())
}
