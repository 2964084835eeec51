//! The kernel: rules enforced every round, adversarial strategies refused, determinism
//! across thread counts, exploration and delivery end to end.

use std::sync::Arc;

use sim_core::agent::{Ctx, Needs, Params, Strategy, StrategyRegistry};
use sim_core::engine::{Group, Start};
use sim_core::engine::{Scenario, ScenarioBuilder, Simulation, TurnSharing};
use sim_core::glam::DVec2;
use sim_core::io::InvariantChecker;
use sim_core::io::{Observer, ObserverError};
use sim_core::spatial::{Grid, ObstacleMap, TreasureId};
use sim_core::world::RoundReport;
use sim_core::world::{Action, HomeBase, MapData, Outcome, RobotType, TreasureSpec};

/// 48 m × 48 m: outer free space, a room with a door, a few pillars.
fn rooms_map(treasures: Vec<TreasureSpec>) -> Arc<MapData> {
    let grid = Grid::new(DVec2::ZERO, 1.0, 48, 48).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        let wall = (x == 24 && (10..40).contains(&y) && !(20..=22).contains(&y)) || (y == 40 && (24..44).contains(&x));
        let pillar = (x % 12 == 6) && (y % 12 == 6) && x < 20;
        wall || pillar
    });
    Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(4.5, 4.5),
            radius_m: 2.0,
        },
        treasures,
    })
}

/// A scenario's parts, still open to changes (starts, rounds) before it is validated.
struct Setup {
    map: Arc<MapData>,
    seed: u64,
    rounds: u64,
    types: Vec<RobotType>,
    groups: Vec<Group>,
}

impl Setup {
    fn build(self, registry: &StrategyRegistry) -> sim_core::Result<Scenario> {
        let mut b = ScenarioBuilder::new(self.map)
            .with_name("test")
            .with_seed(self.seed)
            .with_rounds(self.rounds)
            .with_types(self.types);
        for g in self.groups {
            b = b.with_group(g);
        }
        b.build(registry)
    }
}

fn new_sim(s: Setup, registry: &StrategyRegistry) -> sim_core::Result<Simulation> {
    Simulation::new(s.build(registry)?)
}

fn scenario(map: Arc<MapData>, seed: u64, rounds: u64, groups: Vec<(u32, RobotType, &str)>) -> Setup {
    let mut types = Vec::new();
    let groups = groups
        .into_iter()
        .enumerate()
        .map(|(i, (count, kind, strategy))| {
            types.push(kind);
            Group {
                name: format!("g{i}"),
                count,
                type_index: i,
                strategy: strategy.into(),
                params: Params::default(),
                start: Start::Home,
            }
        })
        .collect();
    Setup {
        map,
        seed,
        rounds,
        types,
        groups,
    }
}

fn run_checked(sim: &mut Simulation, extra: &mut [&mut dyn Observer]) -> InvariantChecker {
    let mut checker = InvariantChecker::new();
    let mut observers: Vec<&mut dyn Observer> = vec![&mut checker];
    for o in extra.iter_mut() {
        observers.push(&mut **o);
    }
    sim.run(&mut observers).unwrap_or_else(|e| panic!("{e}"));
    checker
}

/// Records every round's metrics and every robot's exact position bits.
#[derive(Default)]
struct Trace(Vec<(String, Vec<RobotBits>)>);

/// A robot's position and energy, bit for bit.
type RobotBits = (u64, u64, u64);

impl Observer for Trace {
    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        let robots = sim
            .robots()
            .iter()
            .map(|r| (r.position.x.to_bits(), r.position.y.to_bits(), r.energy.to_bits()))
            .collect();
        self.0
            .push((format!("{:?} {:?}", report.metrics, report.events), robots));
        Ok(())
    }
}

#[test]
fn frontier_explores_the_rooms_map() {
    let map = rooms_map(Vec::new());
    let registry = StrategyRegistry::with_builtins();
    let mut sim = new_sim(
        scenario(map, 1, 600, vec![(4, RobotType::explorer(), "frontier")]),
        &registry,
    )
    .unwrap();
    let checker = run_checked(&mut sim, &mut []);
    assert_eq!(checker.rounds_checked, 600);
    let explored = sim.report().metrics.explored_fraction;
    assert!(explored >= 0.95, "explored {explored}");
}

fn rounds_to_explore(robots: u32, fraction: f64) -> u64 {
    let registry = StrategyRegistry::with_builtins();
    let s = scenario(
        rooms_map(Vec::new()),
        7,
        2000,
        vec![(robots, RobotType::explorer(), "cooperative")],
    );
    let mut sim = new_sim(s, &registry).unwrap();
    while sim.round() < 2000 {
        if sim.step().metrics.explored_fraction >= fraction {
            return sim.round();
        }
    }
    panic!("{robots} robots never explored {fraction}");
}

