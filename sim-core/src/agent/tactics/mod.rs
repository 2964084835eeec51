//! Tactics (paper §4.3): reusable local procedures any strategy can call.
//!
//! A [`Tactic`] watches the situation and, when it wants to act, *suggests* the action
//! (the paper's `hasAction()` / `performAction()`). Built in: [`CollisionAvoidance`] (robots
//! and obstacles, with stuck detection), [`EnergyManagement`] (keep a path home; go back in
//! time; recharge), [`BoundaryFollowing`] (slide along an obstacle), [`Navigator`] (shortest
//! paths on the navigation graph within known terrain, and frontier search) and [`Team`]
//! (forming, following and breaking up groups).

mod boundary;
mod collision;
mod energy;
mod navigator;
mod team;

pub use boundary::BoundaryFollowing;
pub use collision::CollisionAvoidance;
pub use energy::EnergyManagement;
pub use navigator::Navigator;
pub use team::Team;

use crate::agent::ctx::Ctx;
use crate::world::{Action, Outcome};

/// A local procedure that may take over a round.
pub trait Tactic: Send {
    /// The action this tactic wants now, if any.
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action>;
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
