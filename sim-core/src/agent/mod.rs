//! Layer 3, the agent API: what a strategy is ([`Strategy`], [`Needs`]), what it sees and
//! may do in a round ([`Ctx`]), its parameters and the [`StrategyRegistry`], the tactics it
//! composes, and the built-in strategies (written with this public API only). Imports
//! only from [`spatial`](crate::spatial) and [`world`](crate::world).

mod builtin;
mod ctx;
mod params;
mod perception;
mod registry;
mod strategy;
mod tactics;
mod testing;

pub use ctx::{Ctx, Mind, RobotRng, StrategyOutput, WorldView};
pub use params::Params;
pub use perception::{DataModule, Perception, SeenRobot, SeenTreasure};
pub use registry::{ComposedFactory, Factory, StrategyRegistry, TacticFactory, TacticRegistry};
pub use strategy::{Needs, Strategy, StrategyFailure, restore_state, save_state};
pub use tactics::{
    BoundaryFollowing, CollisionAvoidance, EnergyManagement, FrontierSeeking, GIVE_UP_ROUNDS, MAX_TOUR_STOPS,
    Navigator, REPLAN_WHEN_KNOWN, REPLAN_WITHIN_VIEW, REVEAL_FIRST, SEARCH_BUDGET, SEEN_COST_VIEWS, ShortestPath,
    TOUR_BASE_WEIGHT, TOUR_STOPS, Tactic, Team, Teaming, Tour, blocked,
};
pub use testing::TestWorld;