#[test]
fn more_robots_explore_faster() {
    let one = rounds_to_explore(1, 0.9);
    let eight = rounds_to_explore(8, 0.9);
    assert!(eight * 2 < one, "1 robot: {one} rounds, 8 robots: {eight} rounds");
}

#[test]
fn excavators_and_transporters_deliver_every_treasure() {
    let treasures = vec![
        TreasureSpec {
            position: DVec2::new(12.5, 30.5),
            quantity: 6,
        },
        TreasureSpec {
            position: DVec2::new(35.5, 20.5),
            quantity: 4,
        },
        TreasureSpec {
            position: DVec2::new(40.5, 44.5),
            quantity: 5,
        },
    ];
    let map = rooms_map(treasures);
    let registry = StrategyRegistry::with_builtins();
    let s = scenario(
        map,
        3,
        3000,
        vec![
            (3, RobotType::explorer(), "cooperative"),
            (2, RobotType::excavator(), "excavator"),
            (2, RobotType::transporter(), "transporter"),
        ],
    );
    let mut sim = new_sim(s, &registry).unwrap();
    let mut checker = InvariantChecker::new();
    checker.on_start(&sim).unwrap();
    while sim.round() < 3000 && sim.report().metrics.treasures_delivered < 3 {
        sim.step();
        let report = sim.report().clone();
        checker.on_round(&sim, &report).unwrap();
    }
    let m = sim.report().metrics;
    eprintln!("all treasures delivered after {} rounds", sim.round());
    assert_eq!(m.treasures_delivered, 3, "after {} rounds: {m:?}", sim.round());
    assert_eq!(m.units_delivered, 15);
    assert!(sim.treasures().iter().all(|t| t.delivered == t.initial));
}

/// The trace of a run of `groups` on the rooms map with one treasure, on `threads` worker
/// threads, the simulation set up by `adjust`.
fn rooms_trace(
    threads: usize,
    seed: u64,
    rounds: u64,
    groups: Vec<(u32, RobotType, &str)>,
    adjust: impl FnOnce(Simulation) -> Simulation + Send,
) -> Trace {
    let treasures = vec![TreasureSpec {
        position: DVec2::new(30.5, 30.5),
        quantity: 3,
    }];
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let s = scenario(rooms_map(treasures), seed, rounds, groups);
        let mut sim = adjust(new_sim(s, &StrategyRegistry::with_builtins()).unwrap());
        let mut t = Trace::default();
        run_checked(&mut sim, &mut [&mut t]);
        t
    })
}

/// Two traces of `rounds` rounds are the same, round by round.
fn assert_same_rounds(a: &Trace, b: &Trace, rounds: usize) {
    assert_eq!(a.0.len(), rounds);
    assert_eq!(b.0.len(), rounds);
    for (round, (a, b)) in a.0.iter().zip(&b.0).enumerate() {
        assert_eq!(a, b, "round {} differs", round + 1);
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let groups = || {
        vec![
            (6, RobotType::explorer(), "cooperative"),
            (3, RobotType::explorer(), "random_walk"),
            (2, RobotType::excavator(), "excavator"),
            (2, RobotType::transporter(), "transporter"),
        ]
    };
    let one = rooms_trace(1, 42, 150, groups(), |sim| sim);
    let four = rooms_trace(4, 42, 150, groups(), |sim| sim);
    assert_same_rounds(&one, &four, 150);
    // A different seed gives a different run (the seed is really used).
    let walkers = || vec![(3, RobotType::explorer(), "random_walk")];
    let a = rooms_trace(1, 43, 150, walkers(), |sim| sim);
    let b = rooms_trace(1, 42, 150, walkers(), |sim| sim);
    assert_ne!(a.0, b.0);
}

/// Turns that depend on nobody, resolved in step 2 in parallel, give exactly the run that
/// resolving every turn in id order gives: a crowd of random walkers that bump into each
/// other, explorers that talk, and workers that dig and carry (every round's metrics,
/// events and robot bits), on 2 threads.
#[test]
fn turns_resolved_alone_give_the_id_order_run() {
    let groups = || {
        vec![
            (30, RobotType::explorer(), "random_walk"),
            (6, RobotType::explorer(), "cooperative"),
            (2, RobotType::excavator(), "excavator"),
            (2, RobotType::transporter(), "transporter"),
        ]
    };
    let alone = rooms_trace(2, 7, 200, groups(), |sim| sim.with_turns_resolved_alone(true));
    let in_order = rooms_trace(2, 7, 200, groups(), |sim| sim.with_turns_resolved_alone(false));
    assert_same_rounds(&alone, &in_order, 200);
}

/// A 160 m × 160 m open map with a few walls and a home of 6 m in the middle, three
/// treasures near it.
fn crowd_map() -> Arc<MapData> {
    let grid = Grid::new(DVec2::ZERO, 1.0, 160, 160).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        (x == 70 && (60..78).contains(&y)) || (y == 92 && (70..100).contains(&x))
    });
    let treasures = [(74.5, 80.5, 6), (88.5, 76.5, 4), (80.5, 88.5, 5)]
        .map(|(x, y, quantity)| TreasureSpec {
            position: DVec2::new(x, y),
            quantity,
        })
        .to_vec();
    Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(80.0, 80.0),
            radius_m: 6.0,
        },
        treasures,
    })
}

