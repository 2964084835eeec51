//! The greedy reference explorer against hand-worked distances.

use std::sync::Arc;

use scale::exploration::{
    GREEDY_REFERENCE, explore, explore_with, explorer_robot, indoor_maps, starting_at, starts_along_the_reference,
};
use sim_core::agent::{Params, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData};

/// A corridor 30 m × 1 m inside 0.3 m walls (free from x = 0.3 to 29.7, 0.1 m cells), the
/// robot starting at (1.5, 0.8). A cell counts as explored when it lies wholly in the 3.5 m
/// view: the corridor's cells up to √(3.5² − 0.5²) = 3.464 m ahead, less up to a cell,
/// and everything behind. 98 % of the 29.4 m is 28.812 m, seen from x ≥ 0.3 + 28.812 −
/// 3.464 + u = 25.648 + u (u < 0.1). Views come at the start of a round, after r − 1 steps
/// of 0.25 m: 1.5 + 0.25 (r − 1) ≥ 25.648 + u first holds at r − 1 = 97 (96.6 + 4u < 97),
/// so round 98, and the distance counted at its end is 98 × 0.25 = 24.5 m. A reference that
/// dithers or turns back walks more.
#[test]
fn the_reference_walks_a_corridor_straight_to_its_end() {
    let map = corridor();
    let run = explore(&map, GREEDY_REFERENCE, 1, 400).unwrap();
    let (_, d98) = run.at_98.expect("the corridor is explored");
    assert!((d98 - 24.5).abs() < 1e-6, "walked {d98} m to 98 %");
    // Straight on: nothing walked through ground already explored until then.
    assert!(run.overlap_m < 1e-9, "{run:?}");
}

/// The corridor of `the_reference_walks_a_corridor_straight_to_its_end`.
fn corridor() -> Arc<MapData> {
    let cell_m = 0.1;
    let grid = Grid::from_size_m(DVec2::ZERO, cell_m, 30.0, 1.6).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        let (px, py) = ((f64::from(x) + 0.5) * cell_m, (f64::from(y) + 0.5) * cell_m);
        !(0.3..=29.7).contains(&px) || !(0.3..=1.3).contains(&py)
    });
    Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(1.5, 0.8),
            radius_m: 0.3,
        },
        treasures: Vec::new(),
    })
}

/// In the corridor the reference walks on at 0.25 m a round from x = 1.5 until 90 % is
/// explored (round 89, by the reckoning above with 26.46 m instead of 28.812): 88 positions
/// before it, so three starts are those after rounds 23, 45 and 67, at x ≈ 7.25, 12.75
/// and 18.25 (a little less: its first legs bend towards the corridor's middle). A run
/// from a start begins there.
#[test]
fn starts_lie_evenly_along_the_references_walk() {
    let map = corridor();
    let starts = starts_along_the_reference(&map, 3, 400).unwrap();
    assert_eq!(starts.len(), 3, "{starts:?}");
    for (p, x) in starts.iter().zip([7.25, 12.75, 18.25]) {
        assert!((p.x - x).abs() < 0.01 && (0.425..=1.175).contains(&p.y), "{starts:?}");
    }
    let from = starting_at(&map, starts[2]);
    let scenario = ScenarioBuilder::new(from)
        .with_rounds(1)
        .with_types(vec![explorer_robot()])
        .with_group(Group::new("frontier", 0, 1))
        .build(&StrategyRegistry::with_builtins())
        .unwrap();
    let sim = Simulation::new(scenario).unwrap();
    assert!(sim.robots()[0].position.distance(starts[2]) <= 0.2);
}

/// Every indoor map of the comparison set is one connected region the reference explores
/// to 90 %: the table compares explorers on maps that can be explored.
#[test]
fn the_reference_explores_every_indoor_map() {
    for (name, map) in indoor_maps().unwrap() {
        let run = explore(&map, GREEDY_REFERENCE, 1, 6_000).unwrap();
        assert!(run.at_90.is_some(), "{name}: {run:?}");
    }
}

#[path = "../../tests/src/skip.rs"]
mod skip;

