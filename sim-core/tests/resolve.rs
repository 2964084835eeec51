//! The physical unit's rules, through a real [`Simulation`]: robots play scripted actions
//! and the tests check what the kernel made of them. Expected values are worked out by
//! hand in the comments.

use std::sync::Arc;

use sim_core::agent::{Ctx, Needs, Strategy, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation, Start};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap, TreasureId};
use sim_core::world::{Action, HomeBase, MapData, Outcome, Payload, RobotType, TreasureSpec};

const EPS: f64 = 1e-9;

/// What a scripted robot does in a round, from the context (round, own position).
type Plan = Arc<dyn Fn(&Ctx) -> Action + Send + Sync>;

/// A strategy that plays its plan; blind (no sensing energy).
struct Scripted(Plan);

impl Strategy for Scripted {
    fn needs(&self) -> Needs {
        Needs::NONE
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        (self.0)(ctx)
    }
}

/// `actions[round − 1]`, then Idle.
fn script(actions: Vec<Action>) -> Plan {
    Arc::new(move |ctx: &Ctx| {
        usize::try_from(ctx.round - 1)
            .ok()
            .and_then(|i| actions.get(i).copied())
            .unwrap_or(Action::Idle)
    })
}

/// Every round, move by `d` from wherever the robot stands.
fn move_by(d: DVec2) -> Plan {
    Arc::new(move |ctx: &Ctx| Action::MoveTo { to: ctx.position() + d })
}

/// 10 m × 10 m, 1 m cells, a wall filling column x = 6 (so its west face is at x = 6 m);
/// home: a disc of 1 m around (1.5, 1.5).
fn map(treasures: Vec<TreasureSpec>) -> MapData {
    let grid = Grid::new(DVec2::ZERO, 1.0, 10, 10).unwrap();
    MapData {
        obstacles: ObstacleMap::from_fn(grid, |x, _| x == 6),
        home: HomeBase::Disc {
            center: DVec2::new(1.5, 1.5),
            radius_m: 1.0,
        },
        treasures,
    }
}

/// One robot per entry (ids in order): type index, start and plan.
fn simulation(map: MapData, types: Vec<RobotType>, robots: Vec<(usize, Start, Plan)>) -> Simulation {
    let mut registry = StrategyRegistry::with_builtins();
    let mut builder = ScenarioBuilder::new(map).with_types(types).with_rounds(20);
    for (i, (type_index, start, plan)) in robots.into_iter().enumerate() {
        let name = format!("scripted{i}");
        registry.register(&name, "plays a test script", move |_| {
            Ok(Box::new(Scripted(Arc::clone(&plan))))
        });
        builder = builder.with_group(Group::new(name, type_index, 1).with_start(start));
    }
    Simulation::new(builder.build(&registry).unwrap()).unwrap()
}

fn explorer() -> RobotType {
    // Speed 1 m, radius 0.125 m, energy_per_m 1, idle 0.05, capacity 5,000.
    RobotType::explorer()
}

#[test]
fn a_move_longer_than_speed_is_trimmed_to_speed() {
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        vec![(0, Start::At(DVec2::new(3.0, 5.1)), move_by(DVec2::new(0.0, 3.0)))],
    );
    let start = sim.robots()[0].position;
    sim.step();
    let r = &sim.robots()[0];
    // Asked for 3 m north, speed 1 m: exactly 1 m north.
    assert!(
        (r.position - (start + DVec2::new(0.0, 1.0))).length() < EPS,
        "{}",
        r.position
    );
    assert_eq!(r.last_action.1, Outcome::Trimmed);
    assert!((r.stats.distance_m - 1.0).abs() < EPS);
}

#[test]
fn a_move_within_speed_is_done_exactly() {
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        vec![(0, Start::At(DVec2::new(3.0, 5.1)), move_by(DVec2::new(0.6, -0.8)))],
    );
    let start = sim.robots()[0].position;
    sim.step();
    let r = &sim.robots()[0];
    // |(0.6, −0.8)| = 1.0 ≤ speed: done as asked.
    assert!((r.position - (start + DVec2::new(0.6, -0.8))).length() < EPS);
    assert_eq!(r.last_action.1, Outcome::Done);
}