/// Step 3's turns taken side by side (moves settled by strips of the map, several workers
/// waiting for or settling one another's movers) give exactly the run of one pass in id
/// order: 1,300 robots crowded round home, walkers that block one another, larger and
/// faster walkers, walkers that run dry, explorers that talk, workers that dig and carry,
/// a strategy that fails (every round's metrics, events, positions and energies), on 1, 3
/// and 4 threads; with unlimited radios and with a radio budget.
#[test]
fn turns_side_by_side_give_the_id_order_run() {
    let mut registry = StrategyRegistry::with_builtins();
    registry.register("fragile", "", |_| Ok(Box::new(Fragile)));
    let groups = |radio_bytes: u64| {
        let talker = RobotType::explorer().with_radio_bytes_per_round(radio_bytes);
        vec![
            (3, RobotType::explorer(), "fragile"),
            (1000, RobotType::explorer(), "random_walk"),
            (
                50,
                RobotType::explorer().with_radius_m(0.4).with_speed_m_per_round(1.5),
                "random_walk",
            ),
            (150, RobotType::explorer().with_energy_capacity(30.0), "random_walk"),
            (60, talker, "cooperative"),
            (20, RobotType::excavator(), "excavator"),
            (20, RobotType::transporter(), "transporter"),
        ]
    };
    for radio_bytes in [u64::MAX, 4096] {
        let run = |threads: usize, sharing: TurnSharing| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let s = scenario(crowd_map(), 11, 120, groups(radio_bytes));
                let mut sim = new_sim(s, &registry).unwrap().with_turn_sharing(sharing);
                let mut t = Trace::default();
                run_checked(&mut sim, &mut [&mut t]);
                (t, sim.phase_times())
            })
        };
        let (in_order, times) = run(3, TurnSharing::InOrder);
        assert_eq!(times.rounds_side_by_side, 0);
        for threads in [1, 3, 4] {
            let (side_by_side, times) = run(threads, TurnSharing::SideBySide);
            assert_same_rounds(&side_by_side, &in_order, 120);
            assert_eq!(times.rounds_side_by_side, 120, "every round's turns went side by side");
        }
        let alive_at_end = in_order.0[119].1.iter().filter(|r| r.2 > 0).count();
        assert!(alive_at_end < 1300, "some walkers ran dry");
    }
}

/// A run stepped on a pool of 4 workers and a pool of 1 in turn, its turns side by side:
/// the 1-worker rounds have the strips cut for 4, so their only worker settles each strip
/// itself, up to the movers it needs of the others, before finishing its own. Same run as
/// in id order.
#[test]
fn turns_side_by_side_on_one_worker_with_several_strips_give_the_id_order_run() {
    let registry = StrategyRegistry::with_builtins();
    let groups = vec![(1200, RobotType::explorer(), "random_walk")];
    let (four, one) = (
        rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap(),
        rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap(),
    );
    let run = |sharing: TurnSharing| {
        let s = scenario(crowd_map(), 5, 40, groups.clone());
        let mut sim = new_sim(s, &registry).unwrap().with_turn_sharing(sharing);
        let mut trace = Trace::default();
        for round in 1..=40 {
            let pool = if round % 2 == 1 { &four } else { &one };
            let report = pool.install(|| sim.step().clone());
            trace.on_round(&sim, &report).unwrap();
        }
        (trace, sim.phase_times().rounds_side_by_side)
    };
    let (side_by_side, shared) = run(TurnSharing::SideBySide);
    let (in_order, _) = run(TurnSharing::InOrder);
    assert_eq!(shared, 40);
    assert_same_rounds(&side_by_side, &in_order, 40);
}

