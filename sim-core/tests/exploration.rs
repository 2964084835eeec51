//! Exploration metrics through a real [`Simulation`]: the team's overlap and the rounds and
//! distances at which the explored fraction first reached 50, 90 and 98 %. Expected values
//! are worked out by hand in the comments.

use sim_core::agent::{Ctx, Needs, Strategy, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation, Start};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{Action, ExploredMilestones, HomeBase, MapData, RobotType, RoundMetrics};

const EPS: f64 = 1e-9;

/// A sensing robot that walks east for `out` rounds, 1 m a round, then west.
struct OutAndBack {
    out: u64,
}

impl Strategy for OutAndBack {
    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let dx = if ctx.round <= self.out { 1.0 } else { -1.0 };
        Action::MoveTo {
            to: ctx.position() + DVec2::new(dx, 0.0),
        }
    }
}

/// An open 40 m × `height` m map of 1 m cells; one explorer with a 2 m view and 1 m steps,
/// from (5.5, `height` / 2), playing [`OutAndBack`] for `rounds`.
fn out_and_back(height: u32, out: u64, rounds: u64) -> Simulation {
    let grid = Grid::new(DVec2::ZERO, 1.0, 40, height).unwrap();
    let map = MapData {
        obstacles: ObstacleMap::from_fn(grid, |_, _| false),
        home: HomeBase::Disc {
            center: DVec2::new(1.5, 1.5),
            radius_m: 1.0,
        },
        treasures: Vec::new(),
    };
    let mut kind = RobotType::explorer();
    kind.view_radius_m = 2.0;
    let mut registry = StrategyRegistry::with_builtins();
    registry.register("out_and_back", "walks east, then west", move |_| {
        Ok(Box::new(OutAndBack { out }))
    });
    let scenario = ScenarioBuilder::new(map)
        .with_types(vec![kind])
        .with_rounds(rounds)
        .with_group(Group::new("out_and_back", 0, 1).with_start(Start::At(DVec2::new(5.5, f64::from(height) / 2.0))))
        .build(&registry)
        .unwrap();
    Simulation::new(scenario).unwrap()
}

/// Out for 8 rounds, back for 8. Rounds 1–8 see from 5.5, 6.5, …, 12.5 and each view shows
/// a new column of cells to the east. Round 9 sees from 13.5, which is new too (it arrived
/// there in round 8, after the view), and walks back to 12.5. Rounds 10–16 see from 12.5,
/// 11.5, …, 6.5: each the very view of a round on the way out, so nothing new; their seven
/// 1 m moves are the overlap.
#[test]
fn walking_back_over_explored_ground_is_the_overlap() {
    let mut sim = out_and_back(9, 8, 16);
    let mut overlap_by_round = Vec::new();
    for _ in 0..16 {
        let m = sim.step().metrics;
        overlap_by_round.push(m.overlap_m);
    }
    let r = &sim.robots()[0];
    assert!((r.stats.distance_m - 16.0).abs() < EPS, "{}", r.stats.distance_m);
    assert!((r.stats.overlap_m - 7.0).abs() < EPS, "{}", r.stats.overlap_m);
    // None of it on the way out nor in round 9; then 1 m a round.
    let want: Vec<f64> = (1..=16).map(|k: u32| f64::from(k.saturating_sub(9))).collect();
    assert_eq!(overlap_by_round, want);
    assert!((sim.report().metrics.overlap_m - 7.0).abs() < EPS);
}

/// The milestones by hand: the fraction crosses 50 % in round 3 (0.52) and 90 % in round 5
/// (exactly 0.9: "at least"), and never 98 %; each keeps the round and distance of its
/// first crossing, whatever the later rounds bring.
#[test]
fn milestones_keep_the_first_round_at_or_above_each_fraction() {
    let mut milestones = ExploredMilestones::default();
    let fractions = [0.1, 0.49, 0.52, 0.8, 0.9, 0.95, 0.97];
    let mut last = RoundMetrics::default();
    for (k, &explored_fraction) in fractions.iter().enumerate() {
        let round = k as u64 + 1;
        let mut m = RoundMetrics {
            round,
            explored_fraction,
            distance_m: 10.0 * round as f64,
            ..RoundMetrics::default()
        };
        milestones.note(&mut m);
        if round == 2 {
            assert_eq!((m.explored_50_round, m.explored_90_round), (0, 0));
        }
        last = m;
    }
    assert_eq!(last.explored_50_round, 3);
    assert!((last.explored_50_distance_m - 30.0).abs() < EPS);
    assert_eq!(last.explored_90_round, 5);
    assert!((last.explored_90_distance_m - 50.0).abs() < EPS);
    assert_eq!(last.explored_98_round, 0);
    assert!(last.explored_98_distance_m.abs() < EPS);
}

/// Through a run: the 50 % milestone is the first round whose metrics reach 0.5, with that
/// round's distance, as the per-round metrics show it.
#[test]
fn a_runs_milestones_are_its_first_rounds_past_each_fraction() {
    // 40 m × 4 m, a 2 m view walking the middle east: it sees most of the height, from
    // x = 3.5 to the east edge, so the fraction passes 50 % on the way and stays short of 98 %.
    let mut sim = out_and_back(4, 40, 40);
    let mut rows = Vec::new();
    for _ in 0..40 {
        rows.push(sim.step().metrics);
    }
    let most = rows.iter().map(|m| m.explored_fraction).fold(0.0, f64::max);
    let first = rows
        .iter()
        .find(|m| m.explored_fraction >= 0.5)
        .unwrap_or_else(|| panic!("tops out at {most}"));
    assert!(most < 0.9, "{most}");
    let last = rows.last().unwrap();
    assert_eq!(last.explored_50_round, first.round);
    assert!((last.explored_50_distance_m - first.distance_m).abs() < EPS);
    assert_eq!(last.explored_90_round, 0);
    // Before its round, no row has it; from it on, every row does.
    for m in &rows {
        let want = if m.round < first.round { 0 } else { first.round };
        assert_eq!(m.explored_50_round, want, "round {}", m.round);
    }
}
