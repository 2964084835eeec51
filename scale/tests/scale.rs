//! The scale scenarios at a reduced size, so that they keep working (timings belong to
//! `smartteams-bench`, not here).

use scale::{RandomWalk, measure};
use sim_core::engine::Simulation;

fn small_walk() -> RandomWalk {
    RandomWalk {
        robots: 150,
        side_m: 128.0,
        home_radius_m: 8.0,
        ..RandomWalk::default()
    }
}

#[test]
fn random_walk_gives_the_same_result_on_one_and_two_threads() {
    let one = measure(small_walk().scenario().unwrap(), 40, 1).unwrap();
    let two = measure(small_walk().scenario().unwrap(), 40, 2).unwrap();
    assert_eq!(one.digest, two.digest);
    assert_eq!(one.explored_fraction.to_bits(), two.explored_fraction.to_bits());
    assert_eq!((one.robots, one.rounds), (150, 40));
    // 150 walkers of 0.5 m steps for 40 rounds saw more than their 8 m home.
    assert!(one.explored_fraction > 0.02, "{}", one.explored_fraction);
}

#[test]
fn walkers_build_no_navigation_graph() {
    let mut sim = Simulation::new(small_walk().scenario().unwrap()).unwrap();
    for _ in 0..20 {
        sim.step();
    }
    // No walker plans a route, so the graph (seconds on a big map) is never built.
    assert!(sim.nav_if_built().is_none());
    // The map is white noise of density 0.3 outside home, so walkers have been held back.
    assert!(sim.robots().iter().all(|r| r.stats.distance_m > 0.0));
    // Asked for, it is built then.
    assert!(!sim.nav().is_empty());
    assert!(sim.nav_if_built().is_some());
}

#[test]
fn the_walker_map_keeps_home_clear_and_has_the_density_asked_for() {
    let scenario = small_walk().scenario().unwrap();
    let sim = Simulation::new(scenario).unwrap();
    let obstacles = sim.obstacles();
    let home = sim.map().home.center();
    assert!(obstacles.is_disc_free(home, 8.0));
    let blocked = obstacles.tree().count_cells(true) as f64;
    let cells = 128.0 * 128.0;
    // 0.3 of the cells outside the cleared disc of 9.5 m (≈ 284 cells).
    let expected = 0.3 * (cells - 284.0);
    assert!((blocked - expected).abs() < 0.03 * expected, "{blocked} vs {expected}");
}

#[test]
fn the_swarm_gives_the_same_result_on_one_and_two_threads_and_stays_within_its_radios() {
    let swarm = scale::Swarm {
        robots: 120,
        side_m: 2_000.0,
        mesas: 60,
        mesa_scale_m: 40.0,
        treasures: 20,
        radio_bytes_per_round: 2_000,
        ..scale::Swarm::default()
    };
    let one = measure(swarm.scenario().unwrap(), 30, 1).unwrap();
    let two = measure(swarm.scenario().unwrap(), 30, 2).unwrap();
    assert_eq!(one.digest, two.digest);
    assert_eq!(one.robots, 120);
    let mut sim = Simulation::new(swarm.scenario().unwrap()).unwrap();
    for _ in 0..10 {
        sim.step();
        for inbox in sim.pending_messages() {
            let bytes: u64 = inbox.iter().map(|m| m.payload.size_bytes()).sum();
            assert!(bytes <= 2_000, "{bytes} bytes received in a round");
        }
    }
}

/// Fig. 4 at a reduced size: the shape the paper reports holds (memory flattens in time
/// and grows with the number of robots), and the CSV files say what was measured.
#[test]
fn fig4_small_has_the_papers_shape_and_writes_its_csv() {
    let fig = scale::fig4::Fig4 {
        side_m: 256.0,
        mesas: 20,
        robots_over_time: 10,
        rounds: 300,
        every: 10,
        robot_counts: vec![5, 10, 20],
        rounds_before_count: 20,
        explored_counts: vec![2, 8],
        explored_rounds: 100,
        seed: 3,
    };
    let data = fig.run(|_| {}).unwrap();
    assert_eq!(data.memory_over_time.len(), 31);
    // Memory grows fast while robots leave home, far slower once explored parts merge:
    // the last 100 rounds add less than the first 100 did.
    let at = |round: u64| data.memory_over_time.iter().find(|p| p.0 == round).unwrap().1 as f64;
    assert!(at(300) - at(200) < at(100) - at(0), "{:?}", data.memory_over_time);
    // More robots hold more known maps after the same number of rounds.
    let by: Vec<usize> = data.memory_by_robots.iter().map(|p| p.1).collect();
    assert!(by[0] < by[1] && by[1] < by[2], "{by:?}");
    // More robots explore more.
    let last = |i: usize| data.explored[i].1.last().unwrap().1;
    assert!(last(0) < last(1));
    let dir = std::env::temp_dir().join(format!("smartteams-fig4-{}", std::process::id()));
    let written = data.write(&dir, false).unwrap();
    assert_eq!(written.len(), 3);
    let robots_csv = std::fs::read_to_string(dir.join("memory-vs-robots.csv")).unwrap();
    assert_eq!(robots_csv.lines().count(), 4);
    assert!(robots_csv.starts_with("robots,known_map_bytes,bytes_per_robot,kernel_map_bytes\n5,"));
    std::fs::remove_dir_all(&dir).unwrap();
}