#[test]
fn a_move_into_a_wall_stops_short_of_it() {
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        vec![(0, Start::At(DVec2::new(5.1, 5.1)), move_by(DVec2::new(0.9, 0.0)))],
    );
    let start = sim.robots()[0].position;
    assert!(start.x < 5.875);
    sim.step();
    let r = &sim.robots()[0];
    // Wall face at x = 6, radius 0.125: the centre may reach x = 5.875 and no further.
    // Bisection over 24 halvings of a 0.9 m move: tolerance 0.9 / 2^24 ≈ 5.4e−8 m.
    assert!(r.position.x <= 5.875 + 1e-12, "{}", r.position);
    assert!(
        r.position.x >= 5.875 - 0.9 / f64::from(1 << 24) - 1e-12,
        "{}",
        r.position
    );
    assert!((r.position.y - start.y).abs() < EPS);
    assert_eq!(r.last_action.1, Outcome::Trimmed);
}

#[test]
fn a_move_entirely_blocked_is_refused() {
    // Round 1: move to touch the wall exactly (centre at x = 5.875, edge at x = 6): done.
    // Round 2: any further move east has no free fraction at all: refused, no motion.
    let plan: Plan = Arc::new(|ctx: &Ctx| {
        if ctx.round == 1 {
            Action::MoveTo {
                to: DVec2::new(5.875, ctx.position().y),
            }
        } else {
            Action::MoveTo {
                to: ctx.position() + DVec2::new(0.5, 0.0),
            }
        }
    });
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        vec![(0, Start::At(DVec2::new(5.1, 5.1)), plan)],
    );
    sim.step();
    let after1 = sim.robots()[0].clone();
    assert_eq!(after1.last_action.1, Outcome::Done);
    assert!((after1.position.x - 5.875).abs() < EPS, "{}", after1.position);
    sim.step();
    let r = &sim.robots()[0];
    assert_eq!(r.last_action.1, Outcome::Refused);
    assert_eq!(r.position, after1.position);
    // A refused move costs no movement energy: only idle 0.05.
    assert!((after1.energy - r.energy - 0.05).abs() < EPS);
}

#[test]
fn two_robots_asking_for_the_same_spot_lower_id_wins() {
    // Robots at x ≈ 3.0 (id 0) and x ≈ 3.6 (id 1), same row; both ask for the midpoint
    // M = (3.3, y). Id 0 resolves first: 0.3 m ≤ speed, so it is at M (done).
    // Id 1: the move of 0.3 m west is halved until it overlaps nobody (gap ≥ 2·0.125):
    //   1/1 → 0 m from M, 1/2 → 0.15, 1/4 → 0.225 (all < 0.25), 1/8 → 0.2625 ≥ 0.25.
    // So id 1 ends at B + (M − B)/8, trimmed.
    let plan: Plan = Arc::new(|ctx: &Ctx| Action::MoveTo {
        to: DVec2::new(3.3, ctx.position().y),
    });
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        vec![
            (0, Start::At(DVec2::new(3.0, 5.1)), Arc::clone(&plan)),
            (0, Start::At(DVec2::new(3.6, 5.1)), plan),
        ],
    );
    let a = sim.robots()[0].position;
    let b = sim.robots()[1].position;
    assert!((a.y - b.y).abs() < EPS);
    assert!((b.x - a.x - 0.6).abs() < 1e-6, "{a} {b}");
    let m = DVec2::new(3.3, a.y);
    sim.step();
    let r0 = &sim.robots()[0];
    let r1 = &sim.robots()[1];
    assert!((r0.position - m).length() < EPS, "{}", r0.position);
    assert_eq!(r0.last_action.1, Outcome::Done);
    let want = b + (m - b) / 8.0;
    assert!((r1.position - want).length() < EPS, "{} vs {want}", r1.position);
    assert_eq!(r1.last_action.1, Outcome::Trimmed);
    // Round 2: id 1 again asks for M, 0.2625 m away (id 0 standing on it). After k
    // halvings it would end 0.2625·(1 − 2^−k) from M: k = 4 → 0.2461 < 0.25, k = 5 →
    // 0.2543 ≥ 0.25. So it creeps (M − B′)/32 closer, trimmed, and still no overlap.
    let before = r1.position;
    sim.step();
    let r1 = &sim.robots()[1];
    assert_eq!(r1.last_action.1, Outcome::Trimmed);
    let want = before + (m - before) / 32.0;
    assert!((r1.position - want).length() < EPS, "{} vs {want}", r1.position);
    assert!(r1.position.distance(m) >= 0.25);
    // Id 0 stays where it is (a move of length 0 is done).
    assert!((sim.robots()[0].position - m).length() < EPS);
}