/// On the ROS depot map (opt-in: `SMARTTEAMS_DATA`), the reference started at (13.025,
/// 13.125) comes to press against a wall at (26.34, 4.07), where a path planned from its own
/// cell begins with the step the wall refuses. After a move that went nowhere it searches
/// from the open cells in a straight move's reach, so it leaves the wall and explores the
/// depot to 90 %; searching from its cell, it would stay there at 87.5 %.
#[test]
fn the_reference_leaves_a_wall_that_refused_its_step() {
    let Some(data) = std::env::var_os("SMARTTEAMS_DATA") else {
        skip::skip(
            "data",
            "the_reference_leaves_a_wall_that_refused_its_step",
            "SMARTTEAMS_DATA is not set",
        );
        return;
    };
    let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let maps = scale::exploration::comparison_maps(&workspace, Some(std::path::Path::new(&data))).unwrap();
    let (_, depot) = maps
        .iter()
        .find(|(name, _)| name.starts_with("depot"))
        .expect("the depot map");
    let run = explore(
        &starting_at(depot, DVec2::new(13.025, 13.125)),
        GREEDY_REFERENCE,
        1,
        3_000,
    )
    .unwrap();
    assert!(run.at_90.is_some(), "{run:?}");
}

/// A corridor cut by a wall with a 0.2 m gap, narrower than the robot's 0.25 m body: the
/// reference explores its side and stops for good where its grid has no way on, idling
/// from then on (its search, given the same place and the same known cells, finds nothing
/// again, so it is not run again; the robot stays put and learns nothing more).
#[test]
fn the_reference_stays_put_once_no_frontier_is_in_reach() {
    let cell_m = 0.1;
    let grid = Grid::from_size_m(DVec2::ZERO, cell_m, 12.0, 1.6).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        let (px, py) = ((f64::from(x) + 0.5) * cell_m, (f64::from(y) + 0.5) * cell_m);
        let wall = (6.0..6.3).contains(&px) && !(0.7..0.9).contains(&py);
        wall || !(0.3..=11.7).contains(&px) || !(0.3..=1.3).contains(&py)
    });
    let map = Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(1.5, 0.8),
            radius_m: 0.3,
        },
        treasures: Vec::new(),
    });
    let early = explore(&map, GREEDY_REFERENCE, 1, 300).unwrap();
    let late = explore(&map, GREEDY_REFERENCE, 1, 3_000).unwrap();
    assert!(early.at_90.is_none() && early.explored < 0.75, "{early:?}");
    assert_eq!(
        (late.rounds, late.distance_m, late.explored),
        (3_000, early.distance_m, early.explored)
    );
}

/// `explore_with` hands its parameters to the strategy: `frontier` with its defaults spelt
/// out walks exactly as with none, searching again only once the whole view round a seen
/// target is known (instead of 65 % of it) it walks another way, and a name it does not
/// take is an error naming it.
#[test]
fn parameters_reach_the_compared_explorer() {
    let (_, rooms) = indoor_maps().unwrap().into_iter().next().expect("an indoor map");
    let run =
        |pairs: &[(&str, &str)]| explore_with(&rooms, "frontier", &Params::from_pairs(pairs.iter().copied()), 1, 3_000);
    let plain = run(&[]).unwrap();
    let defaults = run(&[
        ("replan_within_view", "0.5"),
        ("seen_cost_views", "2"),
        ("reveal_first", "0.15"),
        ("replan_when_known", "0.65"),
        ("tour_stops", "7"),
    ])
    .unwrap();
    assert_eq!(plain, defaults);
    let later = run(&[("replan_when_known", "1")]).unwrap();
    assert_ne!(later.at_90, plain.at_90, "{later:?}");
    let unknown = run(&[("replan_within_views", "0.25")]).unwrap_err();
    assert!(
        format!("{unknown:#}").contains("unknown parameter 'replan_within_views'"),
        "{unknown:#}"
    );
}

/// On the indoor loop (a ring corridor round a block, 20 m × 20 m at 0.1 m), heading for
/// the nearest frontier leaves the ring's outer corners behind and walks back round the
/// ring for them at the end: 1.45× the greedy reference's walk to 98 %. `frontier`'s tour
/// takes them as it passes: within 1.05× of the reference.
#[test]
fn frontiers_tour_takes_the_loops_corners_on_the_way() {
    let ring = &indoor_loop();
    let to_98 = |strategy: &str, pairs: &[(&str, &str)]| {
        let params = Params::from_pairs(pairs.iter().copied());
        explore_with(ring, strategy, &params, 1, 20_000)
            .unwrap()
            .at_98
            .expect("98 % reached")
            .1
    };
    let reference = to_98(GREEDY_REFERENCE, &[]);
    let toured = to_98("frontier", &[]);
    let nearest = to_98("frontier", &[("tour_stops", "0")]);
    assert!(
        toured <= 1.05 * reference,
        "tour {toured:.1} m, reference {reference:.1} m"
    );
    assert!(
        nearest > 1.3 * reference,
        "nearest {nearest:.1} m, reference {reference:.1} m"
    );
}