/// Planning is timed only when asked, into `PhaseTimes::planning`, and timing it changes
/// nothing in the run. Explorers plan frontier routes and workers routes to treasures on
/// the rooms map.
#[test]
fn planning_time_is_measured_when_asked_and_changes_nothing() {
    let groups = || {
        vec![
            (6, RobotType::explorer(), "cooperative"),
            (2, RobotType::excavator(), "excavator"),
            (2, RobotType::transporter(), "transporter"),
        ]
    };
    let timed = rooms_trace(2, 9, 120, groups(), |sim| sim.with_time_planning(true));
    let untimed = rooms_trace(2, 9, 120, groups(), |sim| sim);
    assert_same_rounds(&timed, &untimed, 120);
    let planning = |on: bool| {
        let s = scenario(rooms_map(Vec::new()), 9, 60, groups());
        let mut sim = new_sim(s, &StrategyRegistry::with_builtins())
            .unwrap()
            .with_time_planning(on);
        for _ in 0..60 {
            sim.step();
        }
        sim.phase_times().planning
    };
    let (on, off) = (planning(true), planning(false));
    assert!(
        on > std::time::Duration::ZERO,
        "explorers planned, yet no planning time"
    );
    assert!(on < std::time::Duration::from_mins(1));
    assert_eq!(off, std::time::Duration::ZERO);
}

/// A strategy that always asks for the same action, and records what came of it.
struct Cheat(fn(&Ctx) -> Action);

impl Strategy for Cheat {
    fn needs(&self) -> Needs {
        Needs::NONE
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        (self.0)(ctx)
    }
}

fn cheat_registry() -> StrategyRegistry {
    let mut r = StrategyRegistry::empty();
    r.register("teleport", "", |_| {
        Ok(Box::new(Cheat(|_| Action::MoveTo {
            to: DVec2::new(40.0, 44.0),
        })))
    });
    r.register("through_wall", "", |_| {
        Ok(Box::new(Cheat(|c| Action::MoveTo {
            to: c.position() + DVec2::new(0.9, 0.0),
        })))
    });
    r.register("dig", "", |_| {
        Ok(Box::new(Cheat(|_| Action::Excavate {
            treasure: TreasureId::new(0),
        })))
    });
    r.register("hoard", "", |_| {
        Ok(Box::new(Cheat(|_| Action::Load {
            treasure: TreasureId::new(0),
        })))
    });
    r.register("unload_anywhere", "", |_| Ok(Box::new(Cheat(|_| Action::Unload))));
    r.register("nan", "", |_| {
        Ok(Box::new(Cheat(|_| Action::MoveTo {
            to: DVec2::new(f64::NAN, 1.0),
        })))
    });
    r
}

#[test]
fn cheating_strategies_are_refused() {
    let treasure = TreasureSpec {
        position: DVec2::new(4.5, 4.5),
        quantity: 50,
    };
    let map = rooms_map(vec![treasure]);
    let registry = cheat_registry();
    let kind = RobotType::explorer().with_speed_m_per_round(0.7);
    let s = scenario(
        map.clone(),
        1,
        40,
        vec![
            (2, kind.clone(), "teleport"),
            (2, kind.clone(), "dig"),
            (1, RobotType::transporter().with_carry_capacity(3), "hoard"),
            (1, kind.clone(), "unload_anywhere"),
            (1, kind, "nan"),
        ],
    );
    let mut sim = new_sim(s, &registry).unwrap();
    let start: Vec<DVec2> = sim.robots().iter().map(|r| r.position).collect();
    run_checked(&mut sim, &mut []);
    let robots = sim.robots();
    // Teleporters walk at speed 0.7 at most: 40 rounds ⇒ ≤ 28 m from the start.
    for r in &robots[0..2] {
        assert!(r.position.distance(start[r.id.index()]) <= 28.0 + 1e-9);
        assert!(r.stats.distance_m <= 28.0 + 1e-9);
    }
    // Explorers cannot dig: the treasure is untouched, every attempt refused.
    assert_eq!(sim.treasures()[0].buried, 50);
    assert_eq!(robots[2].last_action.1, Outcome::Refused);
    // Nothing was dug, so nothing can be loaded; unloading with nothing is refused.
    assert_eq!(robots[4].load(), 0);
    assert_eq!(robots[5].last_action.1, Outcome::Refused);
    assert_eq!(robots[6].position, start[6]);

    // A wall walker stops at the wall: start it west of the wall at x = 24.
    let mut s = scenario(map, 1, 30, vec![(1, RobotType::explorer(), "through_wall")]);
    s.groups[0].start = Start::At(DVec2::new(20.5, 15.5));
    let mut sim = new_sim(s, &registry).unwrap();
    run_checked(&mut sim, &mut []);
    let x = sim.robots()[0].position.x;
    assert!(x <= 24.0 - 0.125 + 1e-9 && x > 23.0, "stopped at x = {x}");
}