/// Step 2 lists who could be in a move's way by the id order (those before a robot within
/// the radii plus the top speed of its move, those after it within the radii), and step 3
/// meets each where the order leaves it.
#[test]
fn a_move_meets_robots_before_it_where_they_moved_and_after_it_where_they_stand() {
    // Starts on the placement lattice (spacing 2 · 0.125 + 0.05 = 0.3 m), so they are
    // kept as given.
    let at = |kx: u32, ky: u32| DVec2::new(f64::from(kx) * 0.3, f64::from(ky) * 0.3);
    let starts = [at(3, 17), at(9, 17), at(14, 10), at(17, 10)];
    // Id 0 moves 1 m east, (0.9, 5.1) → (1.9, 5.1): id 1 stands 0.8 m from that, done.
    // Id 1 asks for 0.75 m west, (2.7, 5.1) → (1.95, 5.1): id 0 now stands 0.05 m from
    // that (< 2 · 0.125), so halved once: (2.325, 5.1), 0.425 m away, trimmed. Id 0 started
    // 1.05 m from id 1's move: only the reach that counts the top speed (0.25 + 1 m) has it.
    // Id 2 moves 0.8 m east, (4.2, 3.0) → (5.0, 3.0): id 3, after it, still stands at
    // (5.1, 3.0), 0.1 m away, so halved once: (4.6, 3.0), trimmed, although id 3 then moves
    // 1 m north, done (id 2 ends 0.5 m from its move).
    let moves = [
        DVec2::new(1.0, 0.0),
        DVec2::new(-0.75, 0.0),
        DVec2::new(0.8, 0.0),
        DVec2::new(0.0, 1.0),
    ];
    let mut sim = simulation(
        map(vec![]),
        vec![explorer()],
        starts
            .iter()
            .zip(moves)
            .map(|(&s, d)| (0, Start::At(s), script(vec![Action::MoveTo { to: s + d }])))
            .collect(),
    );
    for (r, s) in sim.robots().iter().zip(starts) {
        assert_eq!(r.position, s, "{} is placed where asked", r.id);
    }
    sim.step();
    let want = [
        (starts[0] + moves[0], Outcome::Done),
        (starts[1] + moves[1] / 2.0, Outcome::Trimmed),
        (starts[2] + moves[2] / 2.0, Outcome::Trimmed),
        (starts[3] + moves[3], Outcome::Done),
    ];
    for (r, (position, outcome)) in sim.robots().iter().zip(want) {
        assert!(
            (r.position - position).length() < EPS,
            "{}: {} vs {position}",
            r.id,
            r.position
        );
        assert_eq!(r.last_action.1, outcome, "{}", r.id);
    }
}

#[test]
fn excavate_without_the_ability_is_refused() {
    // Robots at ≈ (3.0, 5.1); a treasure of 7 units 0.3 m east, within reach (0.125 + 0.5).
    let treasure = TreasureSpec {
        position: DVec2::new(3.3, 5.1),
        quantity: 7,
    };
    let dig = script(vec![Action::Excavate {
        treasure: TreasureId::new(0),
    }]);
    let mut sim = simulation(
        map(vec![treasure]),
        vec![explorer()],
        vec![(0, Start::At(DVec2::new(3.0, 5.1)), dig.clone())],
    );
    sim.step();
    let r = &sim.robots()[0];
    assert_eq!(r.last_action.1, Outcome::Refused);
    assert_eq!(r.stats.units_dug, 0);
    let t = sim.treasures()[0];
    assert_eq!((t.buried, t.loose), (7, 0));
    // Only idle energy: 5,000 − 0.05 (no digging energy charged).
    assert!((r.energy - 4_999.95).abs() < EPS);

    // The same with an excavator (1 unit a round, 2 energy a round): done, 6 buried, 1 loose.
    let mut sim = simulation(
        map(vec![TreasureSpec {
            position: DVec2::new(3.3, 5.1),
            quantity: 7,
        }]),
        vec![RobotType::excavator()],
        vec![(0, Start::At(DVec2::new(3.0, 5.1)), dig)],
    );
    sim.step();
    let r = &sim.robots()[0];
    assert_eq!(r.last_action.1, Outcome::Done);
    assert_eq!(r.stats.units_dug, 1);
    let t = sim.treasures()[0];
    assert_eq!((t.buried, t.loose), (6, 1));
    // 5,000 − 0.05 idle − 2 digging = 4,997.95.
    assert!((r.energy - 4_997.95).abs() < EPS);
}

