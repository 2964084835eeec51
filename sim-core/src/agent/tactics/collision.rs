//! Collision avoidance: escape when stuck.

use glam::DVec2;
use rand::Rng;

use super::Tactic;
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::world::{Action, Outcome};

/// Escapes when a robot has been stuck (moves refused or trimmed to nothing, by walls or
/// other robots) for `patience_rounds`: it heads off in a random free direction for
/// `escape_rounds`, then the strategy takes over again. (Overlaps themselves can never
/// happen: the physical unit refuses them.)
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct CollisionAvoidance {
    /// Rounds without progress before escaping (default 3).
    pub patience_rounds: u32,
    /// Rounds an escape lasts (default 3).
    pub escape_rounds: u32,
    stuck: u32,
    escaping: u32,
    heading: DVec2,
    last_position: Option<DVec2>,
}

impl Default for CollisionAvoidance {
    fn default() -> Self {
        Self {
            patience_rounds: 3,
            escape_rounds: 3,
            stuck: 0,
            escaping: 0,
            heading: DVec2::X,
            last_position: None,
        }
    }
}

impl CollisionAvoidance {
    /// Whether the robot has stopped making progress.
    pub fn is_stuck(&self) -> bool {
        self.stuck >= self.patience_rounds
    }
}

impl Tactic for CollisionAvoidance {
    fn needs(&self) -> Needs {
        Needs {
            known_map: true,
            ..Needs::NONE
        }
    }

    crate::serde_state!();

    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let p = ctx.position();
        let moved = self.last_position.map_or(f64::INFINITY, |q| q.distance(p));
        self.last_position = Some(p);
        // Held back by a wall or a robot; standing still by choice is not being stuck.
        let held_back = matches!(
            ctx.me.last_action,
            (Action::MoveTo { .. }, Outcome::Trimmed | Outcome::Refused)
        );
        if held_back && moved < 0.01 * ctx.kind.speed_m_per_round {
            self.stuck += 1;
        } else {
            self.stuck = 0;
        }
        if self.is_stuck() && self.escaping == 0 {
            self.escaping = self.escape_rounds;
            self.stuck = 0;
            self.heading = random_free_heading(ctx).unwrap_or(-self.heading);
        }
        if self.escaping > 0 {
            self.escaping -= 1;
            let to = p + self.heading * ctx.kind.speed_m_per_round;
            if !may_head_for(ctx, to) {
                self.heading = random_free_heading(ctx).unwrap_or(-self.heading);
            }
            return Some(Action::MoveTo {
                to: p + self.heading * ctx.kind.speed_m_per_round,
            });
        }
        None
    }
}

/// Whether an escape may head for `to`: not known to be blocked, and not off the map (no
/// cell there is ever known, so the known map cannot say; a robot pressed against the
/// map's edge would pick such headings again and again): `escapes_never_head_off_the_map`.
fn may_head_for(ctx: &Ctx, to: DVec2) -> bool {
    let on_map = ctx.known().is_none_or(|k| k.grid().extent().contains_strictly(to));
    on_map && ctx.can_move(ctx.position(), to) != Some(false)
}

fn random_free_heading(ctx: &mut Ctx) -> Option<DVec2> {
    let p = ctx.position();
    let step = ctx.kind.speed_m_per_round;
    let start = ctx.rng.random_range(0.0..std::f64::consts::TAU);
    (0..12)
        .map(|i| DVec2::from_angle(start + f64::from(i) * std::f64::consts::TAU / 12.0))
        .find(|h| may_head_for(ctx, p + *h * step))
}