#[test]
fn hoarders_are_capped_by_capacity_and_digging_feeds_them() {
    let treasure = TreasureSpec {
        position: DVec2::new(4.5, 4.5),
        quantity: 100,
    };
    let mut registry = cheat_registry();
    registry.register("dig_forever", "", |_| {
        Ok(Box::new(Cheat(|_| Action::Excavate {
            treasure: TreasureId::new(0),
        })))
    });
    let s = scenario(
        rooms_map(vec![treasure]),
        1,
        30,
        vec![
            (1, RobotType::excavator().with_excavation(2), "dig_forever"),
            (1, RobotType::transporter().with_carry_capacity(3), "hoard"),
        ],
    );
    let mut sim = new_sim(s, &registry).unwrap();
    run_checked(&mut sim, &mut []);
    let t = sim.treasures()[0];
    assert_eq!(sim.robots()[1].load(), 3, "{t:?}");
    assert_eq!(t.buried, 100 - 2 * 30);
}

struct Events<'a>(&'a mut Vec<sim_core::world::Event>);
impl Observer for Events<'_> {
    fn on_round(&mut self, _: &Simulation, r: &RoundReport) -> Result<(), ObserverError> {
        self.0.extend(r.events.iter().cloned());
        Ok(())
    }
}

#[test]
fn energy_runs_out_and_disables_for_good() {
    let registry = StrategyRegistry::with_builtins();
    // 20 energy, 1 per metre: a random walker dies within ~20 m, far from home.
    let kind = RobotType::explorer().with_energy_capacity(20.0);
    let mut s = scenario(rooms_map(Vec::new()), 5, 200, vec![(3, kind, "random_walk")]);
    s.groups[0].start = Start::At(DVec2::new(30.5, 5.5));
    let mut sim = new_sim(s, &registry).unwrap();
    let mut events = Vec::new();
    run_checked(&mut sim, &mut [&mut Events(&mut events)]);
    assert!(sim.robots().iter().all(|r| !r.alive && r.energy == 0.0));
    assert_eq!(
        events
            .iter()
            .filter(|e| matches!(e, sim_core::world::Event::RobotDisabled { .. }))
            .count(),
        3
    );
    assert_eq!(sim.report().metrics.robots_alive, 0);
}

#[test]
fn energy_management_brings_explorers_home_to_recharge() {
    let registry = StrategyRegistry::with_builtins();
    let kind = RobotType::explorer().with_energy_capacity(120.0);
    let s = scenario(rooms_map(Vec::new()), 9, 800, vec![(2, kind, "frontier")]);
    let mut sim = new_sim(s, &registry).unwrap();
    run_checked(&mut sim, &mut []);
    assert!(
        sim.robots().iter().all(|r| r.alive),
        "{:?}",
        sim.robots().iter().map(|r| r.energy).collect::<Vec<_>>()
    );
    // They walked far more than one tank's worth, so they recharged on the way.
    assert!(sim.robots().iter().all(|r| r.stats.distance_m > 150.0));
}

#[test]
fn team_groups_form_and_follow_their_leader() {
    let registry = StrategyRegistry::with_builtins();
    let mut s = scenario(rooms_map(Vec::new()), 4, 120, vec![(4, RobotType::explorer(), "team")]);
    s.rounds = 120;
    let mut sim = new_sim(s, &registry).unwrap();
    let mut events = Vec::new();
    run_checked(&mut sim, &mut [&mut Events(&mut events)]);
    // Robots 1–3 hear robot 0 (lowest id in range) in round 2 and join its group.
    for follower in 1..4 {
        assert!(
            events.contains(&sim_core::world::Event::GroupJoined {
                robot: sim_core::spatial::RobotId::new(follower),
                leader: sim_core::spatial::RobotId::new(0),
            }),
            "{events:?}"
        );
    }
    // Followers stay near the leader: spacing 2 m, plus the leader's position is a round old
    // when heard and it walks on at 1 m a round; walls and team mates can hold one back.
    let leader = sim.robots()[0].position;
    let gaps: Vec<f64> = sim.robots()[1..].iter().map(|r| r.position.distance(leader)).collect();
    assert!(
        gaps.iter().sum::<f64>() / 3.0 <= 4.5 && gaps.iter().all(|&g| g <= 8.0),
        "{gaps:?}"
    );
    assert!(sim.report().metrics.explored_fraction > 0.1);
}