/// Digs 5 units a round and carries 3.
fn digger_carrier() -> RobotType {
    RobotType::new("digger_carrier")
        .with_excavation(5)
        .with_carry_capacity(3)
}

fn dig_load_unload() -> Plan {
    let t = TreasureId::new(0);
    script(vec![
        Action::Excavate { treasure: t },
        Action::Load { treasure: t },
        Action::Load { treasure: t },
        Action::Unload,
    ])
}

/// One digger-carrier playing [`dig_load_unload`] from `start`, with a treasure of 20 units
/// at `treasure`.
fn digger_carrier_sim(treasure: DVec2, start: Start) -> Simulation {
    simulation(
        map(vec![TreasureSpec {
            position: treasure,
            quantity: 20,
        }]),
        vec![digger_carrier()],
        vec![(0, start, dig_load_unload())],
    )
}

#[test]
fn load_beyond_capacity_is_trimmed_to_capacity() {
    let mut sim = digger_carrier_sim(DVec2::new(3.3, 5.1), Start::At(DVec2::new(3.0, 5.1)));
    // Round 1: dig 5 → buried 15, loose 5.
    sim.step();
    let t = sim.treasures()[0];
    assert_eq!((t.buried, t.loose), (15, 5));
    // Round 2: load with room for 3 of the 5 → carries 3, 2 stay loose.
    sim.step();
    let r = &sim.robots()[0];
    assert_eq!(r.load(), 3);
    assert_eq!(r.cargo, vec![(TreasureId::new(0), 3)]);
    assert_eq!(sim.treasures()[0].loose, 2);
    assert_ne!(r.last_action.1, Outcome::Refused);
    // Round 3: full, room 0 → refused, nothing moves.
    sim.step();
    let r = &sim.robots()[0];
    assert_eq!(r.last_action.1, Outcome::Refused);
    assert_eq!(r.load(), 3);
    assert_eq!(sim.treasures()[0].loose, 2);
}

/// A load limited by capacity is a load carried out in part: [`Outcome::Trimmed`] says so.
#[test]
fn load_limited_by_capacity_reports_trimmed() {
    let mut sim = digger_carrier_sim(DVec2::new(3.3, 5.1), Start::At(DVec2::new(3.0, 5.1)));
    sim.step();
    sim.step();
    // 5 loose, room 3: 3 loaded of the 5 asked for.
    assert_eq!(sim.robots()[0].last_action.1, Outcome::Trimmed);
}

#[test]
fn unload_outside_home_is_refused() {
    let mut sim = digger_carrier_sim(DVec2::new(3.3, 5.1), Start::At(DVec2::new(3.0, 5.1)));
    for _ in 0..4 {
        sim.step();
    }
    // Round 4: unload at ≈ (3.0, 5.1), 3.9 m from home's centre (radius 1): refused.
    let r = &sim.robots()[0];
    assert!(!sim.map().home.contains(r.position));
    assert_eq!(r.last_action, (Action::Unload, Outcome::Refused));
    assert_eq!(r.load(), 3);
    assert_eq!(r.stats.units_delivered, 0);
    assert_eq!(sim.treasures()[0].delivered, 0);
}

#[test]
fn unload_at_home_delivers() {
    // The same script, starting at home with the treasure 0.3 m east of home's centre.
    let mut sim = digger_carrier_sim(DVec2::new(1.8, 1.5), Start::Home);
    for _ in 0..4 {
        sim.step();
    }
    let r = &sim.robots()[0];
    assert!(sim.map().home.contains(r.position));
    assert_eq!(r.last_action, (Action::Unload, Outcome::Done));
    assert_eq!(r.load(), 0);
    assert_eq!(r.stats.units_delivered, 3);
    assert_eq!(sim.treasures()[0].delivered, 3);
}

