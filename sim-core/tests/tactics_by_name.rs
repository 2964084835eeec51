//! Tactics by name: strategies composed in the config from registered tactics
//! (`strategy="tactics"`), a tactic a user registers, and the tactics' behaviours, each in
//! a whole simulation: energy management never lets a robot run dry away from home,
//! boundary following gets round a concave obstacle, two groups cross a one-robot-wide
//! passage without deadlock, and followers keep to their leader.

use std::sync::Arc;

use sim_core::agent::{Ctx, Params, StrategyRegistry, Tactic};
use sim_core::engine::{Group, ScenarioBuilder, Simulation, Start};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap, RobotId};
use sim_core::world::{Action, Event, HomeBase, MapData, RobotType};

/// A map of `w × h` cells of `cell_m` metres, blocked where `blocked(x, y)`, home at `home`.
fn map(cell_m: f64, w: u32, h: u32, home: DVec2, blocked: impl Fn(u32, u32) -> bool) -> Arc<MapData> {
    let grid = Grid::new(DVec2::ZERO, cell_m, w, h).unwrap();
    Arc::new(MapData {
        obstacles: ObstacleMap::from_fn(grid, blocked),
        home: HomeBase::Disc {
            center: home,
            radius_m: 1.5,
        },
        treasures: Vec::new(),
    })
}

/// A group of `count` robots of type 0 running `tactics` (and `extra` parameters), starting
/// around `start`.
fn group(count: u32, start: Start, tactics: &str, extra: &[(&str, &str)]) -> Group {
    let mut params = Params::default().with("tactics", tactics);
    for (k, v) in extra {
        params = params.with(*k, *v);
    }
    Group::new("tactics", 0, count).with_params(params).with_start(start)
}

fn sim(map: Arc<MapData>, seed: u64, rounds: u64, kind: RobotType, groups: Vec<Group>) -> Simulation {
    let mut b = ScenarioBuilder::new(map)
        .with_seed(seed)
        .with_rounds(rounds)
        .with_types(vec![kind]);
    for g in groups {
        b = b.with_group(g);
    }
    Simulation::new(b.build(&StrategyRegistry::with_builtins()).unwrap()).unwrap()
}

/// 48 m × 48 m: a room with a door in the east half, pillars in the west, home in a corner.
fn rooms() -> Arc<MapData> {
    map(1.0, 48, 48, DVec2::new(4.5, 4.5), |x, y| {
        let wall = (x == 24 && (10..40).contains(&y) && !(20..=22).contains(&y)) || (y == 40 && (24..44).contains(&x));
        wall || (x % 12 == 6 && y % 12 == 6 && x < 20)
    })
}

#[test]
fn energy_management_never_lets_a_robot_run_dry_away_from_home() {
    // 130 energy units: the farthest free point of the map is ≈ 60 m from home, so a tank
    // holds a round trip and little more; explorers must turn back in time, again and again.
    let kind = RobotType::explorer().with_energy_capacity(130.0);
    let home = HomeBase::Disc {
        center: DVec2::new(4.5, 4.5),
        radius_m: 1.5,
    };
    let mut recharged = 0;
    for seed in 0..24 {
        let mut s = sim(
            rooms(),
            seed,
            700,
            kind.clone(),
            vec![group(3, Start::Home, "energy,collision,frontier", &[])],
        );
        let mut was_low = [false; 3];
        while s.round() < 700 {
            s.step();
            for (i, r) in s.robots().iter().enumerate() {
                assert!(
                    r.alive,
                    "seed {seed}, round {}: robot {i} ran dry at {}",
                    s.round(),
                    r.position
                );
                assert!(
                    r.energy > 0.0 || home.contains(r.position),
                    "seed {seed}, round {}: robot {i} empty away from home",
                    s.round()
                );
                // Count trips home: energy low, then full again.
                if r.energy < 0.5 * 130.0 {
                    was_low[i] = true;
                } else if was_low[i] && r.energy > 0.9 * 130.0 {
                    was_low[i] = false;
                    recharged += 1;
                }
            }
        }
        assert!(
            s.report().metrics.explored_fraction > 0.3,
            "seed {seed}: the robots did not explore"
        );
    }
    // The tactic really was tested: robots went out far enough to need recharging.
    assert!(recharged >= 24, "only {recharged} recharges over 24 seeds");
}