/// A `frontier` robot that sees another heads for the nearest frontier for the next 50
/// rounds instead of planning tours: two robots setting out together on the indoor loop
/// walk as with `tour_stops` 0 over their first 50 rounds, while one robot alone walks
/// another way.
#[test]
fn frontier_robots_in_company_head_for_the_nearest_frontier() {
    let ring = &indoor_loop();
    let run = |robots, pairs: &[(&str, &str)]| {
        explore_with(ring, "frontier", &Params::from_pairs(pairs.iter().copied()), robots, 50).unwrap()
    };
    assert_eq!(run(2, &[]), run(2, &[("tour_stops", "0")]));
    assert_ne!(run(1, &[]), run(1, &[("tour_stops", "0")]));
}

/// Two `cooperative` robots on the rooms example map (128 m × 96 m, radios of 20 m) soon
/// part and seldom hear each other. Each keeps the other's announced goal, however far, as
/// one to stay away from, so they explore different parts rather than each other's: 90 %
/// comes at least 1.6× sooner than for one robot, and their summed walk is at most 1.25× its
/// walk.
#[test]
fn two_cooperative_robots_divide_the_rooms_map_after_they_part() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../maps/rooms.stmap");
    let rooms = Arc::new(MapData::load(&path).unwrap());
    let run = |robots| explore(&rooms, "cooperative", robots, 20_000).unwrap().at_90.unwrap();
    let ((one_rounds, one_m), (two_rounds, two_m)) = (run(1), run(2));
    let faster = one_rounds as f64 / two_rounds as f64;
    assert!(
        faster >= 1.6,
        "2 robots {two_rounds} rounds, 1 robot {one_rounds}: {faster:.2}x"
    );
    assert!(
        two_m <= 1.25 * one_m,
        "2 robots walked {two_m:.1} m, 1 robot {one_m:.1} m"
    );
}

/// Eight `cooperative` robots on the indoor loop (a 20 m ring corridor), starting packed at
/// home: more robots than the ring needs. A robot leaves a target that a mate's announced
/// walk passes, so the eight reach 90 % sooner than one robot and walk at most 1.25× its
/// distance between them.
#[test]
fn eight_cooperative_robots_on_a_loop_leave_what_a_mate_walks_past() {
    assert_eight_sooner_within_a_quarter_more(&indoor_loop());
}

/// Eight `cooperative` robots in the 1.2 m corridors of the indoor corner maze, starting
/// packed at home. Robots that leave their targets to mates wait (and step out of the way of
/// a mate held back among them) rather than follow the mates: the eight reach 90 % sooner
/// than one robot, walking at most 1.25× its distance between them.
#[test]
fn eight_cooperative_robots_in_a_maze_walk_no_more_than_one_and_a_quarter() {
    assert_eight_sooner_within_a_quarter_more(&indoor_map("indoor corner maze"));
}

/// Eight `cooperative` robots from `map`'s home reach 90 % explored in fewer rounds than one,
/// walking at most 1.25× its distance between them.
fn assert_eight_sooner_within_a_quarter_more(map: &Arc<MapData>) {
    let run = |robots| explore(map, "cooperative", robots, 20_000).unwrap().at_90.unwrap();
    let ((one_rounds, one_m), (eight_rounds, eight_m)) = (run(1), run(8));
    assert!(
        eight_rounds < one_rounds,
        "8 robots {eight_rounds} rounds, 1 robot {one_rounds}"
    );
    assert!(
        eight_m <= 1.25 * one_m,
        "8 robots walked {eight_m:.1} m, 1 robot {one_m:.1} m"
    );
}

/// The indoor loop of the exploration maps: a ring corridor round a block, 20 m × 20 m at
/// 0.1 m.
fn indoor_loop() -> Arc<MapData> {
    indoor_map("indoor loop")
}

/// The indoor map of the exploration maps called `name`.
fn indoor_map(name: &str) -> Arc<MapData> {
    let (_, map) = indoor_maps()
        .unwrap()
        .into_iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no indoor map {name}"));
    map
}
