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
    DEFAULT_DECIDE_LIMIT, PhaseTimes, SIDE_BY_SIDE_MIN_ROBOTS, SIDE_BY_SIDE_MIN_WORKERS, Simulation, TurnSharing,
};