#[test]
fn boundary_following_gets_round_a_concave_obstacle_to_the_goal_behind_it() {
    // A U open towards the robot (west), the goal behind its back wall: heading straight
    // for the goal leads into the U's pocket.
    let u = |x: u32, y: u32| {
        let arms = (y == 8 || y == 22) && (14..=26).contains(&x);
        let back = x == 26 && (8..=22).contains(&y);
        arms || back
    };
    for (seed, (from_y, to_y)) in [(15.5, 15.5), (12.3, 17.8), (19.6, 11.2), (10.1, 20.9)]
        .into_iter()
        .enumerate()
    {
        let goal = DVec2::new(36.5, to_y);
        let mut s = sim(
            map(1.0, 44, 32, DVec2::new(2.5, 2.5), u),
            seed as u64,
            400,
            RobotType::explorer().with_speed_m_per_round(0.5),
            vec![group(
                1,
                Start::At(DVec2::new(6.5, from_y)),
                "boundary",
                &[("goal", &format!("36.5,{to_y}"))],
            )],
        );
        let mut deepest_x: f64 = 0.0;
        let mut arrived = None;
        while s.round() < 400 && arrived.is_none() {
            s.step();
            let p = s.robots()[0].position;
            if (9.0..22.0).contains(&p.y) && p.x < 26.0 {
                deepest_x = deepest_x.max(p.x);
            }
            if p.distance(goal) <= 0.1 {
                arrived = Some(s.round());
            }
        }
        // It went into the pocket (so it had to get out again) and reached the goal; the
        // way round is ≈ 20 m to the pocket, 2 × 8 m along the arm, 12 m down the back and
        // 10 m on: ≈ 60 m, 120 rounds at 0.5 m.
        assert!(
            deepest_x > 24.0,
            "seed {seed}: never met the back wall (deepest x {deepest_x})"
        );
        let at = arrived.unwrap_or_else(|| panic!("seed {seed}: stuck at {}", s.robots()[0].position));
        assert!(at < 250, "seed {seed}: took {at} rounds");
    }
}

#[test]
fn two_groups_cross_a_one_robot_wide_passage() {
    // 20 m × 10 m, a wall 1 m thick across it at x = 9.5..10.5 with one gap 0.5 m wide:
    // robots 0.3 m across pass one at a time, never two abreast.
    let wall = |x: u32, y: u32| (38..42).contains(&x) && !(20..22).contains(&y);
    let kind = RobotType::explorer()
        .with_radius_m(0.15)
        .with_speed_m_per_round(0.25)
        .with_view_radius_m(15.0);
    for seed in 0..10 {
        let mut s = sim(
            map(0.25, 80, 40, DVec2::new(1.0, 1.0), wall),
            seed,
            1500,
            kind.clone(),
            vec![
                group(
                    4,
                    Start::At(DVec2::new(4.0, 5.0)),
                    "collision,shortest_path",
                    &[("goal", "16,5.2")],
                ),
                group(
                    4,
                    Start::At(DVec2::new(16.0, 5.0)),
                    "collision,shortest_path",
                    &[("goal", "4,5.2")],
                ),
            ],
        );
        let across = |s: &Simulation| {
            s.robots().iter().all(|r| {
                if r.group == 0 {
                    r.position.x > 11.0
                } else {
                    r.position.x < 9.0
                }
            })
        };
        while s.round() < 1500 && !across(&s) {
            s.step();
        }
        // Robots meeting head-on in the passage wait until one backs off (collision
        // avoidance's random escapes): crossing takes hundreds of rounds, within 1,500.
        let stuck: Vec<(RobotId, DVec2)> = s
            .robots()
            .iter()
            .filter(|r| {
                if r.group == 0 {
                    r.position.x <= 11.0
                } else {
                    r.position.x >= 9.0
                }
            })
            .map(|r| (r.id, r.position))
            .collect();
        assert!(
            stuck.is_empty(),
            "seed {seed}: after {} rounds still on their side: {stuck:?}",
            s.round()
        );
    }
}

