//! A user-defined strategy, in a crate of its own: the paper's `MyStrategy` (§4.3), made to
//! collect what it sees. It heads for the nearest treasure in view, otherwise sweeps north,
//! and lets the collision tactic take over when it is stuck.
//!
//! `register` adds it to a registry under the name `treasure_seeker`; `src/main.rs` turns that
//! into a complete `smartteams`-style command line (`cargo run -p custom-strategy -- run
//! CONFIG.xml`), where configs can use `strategy="treasure_seeker"`.

use sim_core::agent::{CollisionAvoidance, Ctx, Needs, Params, Strategy, StrategyRegistry, Tactic};
use sim_core::glam::DVec2;
use sim_core::world::Action;

/// The paper's `MyStrategy`: go to the first treasure in view, else move north.
#[derive(Default)]
pub struct TreasureSeeker {
    coll: CollisionAvoidance,
    /// Direction of the sweep when nothing is in view.
    pub heading: DVec2,
}

impl Strategy for TreasureSeeker {
    fn needs(&self) -> Needs {
        Needs {
            treasures: true,
            known_map: true,
            ..Needs::NONE
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.coll.suggest(ctx) {
            return a;
        }
        match ctx.treasures_in_view().first() {
            Some(t) => ctx.move_towards(t.position),
            None => ctx.move_by(self.heading),
        }
    }
}

/// Register `treasure_seeker` (parameter `heading_deg`, default 90 = north).
pub fn register(registry: &mut StrategyRegistry) {
    registry.register(
        "treasure_seeker",
        "example: the paper's MyStrategy, from a user crate",
        |p: &Params| {
            p.only(&["heading_deg"])?;
            let deg = p.f64_in("heading_deg", 90.0, -360.0..=360.0)?;
            Ok(Box::new(TreasureSeeker {
                coll: CollisionAvoidance::default(),
                heading: DVec2::from_angle(deg.to_radians()),
            }))
        },
    );
}

#[cfg(test)]
mod tests {
    use sim_core::engine::{Group, ScenarioBuilder, Simulation};
    use sim_core::spatial::{Grid, ObstacleMap};
    use sim_core::world::{HomeBase, MapData, RobotType, TreasureSpec};

    use super::*;

    #[test]
    fn a_user_strategy_runs_by_name_and_finds_the_treasure_north() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 32, 64).unwrap();
        let map = MapData {
            obstacles: ObstacleMap::empty(grid),
            home: HomeBase::Disc {
                center: DVec2::new(16.0, 4.0),
                radius_m: 2.0,
            },
            treasures: vec![TreasureSpec {
                position: DVec2::new(18.0, 40.0),
                quantity: 1,
            }],
        };
        let mut registry = StrategyRegistry::with_builtins();
        register(&mut registry);
        assert!(registry.names().any(|n| n == "treasure_seeker"));
        let scenario = ScenarioBuilder::new(map)
            .with_name("seek")
            .with_seed(1)
            .with_rounds(60)
            .with_types(vec![RobotType::explorer()])
            .with_group(Group::new("treasure_seeker", 0, 1).with_name("seekers"))
            .build(&registry)
            .unwrap();
        let mut sim = Simulation::new(scenario).unwrap();
        sim.run(&mut []).unwrap();
        // North at 1 m a round from y = 4 sees the treasure (view 6 m) by y = 34, then walks
        // to it: it ends within reach.
        assert_eq!(sim.report().metrics.treasures_found, 1);
        assert!(
            sim.robots()[0].position.distance(DVec2::new(18.0, 40.0)) < 0.5,
            "{:?}",
            sim.robots()[0].position
        );
    }
}
