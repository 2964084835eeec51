//! Tactics (paper §4.3): reusable local procedures any strategy can call, by type or by
//! name.
//!
//! A [`Tactic`] watches the situation and, when it wants to act, *suggests* the action
//! (the paper's `hasAction()` / `performAction()`). Built in, and registered by name in
//! every [`TacticRegistry`](crate::agent::TacticRegistry) made
//! [`with_builtins`](crate::agent::TacticRegistry::with_builtins):
//!
//! | name | tactic | what it does |
//! |---|---|---|
//! | `collision` | [`CollisionAvoidance`] | escapes when held back by walls or robots |
//! | `energy` | [`EnergyManagement`] | keeps a known way home, goes back in time, recharges |
//! | `boundary` | [`BoundaryFollowing`] | goes to the goal, following an obstacle's boundary round it (Bug2) |
//! | `shortest_path` | [`ShortestPath`] | goes to the goal along the shortest route in known terrain |
//! | `frontier` | [`FrontierSeeking`] | walks to the nearest frontier (known free space next to the unknown) |
//! | `team` | [`Teaming`] | forms groups, keeps a follower's slot by its leader ([`Team`]) |
//!
//! The goal of `boundary` and `shortest_path` is the robot's published goal
//! ([`Ctx::goal`]), which the strategy (or `frontier`) sets. [`Navigator`] is the route
//! follower they build on.

mod boundary;
mod collision;
mod energy;
mod frontier;
mod navigator;
mod path;
mod team;
mod tour;

pub use boundary::BoundaryFollowing;
pub use collision::CollisionAvoidance;
pub use energy::EnergyManagement;
pub use frontier::{
    FrontierSeeking, GIVE_UP_ROUNDS, REPLAN_WHEN_KNOWN, REPLAN_WITHIN_VIEW, REVEAL_FIRST, SEEN_COST_VIEWS,
};
pub use navigator::Navigator;
pub use path::ShortestPath;
pub use team::{Team, Teaming};
pub use tour::{MAX_TOUR_STOPS, TOUR_BASE_WEIGHT, TOUR_STOPS, Tour};

use crate::agent::ctx::Ctx;
use crate::agent::params::{MAX_DISTANCE_M, MAX_ROUNDS, Params};
use crate::agent::registry::TacticRegistry;
use crate::agent::strategy::Needs;
use crate::world::{Action, Outcome};

/// A local procedure that may take over a round.
pub trait Tactic: Send {
    /// The action this tactic wants now, if any.
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action>;

    /// What it needs perceived (default: nothing); a strategy composed of tactics
    /// perceives what any of them needs.
    fn needs(&self) -> Needs {
        Needs::NONE
    }

    /// Its state, for checkpoints, as
    /// [`Strategy::save_state`](crate::agent::Strategy::save_state) (default `None`: a
    /// strategy using it cannot be checkpointed). [`serde_state!`](crate::serde_state)
    /// writes both methods for a serde-serializable tactic.
    fn save_state(&self) -> Option<Vec<u8>> {
        None
    }

    /// Take back the state [`save_state`](Self::save_state) gave.
    fn restore_state(&mut self, state: &[u8]) -> crate::Result<()> {
        let _ = state;
        Err(crate::Error::InvalidParameter(
            "this tactic keeps no checkpoint state".into(),
        ))
    }
}

/// Nodes a single search may settle (bounds the cost of one plan).
pub const SEARCH_BUDGET: usize = 50_000;

/// Whether a refused or trimmed move suggests the way is blocked.
pub fn blocked(ctx: &Ctx) -> bool {
    matches!(
        ctx.me.last_action,
        (Action::MoveTo { .. }, Outcome::Refused | Outcome::Trimmed)
    )
}

impl TacticRegistry {
    /// A registry with the built-in tactics: `collision`, `energy`, `boundary`,
    /// `shortest_path`, `frontier` and `team` (see the [`Tactic`] implementations).
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        r.register(
            "collision",
            "escapes in a random free direction when held back for patience_rounds (escape_rounds long)",
            |p| {
                p.only(&["patience_rounds", "escape_rounds"])?;
                let mut t = CollisionAvoidance::default();
                let rounds = |name, default: u32| {
                    p.u64_in(name, u64::from(default), 1..=1000)
                        .map(|r| u32::try_from(r).unwrap_or(u32::MAX))
                };
                t.patience_rounds = rounds("patience_rounds", t.patience_rounds)?;
                t.escape_rounds = rounds("escape_rounds", t.escape_rounds)?;
                Ok(Box::new(t))
            },
        );
        r.register(
            "energy",
            "walks home along a known route when energy falls to its cost plus reserve_fraction; recharges to leave_at_fraction",
            |p| {
                p.only(&["reserve_fraction", "leave_at_fraction", "replan_every"])?;
                let mut t = EnergyManagement::default();
                t.reserve_fraction = p.f64_in("reserve_fraction", t.reserve_fraction, 0.0..=1.0)?;
                t.leave_at_fraction = p.f64_in("leave_at_fraction", t.leave_at_fraction, 0.0..=1.0)?;
                t.replan_every = p.u64_in("replan_every", t.replan_every, 1..=MAX_ROUNDS)?;
                Ok(Box::new(t))
            },
        );
        r.register(
            "boundary",
            "heads for the goal; at an obstacle follows its boundary (obstacle on the right) until it can leave closer to the goal (Bug2)",
            |p| {
                p.only(&[])?;
                Ok(Box::new(BoundaryFollowing::default()))
            },
        );
        r.register(
            "shortest_path",
            "goes to the goal along the shortest route in known terrain; while none is known, quiet (optimistic=1: plans as if unknown terrain were open)",
            |p| {
                p.only(&["optimistic"])?;
                Ok(Box::new(ShortestPath::new(p.u64_in("optimistic", 0, 0..=1)? == 1)))
            },
        );
        r.register(
            "frontier",
            "walks to the nearest frontier (known free space next to the unknown) by route, plus seen_cost_views \
             view radii (2) for a view round it already known, those with reveal_first (0.15) of their view \
             unknown first, and publishes it as the goal",
            |p| {
                p.only(&["seen_cost_views", "reveal_first"])?;
                let seen = p.f64_in("seen_cost_views", SEEN_COST_VIEWS, 0.0..=100.0)?;
                let reveal = p.f64_in("reveal_first", REVEAL_FIRST, 0.0..=1.0)?;
                Ok(Box::new(
                    FrontierSeeking::default()
                        .with_ranking_by_target(Some(seen))
                        .with_reveal_first(reveal),
                ))
            },
        );
        r.register(
            "team",
            "announces itself; follows the lowest id in radio range, keeping its slot spacing_m from it (timeout_rounds)",
            |p| Ok(Box::new(Teaming(team_from_params(p)?))),
        );
        r
    }
}

impl Default for TacticRegistry {
    /// The built-in tactics.
    fn default() -> Self {
        Self::with_builtins()
    }
}

/// A [`Team`] from `spacing_m` and `timeout_rounds`.
pub(crate) fn team_from_params(p: &Params) -> crate::Result<Team> {
    p.only(&["spacing_m", "timeout_rounds"])?;
    let mut t = Team::default();
    t.spacing_m = p.f64_in("spacing_m", t.spacing_m, f64::MIN_POSITIVE..=MAX_DISTANCE_M)?;
    t.timeout_rounds = p.u64_in("timeout_rounds", t.timeout_rounds, 0..=MAX_ROUNDS)?;
    Ok(t)
}