#[test]
fn energy_idle_every_round_and_distance_times_energy_per_m() {
    let mut kind = explorer();
    kind.energy_idle = 0.5;
    kind.energy_per_m = 2.5;
    let walk: Plan = Arc::new(|ctx: &Ctx| match ctx.round {
        2 => Action::MoveTo {
            to: ctx.position() + DVec2::new(0.6, 0.0),
        },
        // 3 m asked, trimmed to speed 1 m.
        3 => Action::MoveTo {
            to: ctx.position() + DVec2::new(0.0, -3.0),
        },
        _ => Action::Idle,
    });
    let mut sim = simulation(
        map(vec![]),
        vec![kind],
        vec![(0, Start::At(DVec2::new(3.0, 5.1)), walk)],
    );
    // Round 1, idle: 5,000 − 0.5 = 4,999.5.
    sim.step();
    assert!((sim.robots()[0].energy - 4_999.5).abs() < EPS);
    // Round 2, 0.6 m: 4,999.5 − 0.5 − 0.6·2.5 = 4,997.5.
    sim.step();
    assert!((sim.robots()[0].energy - 4_997.5).abs() < EPS);
    // Round 3, 1 m (trimmed): 4,997.5 − 0.5 − 1·2.5 = 4,994.5.
    sim.step();
    assert!((sim.robots()[0].energy - 4_994.5).abs() < EPS);
    // Round 4, idle: 4,994.5 − 0.5 = 4,994.
    sim.step();
    let r = &sim.robots()[0];
    assert!((r.energy - 4_994.0).abs() < EPS);
    // Spent in all: 4·0.5 + 1.6·2.5 = 6.
    assert!((r.stats.energy_used - 6.0).abs() < EPS);
    assert!((r.stats.distance_m - 1.6).abs() < EPS);
}

/// Publishes a goal and a path made of the round number, moves a little, optionally talks
/// (so that its turn waits for step 3's order) or panics in one round.
struct Planner {
    talk: bool,
    panic_in_round: Option<u64>,
}

impl Strategy for Planner {
    fn needs(&self) -> Needs {
        Needs::NONE
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let r = ctx.round as f64;
        ctx.set_goal(Some(DVec2::new(r, 7.0)));
        ctx.set_path(&[DVec2::new(r, 1.0), DVec2::new(r, 2.0)]);
        if self.talk {
            ctx.broadcast(Payload::Position {
                position: ctx.position(),
                goal: None,
            });
        }
        assert!(self.panic_in_round != Some(ctx.round), "planned failure");
        Action::MoveTo {
            to: ctx.position() + DVec2::new(0.0, 0.1),
        }
    }
}

/// The goal and path a strategy publishes reach the robot (what viewers draw) whether its
/// turn was resolved in step 2 (alone) or in step 3 (it talks), and a robot whose strategy
/// fails keeps the last ones it published.
#[test]
fn published_goals_and_paths_reach_every_robot_that_decided() {
    let mut registry = StrategyRegistry::with_builtins();
    for (name, talk, panic_in_round) in [
        ("quiet", false, None),
        ("talker", true, None),
        ("failing", false, Some(2)),
    ] {
        registry.register(name, "publishes its plan", move |_| {
            Ok(Box::new(Planner { talk, panic_in_round }))
        });
    }
    let mut builder = ScenarioBuilder::new(map(vec![]))
        .with_types(vec![explorer()])
        .with_rounds(5);
    for (name, x) in [("quiet", 1.5), ("talker", 3.5), ("failing", 4.5)] {
        builder = builder.with_group(Group::new(name, 0, 1).with_start(Start::At(DVec2::new(x, 5.0))));
    }
    let mut sim = Simulation::new(builder.build(&registry).unwrap()).unwrap();
    let plan = |round: f64| {
        (
            Some(DVec2::new(round, 7.0)),
            vec![DVec2::new(round, 1.0), DVec2::new(round, 2.0)],
        )
    };
    sim.step();
    for r in sim.robots() {
        assert_eq!((r.goal, r.path.clone()), plan(1.0), "{} after round 1", r.id);
    }
    sim.step();
    let robots = sim.robots();
    assert_eq!((robots[0].goal, robots[0].path.clone()), plan(2.0), "the quiet robot");
    assert_eq!((robots[1].goal, robots[1].path.clone()), plan(2.0), "the talker");
    assert!(!robots[2].alive, "the failing robot is disabled");
    assert_eq!(
        (robots[2].goal, robots[2].path.clone()),
        plan(1.0),
        "the failing robot keeps round 1's"
    );
}
