//! A user-defined strategy, in a crate of its own: the paper's `MyStrategy` (§4.3), made to
//! collect what it sees. It heads for the nearest treasure in view, otherwise sweeps north,
//! and lets the collision tactic take over when it is stuck.
//!
//! It also re-implements the built-in `random_walk` as [`MyRandomWalk`] (`my_random_walk`)
//! with nothing but the public API, and a test shows that it gives the built-in's results
//! to the byte: a built-in strategy has no privileges a user crate lacks.
//!
//! `register` adds both to a registry; `src/main.rs` turns that
//! into a complete `smartteams`-style command line (`cargo run -p custom-strategy -- run
//! CONFIG.xml`), where configs can use `strategy="treasure_seeker"`.

use rand::Rng;
use sim_core::agent::{CollisionAvoidance, Ctx, Needs, Params, Strategy, StrategyRegistry, Tactic, blocked};
use sim_core::glam::DVec2;
use sim_core::world::Action;

/// The paper's `MyStrategy`: go to the first treasure in view, else move north. Its state
/// is serde-serializable, so runs using it can be checkpointed (`save_state`).
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct TreasureSeeker {
    coll: CollisionAvoidance,
    /// Direction of the sweep when nothing is in view.
    pub heading: DVec2,
}

impl Strategy for TreasureSeeker {
    sim_core::serde_state!();

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

/// The built-in `random_walk`, written outside sim-core: walk straight, turn to a random
/// heading with `turn_probability` per round or when a move was held back, and let the
/// collision tactic take over when stuck.
pub struct MyRandomWalk {
    turn_probability: f64,
    heading: Option<DVec2>,
    coll: CollisionAvoidance,
}

impl Strategy for MyRandomWalk {
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
        // The same draws in the same order as the built-in, so that the results match.
        let turn = self.heading.is_none() || blocked(ctx) || ctx.rng.random_bool(self.turn_probability);
        if turn {
            self.heading = Some(DVec2::from_angle(ctx.rng.random_range(0.0..std::f64::consts::TAU)));
        }
        let heading = self.heading.unwrap_or(DVec2::X);
        ctx.move_by(heading * ctx.kind.speed_m_per_round)
    }
}

/// A tactic of our own: head for the nearest treasure in view, and stay there. Configs
/// compose it by name with the built-in tactics, e.g. `strategy="tactics"` with
/// `tactics="collision,treasure_magnet,frontier"`.
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct TreasureMagnet;

impl Tactic for TreasureMagnet {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let p = ctx.position();
        let nearest = ctx
            .treasures_in_view()
            .iter()
            .map(|t| t.position)
            .min_by(|a, b| a.distance_squared(p).total_cmp(&b.distance_squared(p)))?;
        // At the treasure the magnet holds the robot: letting go would hand it to the next
        // tactic, which walks it off, and the magnet pulls it back every other round.
        Some(if nearest.distance(p) > 0.1 {
            ctx.move_towards(nearest)
        } else {
            Action::Idle
        })
    }

    fn needs(&self) -> Needs {
        Needs {
            treasures: true,
            ..Needs::NONE
        }
    }

    sim_core::serde_state!();
}

