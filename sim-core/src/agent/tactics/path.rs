//! Shortest paths to the goal.

use glam::DVec2;

use super::navigator::Navigator;
use super::{Tactic, blocked};
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::world::Action;

/// How close to the goal counts as there.
const ARRIVED_M: f64 = 0.05;
/// Rounds between attempts to plan to a goal no known route reaches.
const RETRY_ROUNDS: u64 = 5;
/// Rounds held back on a route before planning it again.
const HELD_ROUNDS: u32 = 3;

/// Goes to the goal ([`Ctx::goal`]) along the shortest route in known terrain, planned on
/// the navigation graph once per goal and again when the route is held back. While no
/// known route reaches the goal (it lies in unexplored terrain) it plans again every few
/// rounds as the way becomes known, and meanwhile is quiet (so that a tactic after it, such
/// as [`BoundaryFollowing`](super::BoundaryFollowing), gets there through the unknown).
/// Optimistic, it plans as if unknown terrain were open: through known terrain to where a
/// straight way on to the goal crosses nothing it knows to be blocked, then on through the
/// unknown (planned again when held back), or, with no such route, straight for the goal
/// as long as the known terrain lets it. Quiet with no goal, at the goal, or with no way it
/// can take.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ShortestPath {
    /// Head straight for a goal that no known route reaches yet (default `false`).
    pub optimistic: bool,
    nav: Navigator,
    planned_for: Option<DVec2>,
    failed_at: Option<u64>,
    held: u32,
}

impl Default for ShortestPath {
    fn default() -> Self {
        Self::new(false)
    }
}

impl ShortestPath {
    /// A shortest-path tactic, optimistic through the unknown or not.
    pub fn new(optimistic: bool) -> Self {
        Self {
            optimistic,
            nav: Navigator::default(),
            planned_for: None,
            failed_at: None,
            held: 0,
        }
    }

    /// The waypoints still ahead on the current route.
    pub fn remaining(&self) -> &[DVec2] {
        self.nav.remaining()
    }
}

impl Tactic for ShortestPath {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let goal = ctx.goal()?;
        let p = ctx.position();
        if p.distance(goal) <= ARRIVED_M {
            self.nav.clear();
            return None;
        }
        self.held = if blocked(ctx) { self.held + 1 } else { 0 };
        let new_goal = self.planned_for != Some(goal);
        let retry = self.nav.is_idle() && self.failed_at.is_none_or(|r| ctx.round >= r + RETRY_ROUNDS);
        if new_goal || retry || self.held >= HELD_ROUNDS {
            self.planned_for = Some(goal);
            self.held = 0;
            let planned = if self.optimistic {
                self.nav.go_to_optimistic(ctx, goal)
            } else {
                self.nav.go_to(ctx, goal)
            };
            if planned {
                self.failed_at = None;
            } else {
                self.nav.clear();
                self.failed_at = Some(ctx.round);
            }
        }
        if let Some(a) = self.nav.step(ctx) {
            return Some(a);
        }
        let step = goal - p;
        let to = p + step.clamp_length_max(ctx.kind.speed_m_per_round);
        (self.optimistic && ctx.can_move(p, to) != Some(false)).then(|| {
            ctx.set_path(&[goal]);
            Action::MoveTo { to: goal }
        })
    }

    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    crate::serde_state!();
}
