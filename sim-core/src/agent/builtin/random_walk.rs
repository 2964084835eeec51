//! `random_walk`.

use glam::DVec2;
use rand::Rng;

use crate::Result;
use crate::agent::{CollisionAvoidance, Ctx, Needs, Params, Strategy, Tactic, blocked};
use crate::world::Action;

/// Walks straight; turns with `turn_probability` per round or when a move is refused.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct RandomWalk {
    turn_probability: f64,
    heading: Option<DVec2>,
    coll: CollisionAvoidance,
}

impl Strategy for RandomWalk {
    crate::serde_state!();

    fn needs(&self) -> Needs {
        // The known map answers `can_move` for the collision tactic; other robots are
        // never looked at (the physical unit keeps bodies apart), so they are not perceived.
        Needs {
            known_map: true,
            ..Needs::NONE
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.coll.suggest(ctx) {
            return a;
        }
        let turn = self.heading.is_none() || blocked(ctx) || ctx.rng.random_bool(self.turn_probability);
        if turn {
            self.heading = Some(DVec2::from_angle(ctx.rng.random_range(0.0..std::f64::consts::TAU)));
        }
        let h = self.heading.expect("set above");
        ctx.move_by(h * ctx.kind.speed_m_per_round)
    }
}

impl RandomWalk {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        p.only(&["turn_probability"])?;
        Ok(Self {
            turn_probability: p.f64_in("turn_probability", 0.05, 0.0..=1.0)?,
            heading: None,
            coll: CollisionAvoidance::default(),
        })
    }
}