/// Register `treasure_seeker` (parameter `heading_deg`, default 90 = north),
/// `my_random_walk` (parameter `turn_probability`, default 0.05, in 0..=1) and the tactic
/// `treasure_magnet`.
pub fn register(registry: &mut StrategyRegistry) {
    registry.tactics_mut().register(
        "treasure_magnet",
        "example: heads for the nearest treasure in view",
        |p: &Params| {
            p.only(&[])?;
            Ok(Box::new(TreasureMagnet))
        },
    );
    registry.register(
        "my_random_walk",
        "example: the built-in random_walk, re-implemented in a user crate",
        |p: &Params| {
            p.only(&["turn_probability"])?;
            Ok(Box::new(MyRandomWalk {
                turn_probability: p.f64_in("turn_probability", 0.05, 0.0..=1.0)?,
                heading: None,
                coll: CollisionAvoidance::default(),
            }))
        },
    );
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
    use std::path::Path;
    use std::sync::Arc;

    use sim_core::engine::{Group, ScenarioBuilder, Simulation};
    use sim_core::io::{MetricsCsv, write_robot_stats};
    use sim_core::spatial::{Grid, ObstacleMap};
    use sim_core::world::{HomeBase, MapData, RobotType, TreasureSpec};

    use super::*;

    /// A 32 m × 64 m open map, home in the south, one treasure at (18, 40).
    fn north_map() -> MapData {
        let grid = Grid::new(DVec2::ZERO, 1.0, 32, 64).unwrap();
        MapData {
            obstacles: ObstacleMap::empty(grid),
            home: HomeBase::Disc {
                center: DVec2::new(16.0, 4.0),
                radius_m: 2.0,
            },
            treasures: vec![TreasureSpec {
                position: DVec2::new(18.0, 40.0),
                quantity: 1,
            }],
        }
    }

    #[test]
    fn a_user_strategy_runs_by_name_and_finds_the_treasure_north() {
        let mut registry = StrategyRegistry::with_builtins();
        register(&mut registry);
        assert!(registry.names().any(|n| n == "treasure_seeker"));
        let scenario = ScenarioBuilder::new(north_map())
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

    #[test]
    fn a_user_tactic_composes_by_name_with_the_builtins() {
        let mut registry = StrategyRegistry::with_builtins();
        register(&mut registry);
        // Go north (a goal far up the map) by the built-in shortest-path tactic, but let the
        // user's magnet take over once the treasure is in view.
        let params: Params = [
            ("tactics", "collision,treasure_magnet,shortest_path"),
            ("goal", "16,63"),
            ("shortest_path.optimistic", "1"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect();
        let scenario = ScenarioBuilder::new(north_map())
            .with_rounds(60)
            .with_types(vec![RobotType::explorer()])
            .with_group(Group::new("tactics", 0, 1).with_params(params))
            .build(&registry)
            .unwrap();
        let mut sim = Simulation::new(scenario).unwrap();
        sim.run(&mut []).unwrap();
        assert_eq!(sim.report().metrics.treasures_found, 1);
        let at = sim.robots()[0].position;
        assert!(at.distance(DVec2::new(18.0, 40.0)) < 0.2, "{at:?}");
    }

    /// Metrics CSV and robot-stats CSV of 24 walkers of `strategy` crossing the demo map.
    fn walk_on_the_demo_map(strategy: &str) -> (String, String) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo.stmap");
        let map = Arc::new(MapData::load(&path).unwrap());
        let mut registry = StrategyRegistry::with_builtins();
        register(&mut registry);
        let scenario = ScenarioBuilder::new(map)
            .with_name("walk")
            .with_seed(7)
            .with_rounds(300)
            .with_types(vec![RobotType::explorer()])
            .with_group(
                Group::new(strategy, 0, 24).with_name("walkers").with_params(
                    [("turn_probability".to_owned(), "0.1".to_owned())]
                        .into_iter()
                        .collect(),
                ),
            )
            .build(&registry)
            .unwrap();
        let mut sim = Simulation::new(scenario).unwrap();
        let mut metrics = MetricsCsv::new(Vec::new()).unwrap();
        sim.run(&mut [&mut metrics]).unwrap();
        let mut stats = Vec::new();
        write_robot_stats(&sim, &mut stats).unwrap();
        let metrics = String::from_utf8(metrics.into_inner().unwrap()).unwrap();
        let stats = String::from_utf8(stats).unwrap().replace(strategy, "STRATEGY");
        (metrics, stats)
    }

    #[test]
    fn random_walk_written_outside_sim_core_gives_the_builtins_results() {
        let builtin = walk_on_the_demo_map("random_walk");
        let mine = walk_on_the_demo_map("my_random_walk");
        // The walkers really walked (and bumped into things), so the match is not trivial:
        // every one covered ground (column `distance_m`; some may never be the first to see
        // a cell, so `explored_m2` can be 0).
        let last = builtin.0.lines().last().unwrap().to_owned();
        assert!(
            builtin.1.lines().skip(1).all(|l| l
                .split(',')
                .nth(5)
                .and_then(|d| d.parse::<f64>().ok())
                .is_some_and(|d| d > 10.0)),
            "{}",
            builtin.1
        );
        assert_eq!(builtin.0.lines().count(), 301, "{last}");
        assert_eq!(builtin.0, mine.0, "metrics differ");
        assert_eq!(builtin.1, mine.1, "robot stats differ");
    }
}