#[test]
fn followers_keep_to_their_leader_while_it_walks() {
    // Four robots of one type: robot 0 leads (lowest id) to a goal 30 m away; the others
    // follow. Each follower heads for its slot `spacing_m` from where it last heard the
    // leader (a round old), so it is never more than the spacing plus the leader's walk of
    // that round and its own step away from it.
    let spacing_m = 2.0;
    let speed = 0.4;
    let kind = RobotType::explorer().with_speed_m_per_round(speed);
    let mut s = sim(
        map(1.0, 48, 24, DVec2::new(4.5, 12.5), |_, _| false),
        3,
        200,
        kind,
        vec![group(
            4,
            Start::Home,
            "team,shortest_path",
            &[
                ("goal", "40,12.5"),
                ("team.spacing_m", "2"),
                ("shortest_path.optimistic", "1"),
            ],
        )],
    );
    let mut joined = [false; 4];
    let mut following_rounds = 0;
    while s.round() < 200 {
        s.step();
        for e in &s.report().events {
            if let Event::GroupJoined { robot, leader } = e {
                assert_eq!(leader.get(), 0, "robot {robot} joined {leader}");
                joined[robot.index()] = true;
            }
        }
        let leader = s.robots()[0].position;
        for r in &s.robots()[1..] {
            if joined[r.id.index()] && s.round() > 5 {
                let gap = r.position.distance(leader);
                assert!(
                    gap <= spacing_m * 1.25 + 2.0 * speed,
                    "round {}: robot {} is {gap:.2} m from its leader",
                    s.round(),
                    r.id
                );
                following_rounds += 1;
            }
        }
    }
    assert!(joined[1..].iter().all(|&j| j), "not all followers joined: {joined:?}");
    // The leader walked to its goal, so the followers followed over 30 m, not in place.
    assert!(s.robots()[0].position.distance(DVec2::new(40.0, 12.5)) < 1.0);
    assert!(following_rounds > 3 * 150);
}

/// A tactic from "a user crate": stand still on every third round.
struct Pause;

impl Tactic for Pause {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        ctx.round.is_multiple_of(3).then_some(Action::Idle)
    }
}

#[test]
fn tactics_are_composed_by_name_and_users_add_their_own() {
    let mut registry = StrategyRegistry::with_builtins();
    registry
        .tactics_mut()
        .register("pause", "stands still every third round", |p| {
            p.only(&[])?;
            Ok(Box::new(Pause))
        });
    for name in [
        "collision",
        "energy",
        "boundary",
        "shortest_path",
        "frontier",
        "team",
        "pause",
    ] {
        assert!(registry.tactics().names().any(|n| n == name), "{name} not registered");
    }
    let open = map(1.0, 32, 32, DVec2::new(4.5, 4.5), |_, _| false);
    let kind = RobotType::explorer().with_speed_m_per_round(1.0);
    let build = |tactics: &str, registry: &StrategyRegistry| {
        let b = ScenarioBuilder::new(Arc::clone(&open))
            .with_rounds(12)
            .with_types(vec![kind.clone()])
            .with_group(group(
                1,
                Start::At(DVec2::new(4.5, 4.5)),
                tactics,
                &[("goal", "30.5,4.5"), ("shortest_path.optimistic", "1")],
            ));
        b.build(registry).map(|sc| Simulation::new(sc).unwrap())
    };
    // With the user's tactic first, the robot stands still on rounds 3, 6, 9 and 12 and
    // walks 1 m on the others: 8 m in 12 rounds; without it, 12 m.
    let mut s = build("pause,shortest_path", &registry).unwrap();
    while s.round() < 12 {
        s.step();
    }
    assert!(
        (s.robots()[0].position.x - 12.5).abs() < 1e-9,
        "{}",
        s.robots()[0].position
    );
    let mut s = build("shortest_path", &registry).unwrap();
    while s.round() < 12 {
        s.step();
    }
    assert!(
        (s.robots()[0].position.x - 16.5).abs() < 1e-9,
        "{}",
        s.robots()[0].position
    );
    // Bad compositions are refused with the reason.
    let refused = |tactics: &str, extra: &[(&str, &str)]| {
        let b = ScenarioBuilder::new(Arc::clone(&open))
            .with_types(vec![kind.clone()])
            .with_group(group(1, Start::Home, tactics, extra));
        b.build(&registry).err().map(|e| e.to_string()).unwrap_or_default()
    };
    let e = refused("collision,jump", &[]);
    assert!(
        e.contains("unknown tactic 'jump'") && e.contains("shortest_path"),
        "{e}"
    );
    let e = refused("", &[]);
    assert!(e.contains("parameter 'tactics' must name tactics"), "{e}");
    let e = refused("energy", &[("energy.reserve_fraction", "2")]);
    assert!(e.contains("tactic 'energy'") && e.contains("reserve_fraction"), "{e}");
    let e = refused("energy", &[("collision.patience_rounds", "2")]);
    assert!(e.contains("unknown parameter 'collision.patience_rounds'"), "{e}");
    let e = refused("shortest_path", &[("goal", "north")]);
    assert!(e.contains("parameter 'goal' must be a point"), "{e}");
}