/// The collective explored map is marked on another thread while step 3 runs. The round
/// that completes the map still reports `MapExplored` once, and the free area the robots
/// are credited with adds up to the map's (every free cell credited once).
#[test]
fn map_explored_once_and_every_free_cell_credited_once() {
    let grid = Grid::new(DVec2::ZERO, 1.0, 24, 24).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| x == 12 && y < 18);
    let free_m2 = f64::from(24 * 24 - 18);
    let map = Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(3.5, 3.5),
            radius_m: 2.0,
        },
        treasures: Vec::new(),
    });
    let registry = StrategyRegistry::with_builtins();
    let mut sim = new_sim(
        scenario(
            map,
            5,
            400,
            vec![
                (3, RobotType::explorer(), "cooperative"),
                (2, RobotType::explorer(), "random_walk"),
            ],
        ),
        &registry,
    )
    .unwrap();
    let mut explored_in = Vec::new();
    while sim.round() < 400 {
        let report = sim.step();
        let n = report
            .events
            .iter()
            .filter(|e| matches!(e, sim_core::world::Event::MapExplored))
            .count();
        if n > 0 {
            assert_eq!(n, 1);
            let fraction = report.metrics.explored_fraction;
            assert!(
                (fraction - 1.0).abs() < 1e-12,
                "round {}: explored {fraction}",
                report.round
            );
            explored_in.push(report.round);
        }
    }
    assert_eq!(explored_in.len(), 1, "MapExplored in rounds {explored_in:?}");
    let credited: f64 = sim.robots().iter().map(|r| r.stats.explored_m2).sum();
    assert!((credited - free_m2).abs() < 1e-6, "credited {credited} m² of {free_m2}");
}

/// The robots whose known map changed are listed on the explored map's thread, and the
/// first sightings only in rounds that step 2 found news in. Each round's report still
/// lists exactly the robots whose known cells grew (maps only grow), in id order, and a
/// `TreasureFound` for each treasure in the round its `found_round` names, once.
#[test]
fn reports_list_changed_maps_and_first_sightings() {
    let treasures = vec![
        TreasureSpec {
            position: DVec2::new(12.5, 30.5),
            quantity: 2,
        },
        TreasureSpec {
            position: DVec2::new(35.5, 20.5),
            quantity: 2,
        },
    ];
    let registry = StrategyRegistry::with_builtins();
    let mut sim = new_sim(
        scenario(
            rooms_map(treasures),
            7,
            300,
            vec![
                (3, RobotType::explorer(), "cooperative"),
                (2, RobotType::explorer(), "random_walk"),
            ],
        ),
        &registry,
    )
    .unwrap();
    let ids: Vec<_> = sim.robots().iter().map(|r| r.id).collect();
    let cells = |sim: &Simulation| -> Vec<u64> {
        ids.iter()
            .map(|&id| sim.known_map(id).map_or(0, sim_core::spatial::KnownMap::known_cells))
            .collect()
    };
    let (mut some_changed, mut some_unchanged, mut found) = (0, 0, Vec::new());
    while sim.round() < 300 {
        let before = cells(&sim);
        let report = sim.step().clone();
        let after = cells(&sim);
        let grew: Vec<_> = ids
            .iter()
            .zip(before.iter().zip(&after))
            .filter(|(_, (b, a))| a > b)
            .map(|(&id, _)| id)
            .collect();
        assert_eq!(report.known_changed, grew, "round {}", report.round);
        some_changed += usize::from(!grew.is_empty());
        some_unchanged += usize::from(grew.len() < ids.len());
        for e in &report.events {
            if let sim_core::world::Event::TreasureFound { treasure, .. } = e {
                found.push((*treasure, report.round));
            }
        }
    }
    assert!(
        some_changed > 10 && some_unchanged > 10,
        "{some_changed} {some_unchanged}"
    );
    let expected: Vec<_> = (0..2)
        .filter_map(|t| {
            let id = TreasureId::new(t);
            sim.treasure(id).and_then(|s| s.found_round).map(|r| (id, r))
        })
        .collect();
    found.sort_by_key(|&(t, _)| t.get());
    assert_eq!(expected.len(), 2, "both treasures are found within 300 rounds");
    assert_eq!(found, expected);
}

/// Walks east; robot 2 panics in round 10, after queueing a message.
struct Fragile;

impl Strategy for Fragile {
    fn needs(&self) -> Needs {
        Needs::NONE
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if ctx.round == 10 && ctx.me.id.get() == 2 {
            ctx.broadcast(sim_core::world::Payload::Custom {
                kind: "last words".into(),
                data: Vec::new(),
            });
            panic!("sensor fault in round {}", ctx.round);
        }
        Action::MoveTo {
            to: ctx.position() + DVec2::new(0.2, 0.0),
        }
    }
}

