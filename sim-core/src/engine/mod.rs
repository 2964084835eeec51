//! Layer 4, the engine: a validated [`Scenario`] and the [`Simulation`] that runs it, round
//! by round (perceive → decide → resolve, then the caller observes). Imports only from the
//! layers below.

mod checkpoint;
mod hot_workers;
mod round;
mod scenario;
mod simulation;

pub use hot_workers::{CoreLoan, with_hot_workers, with_hot_workers_lending};
pub use round::MAX_MAP_MERGES_PER_ROUND;
pub use scenario::{Group, Scenario, ScenarioBuilder, Start};
pub use simulation::{
    DEFAULT_DECIDE_LIMIT, PhaseTimes, SIDE_BY_SIDE_MIN_ROBOTS, SIDE_BY_SIDE_MIN_ROBOTS_ON_TWO, Simulation, TurnSharing,
};

/// The most worker threads a run may ask for: beyond the cores of any machine runs are
/// made on, and far below where starting the threads would exhaust the process's memory
/// maps.
pub const MAX_THREADS: usize = 1024;

/// Check a worker count (`None`: one per core): `Err` says what is allowed unless it lies
/// in 1..=[`MAX_THREADS`].
///
/// ```
/// assert!(sim_core::engine::check_threads(Some(8)).is_ok());
/// assert!(sim_core::engine::check_threads(Some(0)).is_err());
/// ```
pub fn check_threads(threads: Option<usize>) -> Result<(), String> {
    match threads {
        Some(t) if !(1..=MAX_THREADS).contains(&t) => Err(format!("must be from 1 to {MAX_THREADS}, got {t}")),
        _ => Ok(()),
    }
}