#[test]
fn a_composed_strategy_checkpoints_and_resumes_bit_for_bit() {
    let make = || {
        sim(
            rooms(),
            5,
            120,
            RobotType::explorer().with_energy_capacity(130.0),
            vec![
                group(3, Start::Home, "energy,collision,frontier", &[]),
                group(3, Start::Home, "team,collision,boundary", &[("goal", "40,30")]),
            ],
        )
    };
    let state = |s: &Simulation| {
        let mut out = Vec::new();
        s.write_state(&mut out).unwrap();
        out
    };
    let mut whole = make();
    while whole.round() < 120 {
        whole.step();
    }
    let mut first = make();
    while first.round() < 50 {
        first.step();
    }
    let mut resumed = make();
    resumed.read_state(&state(&first)).unwrap();
    while resumed.round() < 120 {
        resumed.step();
    }
    assert_eq!(state(&resumed), state(&whole));
}

/// An optimistic shortest path gets to a goal in terrain the robot has never seen, behind a
/// wall it only finds on the way (30 × 20, the wall at x = 15 from the bottom up to y =
/// 17): it walks at the wall, sees it, and plans round its end, also with collision
/// avoidance before it. Without optimism the tactic has no known route and stays quiet.
#[test]
fn optimistic_shortest_path_finds_the_way_round_an_unseen_wall() {
    let walled = map(1.0, 30, 20, DVec2::new(3.0, 3.5), |x, y| x == 15 && y < 17);
    let kind = RobotType::explorer().with_speed_m_per_round(1.0);
    let goal = DVec2::new(27.0, 3.5);
    let run = |tactics: &str, optimistic: &str| {
        let mut s = sim(
            Arc::clone(&walled),
            1,
            120,
            kind.clone(),
            vec![group(
                1,
                Start::At(DVec2::new(3.0, 3.5)),
                tactics,
                &[("goal", "27,3.5"), ("shortest_path.optimistic", optimistic)],
            )],
        );
        while s.round() < 120 {
            s.step();
        }
        s.robots()[0].position
    };
    // Round the wall's end: at least |(3, 3.5)-(15, 17)| + 1 + |(16, 17)-(27, 3.5)| ≈ 36.5 m,
    // well within 120 rounds at 1 m a round.
    let at = run("shortest_path", "1");
    assert!(at.distance(goal) < 0.1, "optimistic: ended at {at}");
    // Behind collision avoidance too, which escapes first when the robot is held back at
    // the wall.
    let at = run("collision,shortest_path", "1");
    assert!(at.distance(goal) < 0.1, "optimistic after collision: ended at {at}");
    let at = run("shortest_path", "0");
    assert!(at.distance(DVec2::new(3.0, 3.5)) < 0.5, "not optimistic: moved to {at}");
}

/// `cooperative` takes `max_detour_m` (a distance, unbounded when absent) and refuses
/// nonsense with the parameter's name.
#[test]
fn cooperative_takes_max_detour_m() {
    let registry = StrategyRegistry::with_builtins();
    let make = |v: &str| registry.create("cooperative", &Params::default().with("max_detour_m", v));
    assert!(make("5").is_ok());
    assert!(make("0").is_ok());
    for bad in ["-1", "far", "NaN", "inf"] {
        let e = make(bad).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains("parameter 'max_detour_m' must be a number in [0, 1000000]"),
            "{bad}: {e}"
        );
    }
}

/// `frontier` and `cooperative` take `replan_within_view` (a fraction of the view radius)
/// and refuse anything outside [0, 1] with the parameter's name.
#[test]
fn explorers_take_replan_within_view() {
    let registry = StrategyRegistry::with_builtins();
    for strategy in ["frontier", "cooperative"] {
        let make = |v: &str| registry.create(strategy, &Params::default().with("replan_within_view", v));
        for good in ["0", "0.5", "1"] {
            assert!(make(good).is_ok(), "{strategy} {good}");
        }
        for bad in ["-0.1", "1.5", "soon", "NaN"] {
            let e = make(bad).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(
                e.contains("parameter 'replan_within_view' must be a number in [0, 1]"),
                "{strategy} {bad}: {e}"
            );
        }
    }
}