#[test]
fn a_panicking_strategy_disables_only_its_robot() {
    let mut registry = StrategyRegistry::with_builtins();
    registry.register("fragile", "", |_| Ok(Box::new(Fragile)));
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut s = scenario(
                rooms_map(Vec::new()),
                9,
                30,
                vec![
                    (4, RobotType::explorer(), "fragile"),
                    (2, RobotType::explorer(), "random_walk"),
                ],
            );
            s.groups[0].start = Start::At(DVec2::new(2.5, 26.5));
            let mut sim = new_sim(s, &registry).unwrap();
            let mut events = Vec::new();
            let mut trace = Trace::default();
            run_checked(&mut sim, &mut [&mut Events(&mut events), &mut trace]);
            (sim, events, trace)
        })
    };
    let (sim, events, trace) = run(2);
    // The run went on to the end; only robot 2 stopped, where it stood at the end of round 9.
    assert_eq!(sim.round(), 30);
    let failed: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            sim_core::world::Event::StrategyFailed { robot, reason } => Some((robot.get(), reason.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(
        failed,
        [(2, "its strategy panicked: sensor fault in round 10".to_owned())]
    );
    let robots = sim.robots();
    assert!(!robots[2].alive);
    assert!(robots.iter().enumerate().all(|(i, r)| r.alive == (i != 2)));
    let start = robots[2].position;
    let at_round_9 = trace.0[8].1[2];
    assert_eq!((start.x.to_bits(), start.y.to_bits()), (at_round_9.0, at_round_9.1));
    // The others walked on after round 10 (east at 0.2 m a round; robot 2 now stands in
    // the way of some, so together rather than each).
    let x = |round: usize, i: usize| f64::from_bits(trace.0[round - 1].1[i].0);
    let gained: f64 = [0, 1, 3].iter().map(|&i| x(30, i) - x(10, i)).sum();
    assert!(gained > 3.0, "the other fragile robots gained {gained} m");
    assert!(robots[4..].iter().all(|r| r.stats.distance_m > 1.0));
    let m = sim.report().metrics;
    assert_eq!((m.strategies_failed, m.robots_alive), (1, 5));
    // Its last words were not sent.
    assert_eq!(robots[2].stats.messages_sent, 0);
    // And the same on one thread.
    let (_, events_1, trace_1) = run(1);
    assert_eq!(events_1, events);
    assert_eq!(trace_1.0, trace.0);
}

/// Stands still; robot 1 thinks for 40 ms in round 3.
struct Ponderer;

impl Strategy for Ponderer {
    fn needs(&self) -> Needs {
        Needs::NONE
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if ctx.round == 3 && ctx.me.id.get() == 1 {
            std::thread::sleep(std::time::Duration::from_millis(40));
        }
        Action::Idle
    }
}

#[test]
fn a_slow_decision_is_reported_with_its_robot_and_time() {
    let mut registry = StrategyRegistry::empty();
    registry.register("ponder", "", |_| Ok(Box::new(Ponderer)));
    let run = |limit: Option<std::time::Duration>| {
        let s = scenario(rooms_map(Vec::new()), 1, 5, vec![(3, RobotType::explorer(), "ponder")]);
        let mut sim = new_sim(s, &registry).unwrap().with_decide_limit(limit);
        let mut slow = Vec::new();
        for _ in 0..5 {
            let report = sim.step();
            slow.extend(report.slow_decisions.iter().map(|&(r, t)| (report.round, r.get(), t)));
        }
        slow
    };
    let slow = run(Some(std::time::Duration::from_millis(20)));
    // Timed by the coarse clock (a tick of up to 10 ms): at least the 40 ms slept, less a tick.
    assert!(
        slow.iter()
            .any(|&(round, robot, t)| (round, robot) == (3, 1) && t >= std::time::Duration::from_millis(30)),
        "{slow:?}"
    );
    assert!(run(None).is_empty());
}

/// The state bytes of a simulation (`write_state`).
fn state_bytes(sim: &Simulation) -> Vec<u8> {
    let mut out = Vec::new();
    sim.write_state(&mut out).unwrap();
    out
}

/// A run saved after k rounds and restored into a simulation set up afresh from the same
/// scenario plays on exactly as the run that was never stopped (every round's metrics,
/// events and robot bits, and the final state byte for byte), for every built-in strategy
/// at once (`cooperative` with and without `max_detour_m`), with known maps and sightings
/// in flight and a finite radio budget, on one thread and on two.
#[test]
fn a_restored_run_plays_on_bit_for_bit() {
    const ROUNDS: u64 = 160;
    let registry = StrategyRegistry::with_builtins();
    let setup = || {
        let treasures = vec![
            TreasureSpec {
                position: DVec2::new(12.5, 30.5),
                quantity: 4,
            },
            TreasureSpec {
                position: DVec2::new(30.5, 14.5),
                quantity: 3,
            },
        ];
        let radio = RobotType::explorer().with_radio_bytes_per_round(600);
        let mut s = scenario(
            rooms_map(treasures),
            11,
            ROUNDS,
            vec![
                (5, RobotType::explorer(), "cooperative"),
                (3, radio, "cooperative"),
                (2, RobotType::explorer(), "frontier"),
                (4, RobotType::explorer(), "team"),
                (3, RobotType::explorer(), "random_walk"),
                (2, RobotType::excavator(), "excavator"),
                (2, RobotType::transporter(), "transporter"),
            ],
        );
        // A bounded detour past claimed frontiers is part of the saved state too.
        s.groups[1].params = Params::default().with("max_detour_m", "2");
        s
    };
    // Plays to round `until`; returns the messages sent.
    let play = |sim: &mut Simulation, until: u64, trace: &mut Trace| {
        let mut messages = 0;
        while sim.round() < until {
            sim.step();
            let report = sim.report().clone();
            messages += report.metrics.messages;
            trace.on_round(sim, &report).unwrap();
        }
        messages
    };
    let mut whole = Trace::default();
    let mut sim = new_sim(setup(), &registry).unwrap();
    let messages = play(&mut sim, ROUNDS, &mut whole);
    let end = state_bytes(&sim);
    let m = sim.report().metrics;
    // The run does what the checkpoint must carry: messages sent, treasures dug.
    assert!(messages > 100, "{messages} messages");
    assert!(m.units_dug > 0, "{m:?}");
    for (k, threads) in [(0, 1), (1, 2), (37, 1), (90, 2), (ROUNDS, 1)] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut first = new_sim(setup(), &registry).unwrap();
            let mut before = Trace::default();
            play(&mut first, k, &mut before);
            let saved = state_bytes(&first);
            drop(first);
            let mut resumed = new_sim(setup(), &registry).unwrap();
            resumed.read_state(&saved).unwrap();
            assert_eq!(resumed.round(), k);
            // Saving what was restored gives the same bytes: nothing is lost or reordered.
            assert_eq!(
                state_bytes(&resumed),
                saved,
                "k = {k}: the restored state saves differently"
            );
            let mut after = Trace::default();
            play(&mut resumed, ROUNDS, &mut after);
            let k = usize::try_from(k).unwrap();
            assert_eq!(before.0.len(), k);
            for (round, (a, b)) in whole.0[k..].iter().zip(&after.0).enumerate() {
                assert_eq!(a, b, "resumed after {k} rounds: round {} differs", k + round + 1);
            }
            assert_eq!(
                state_bytes(&resumed),
                end,
                "resumed after {k} rounds: the final state differs"
            );
        });
    }
}

