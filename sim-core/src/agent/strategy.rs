//! Strategies (paper §4.3): one robot's decision process, plugged in by name.
//!
//! A strategy implements [`Strategy`]: it says which perceptions it [`needs`](Strategy::needs)
//! (the kernel computes nothing else for it) and, every round, [`decides`](Strategy::decide)
//! one elementary [`Action`] from a [`Ctx`] that holds its perceptions, its data module, the
//! map within its known region, its messages and a seeded random generator. Strategies are
//! created by name from a [`StrategyRegistry`], so an XML config can assign them to robot
//! groups and a user crate can add its own without touching the simulator.
//!
//! The paper's `MyStrategy` in Rust:
//!
//! ```
//! use sim_core::agent::{CollisionAvoidance, Ctx, Strategy, Tactic};
//! use sim_core::glam::DVec2;
//! use sim_core::world::Action;
//!
//! #[derive(Default)]
//! struct MyStrategy { coll: CollisionAvoidance }
//!
//! impl Strategy for MyStrategy {
//!     fn decide(&mut self, ctx: &mut Ctx) -> Action {
//!         if let Some(a) = self.coll.suggest(ctx) { return a; }
//!         match ctx.treasures_in_view().first() {
//!             Some(t) => ctx.move_towards(t.position),
//!             None => ctx.move_by(DVec2::new(0.0, 1.0)),
//!         }
//!     }
//! }
//! ```

use crate::agent::ctx::Ctx;
use crate::world::{Action, Retention};

/// The perceptions a strategy asks for. The kernel neither computes nor stores the others.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(clippy::struct_excessive_bools)] // one switch per component of the data module
pub struct Needs {
    /// Keep a known map (marked with the view disc every round; merged from messages).
    pub known_map: bool,
    /// Read obstacles (within the known region) and plan on the navigation graph.
    pub obstacles: bool,
    /// See robots in the view radius.
    pub robots: bool,
    /// See treasures in the view radius, and remember them. (Treasures in view are listed
    /// without it too: they count as found whatever the strategy looks at.)
    pub treasures: bool,
    /// Receive messages.
    pub messages: bool,
}

impl Needs {
    /// Everything.
    pub const ALL: Needs = Needs {
        known_map: true,
        obstacles: true,
        robots: true,
        treasures: true,
        messages: true,
    };
    /// A known map and the obstacles in it: what finding routes in known terrain needs.
    pub const NAVIGATION: Needs = Needs {
        known_map: true,
        obstacles: true,
        ..Needs::NONE
    };
    /// Nothing: a blind robot (no sensing energy either).
    pub const NONE: Needs = Needs {
        known_map: false,
        obstacles: false,
        robots: false,
        treasures: false,
        messages: false,
    };

    /// What either needs.
    #[must_use]
    pub fn union(self, other: Needs) -> Needs {
        Needs {
            known_map: self.known_map || other.known_map,
            obstacles: self.obstacles || other.obstacles,
            robots: self.robots || other.robots,
            treasures: self.treasures || other.treasures,
            messages: self.messages || other.messages,
        }
    }

    /// Whether any sensing happens (costs `energy_per_sense`).
    pub fn senses(&self) -> bool {
        self.known_map || self.obstacles || self.robots || self.treasures
    }
}

/// Why a strategy cannot go on, as the payload of an unwind: a strategy that calls
/// `std::panic::resume_unwind(Box::new(StrategyFailure(reason)))` in
/// [`decide`](Strategy::decide) disables its robot alone, as a panic does, with `reason` in
/// the event log and no panic message printed (a strategy written in another language
/// reports its errors so).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StrategyFailure(pub String);

/// One robot's decision process.
pub trait Strategy: Send {
    /// The perceptions this strategy uses (default: all).
    fn needs(&self) -> Needs {
        Needs::ALL
    }
    /// How long remembered treasures and robots are kept (default: the last 64 of each).
    fn retention(&self) -> (Retention, Retention) {
        (Retention::LastN(64), Retention::LastN(64))
    }
    /// Choose this round's action (and send messages through `ctx`).
    fn decide(&mut self, ctx: &mut Ctx) -> Action;

    /// This strategy's state, serialized for a checkpoint; `None` (the default) if it
    /// cannot be saved, and then a run using it cannot be checkpointed. With serde,
    /// `sim_core::agent::save_state(self)` is the whole implementation.
    fn save_state(&self) -> Option<Vec<u8>> {
        None
    }

    /// Take back the state [`save_state`](Self::save_state) gave, on a strategy built from
    /// the same parameters. With serde, `sim_core::agent::restore_state(self, state)`.
    fn restore_state(&mut self, state: &[u8]) -> crate::Result<()> {
        let _ = state;
        Err(crate::Error::InvalidParameter(
            "this strategy keeps no checkpoint state".into(),
        ))
    }
}

/// The checkpoint methods (`save_state`, `restore_state`) of a strategy or tactic whose
/// state is serde-serializable: `impl Strategy for Mine { sim_core::serde_state!(); … }`.
#[macro_export]
macro_rules! serde_state {
    () => {
        fn save_state(&self) -> Option<Vec<u8>> {
            $crate::agent::save_state(self)
        }

        fn restore_state(&mut self, state: &[u8]) -> $crate::Result<()> {
            $crate::agent::restore_state(self, state)
        }
    };
}

/// [`Strategy::save_state`] for a strategy whose state is serde-serializable.
pub fn save_state<T: serde::Serialize>(state: &T) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    ciborium::into_writer(state, &mut out).ok()?;
    Some(out)
}

/// [`Strategy::restore_state`] for a strategy whose state is serde-deserializable.
pub fn restore_state<T: serde::de::DeserializeOwned>(slot: &mut T, state: &[u8]) -> crate::Result<()> {
    *slot = ciborium::from_reader(state)
        .map_err(|e| crate::Error::InvalidParameter(format!("strategy state does not read back: {e}")))?;
    Ok(())
}