/// A state that does not fit the scenario is refused with a reason, and a strategy that
/// cannot save its state makes the run refuse to checkpoint, naming its group.
#[test]
fn states_that_do_not_fit_are_refused() {
    let registry = StrategyRegistry::with_builtins();
    let mut sim = new_sim(
        scenario(
            rooms_map(Vec::new()),
            1,
            50,
            vec![(4, RobotType::explorer(), "cooperative")],
        ),
        &registry,
    )
    .unwrap();
    for _ in 0..20 {
        sim.step();
    }
    let saved = state_bytes(&sim);
    // Another robot count.
    let mut other = new_sim(
        scenario(
            rooms_map(Vec::new()),
            1,
            50,
            vec![(5, RobotType::explorer(), "cooperative")],
        ),
        &registry,
    )
    .unwrap();
    let e = other.read_state(&saved).unwrap_err().to_string();
    assert!(e.contains("4 robots saved, the scenario has 5"), "{e}");
    // A run shorter than the saved round.
    let mut short = new_sim(
        scenario(
            rooms_map(Vec::new()),
            1,
            10,
            vec![(4, RobotType::explorer(), "cooperative")],
        ),
        &registry,
    )
    .unwrap();
    let e = short.read_state(&saved).unwrap_err().to_string();
    assert!(e.contains("round 20 is past the run's 10 rounds"), "{e}");
    // Bytes that are not a state.
    let e = other.read_state(&saved[..saved.len() / 2]).unwrap_err().to_string();
    assert!(e.contains("does not decode"), "{e}");
    // A strategy without `save_state`.
    let cheats = new_sim(
        scenario(rooms_map(Vec::new()), 1, 10, vec![(1, RobotType::explorer(), "dig")]),
        &cheat_registry(),
    )
    .unwrap();
    let e = cheats.check_checkpointable().unwrap_err().to_string();
    assert!(e.contains("group 'g0': strategy 'dig' cannot save its state"), "{e}");
    assert!(cheats.write_state(&mut Vec::new()).is_err());
}

/// A scenario without robots (every group empty) is refused when built, not left to fail
/// in the first round.
#[test]
fn a_scenario_without_robots_is_refused() {
    let registry = StrategyRegistry::with_builtins();
    let built = ScenarioBuilder::new(rooms_map(Vec::new()))
        .with_group(Group::new("random_walk", 0, 0))
        .build(&registry);
    let err = built.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("no robots to simulate"), "{err}");
}
