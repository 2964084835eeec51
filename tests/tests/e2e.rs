//! End-to-end runs through the same library calls as `smartteams run`, on the committed
//! example maps and configs, and the config errors a user sees.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::Parser;
use sim_core::agent::StrategyRegistry;
use sim_core::engine::Simulation;
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData, RobotType};
use viewer_bridge::cli::{Cli, Command, RunArgs};
use viewer_bridge::run::execute;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("smartteams-e2e-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `smartteams run CONFIG --quiet --no-viewer EXTRA…`, parsed exactly as the binary does.
fn args(config: &Path, extra: &[&str]) -> RunArgs {
    let mut argv: Vec<String> = vec!["smartteams".into(), "run".into(), config.display().to_string()];
    argv.extend(["--quiet", "--no-viewer"].iter().chain(extra).map(ToString::to_string));
    match Cli::try_parse_from(argv).unwrap_or_else(|e| panic!("{e}")).command {
        Command::Run(a) => a,
        other => panic!("parsed {other:?}"),
    }
}

#[test]
fn the_demo_config_runs_and_writes_its_csv_outputs() {
    let dir = scratch("demo");
    let registry = StrategyRegistry::with_builtins();
    let (m, r) = (dir.join("m.csv"), dir.join("r.csv"));
    let run = args(
        &repo().join("configs/demo.xml"),
        &[
            "--rounds",
            "60",
            "--metrics",
            m.to_str().unwrap(),
            "--robot-stats",
            r.to_str().unwrap(),
        ],
    )
    .resolve()
    .unwrap();
    // The declared type is the explorer preset with the two attributes overridden.
    let scout = RobotType::explorer().with_view_radius_m(6.0).with_comm_radius_m(25.0);
    assert_eq!(
        run.config.types.last(),
        Some(&RobotType {
            name: "scout".into(),
            ..scout
        })
    );
    let summary = execute(&run, &registry, &mut []).unwrap();
    assert_eq!(summary.rounds, 60);
    let metrics = std::fs::read_to_string(dir.join("m.csv")).unwrap();
    let mut lines = metrics.lines();
    let header = lines.next().unwrap();
    for column in [
        "round",
        "explored_fraction",
        "treasures_found",
        "treasures_excavated",
        "treasures_delivered",
        "robots_alive",
        "mean_energy",
        "messages",
        "distance_m",
    ] {
        assert!(
            header.split(',').any(|c| c == column),
            "missing column {column} in {header}"
        );
    }
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 60);
    for (i, row) in rows.iter().enumerate() {
        assert!((row[0] - (i + 1) as f64).abs() < 1e-9, "round column {}", row[0]);
        assert!((0.0..=1.0).contains(&row[1]));
        if i > 0 {
            // Knowledge and distance only grow.
            assert!(row[1] >= rows[i - 1][1] && row[8] >= rows[i - 1][8]);
        }
    }
    assert!(rows[59][1] > rows[0][1], "nothing explored");
    let robots = std::fs::read_to_string(dir.join("r.csv")).unwrap();
    assert_eq!(robots.lines().count(), 1 + 20, "header + 20 robots");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn same_seed_same_csv_whatever_the_thread_count() {
    let dir = scratch("threads");
    let registry = StrategyRegistry::with_builtins();
    let csv = |threads: usize, turns: &str| {
        let out = dir.join(format!("m{threads}-{turns}.csv"));
        let t = threads.to_string();
        let run = args(
            &repo().join("configs/demo.xml"),
            &[
                "--rounds",
                "80",
                "--threads",
                &t,
                "--turns",
                turns,
                "--metrics",
                out.to_str().unwrap(),
            ],
        )
        .resolve()
        .unwrap();
        execute(&run, &registry, &mut []).unwrap();
        std::fs::read(out).unwrap()
    };
    let one = csv(1, "auto");
    assert_eq!(one, csv(2, "auto"));
    // Turns side by side, on two threads and on one: the same rows.
    assert_eq!(one, csv(2, "side-by-side"));
    assert_eq!(one, csv(1, "side-by-side"));
    assert_eq!(one, csv(2, "in-order"));
    std::fs::remove_dir_all(dir).unwrap();
}

fn config_error(xml: &str, dir: &Path) -> String {
    let path = dir.join("bad.xml");
    std::fs::write(&path, xml).unwrap();
    let registry = StrategyRegistry::with_builtins();
    let result = args(&path, &[])
        .resolve()
        .and_then(|run| execute(&run, &registry, &mut []));
    format!("{:#}", result.expect_err("config should be refused"))
}

/// A 20 m map with a wall at x ∈ [5, 6), saved in `dir`.
fn small_map(dir: &Path) -> PathBuf {
    let grid = Grid::new(DVec2::ZERO, 1.0, 20, 20).unwrap();
    let map = MapData {
        obstacles: ObstacleMap::from_fn(grid, |x, _| x == 5),
        home: HomeBase::Disc {
            center: DVec2::new(10.0, 10.0),
            radius_m: 1.0,
        },
        treasures: Vec::new(),
    };
    let path = dir.join("small.stmap");
    map.save(&path).unwrap();
    path
}

#[test]
fn config_errors_name_file_line_column_and_what_was_expected() {
    let dir = scratch("errors");
    small_map(&dir);
    let group = r#"<group count="2" type="explorer" strategy="frontier"/>"#;

    // Malformed: <group> never closed; the mismatch is found on line 4.
    let e = config_error(
        "<simulation rounds=\"5\">\n  <map file=\"small.stmap\"/>\n  <group count=\"2\" type=\"explorer\" strategy=\"frontier\">\n</simulation>\n",
        &dir,
    );
    assert!(e.contains("bad.xml:4:"), "{e}");
    assert!(e.contains("malformed XML"), "{e}");

    // Unknown strategy on line 3: the known ones are listed.
    let e = config_error(
        "<simulation>\n  <map file=\"small.stmap\"/>\n  <group count=\"2\" type=\"explorer\" strategy=\"frontir\"/>\n</simulation>",
        &dir,
    );
    assert!(e.contains("bad.xml:3:3"), "{e}");
    assert!(
        e.contains(
            "unknown strategy 'frontir' (known: cooperative, excavator, frontier, random_walk, tactics, team, transporter)"
        ),
        "{e}"
    );

    // An unknown tactic in a composed strategy, listing the known ones.
    let e = config_error(
        "<simulation>\n  <map file=\"small.stmap\"/>\n  <group count=\"2\" type=\"explorer\" strategy=\"tactics\">\n    <param name=\"tactics\" value=\"collision,jump\"/>\n  </group>\n</simulation>",
        &dir,
    );
    assert!(e.contains("bad.xml:3:3"), "{e}");
    assert!(
        e.contains("strategy 'tactics': unknown tactic 'jump' (known: boundary, collision, energy, frontier, shortest_path, team)"),
        "{e}"
    );

    // Unknown robot type, listing the known ones.
    let e = config_error(
        &format!(
            "<simulation>\n<map file=\"small.stmap\"/>\n{}\n</simulation>",
            group.replace("explorer", "digger")
        ),
        &dir,
    );
    assert!(
        e.contains("unknown robot type 'digger' (known: explorer, excavator, transporter)"),
        "{e}"
    );

    // Negative radius, on the robot type's line.
    let e = config_error(
        &format!(
            "<simulation>\n<map file=\"small.stmap\"/>\n<robot-type name=\"bad\" radius_m=\"-1\"/>\n{group}\n</simulation>"
        ),
        &dir,
    );
    assert!(
        e.contains("bad.xml:3:1") && e.contains("radius_m must be a finite number > 0, got -1"),
        "{e}"
    );

    // An attribute that no robot type has, listing those it has.
    let e = config_error(
        &format!(
            "<simulation>\n<map file=\"small.stmap\"/>\n<robot-type name=\"bad\" base=\"explorer\" colour=\"red\"/>\n{group}\n</simulation>"
        ),
        &dir,
    );
    assert!(
        e.contains("bad.xml:3:1")
            && e.contains("robot type 'bad': unknown robot-type attribute 'colour'")
            && e.contains("view_radius_m"),
        "{e}"
    );

    // Not a number.
    let e = config_error(
        &format!("<simulation seed=\"lots\">\n<map file=\"small.stmap\"/>\n{group}\n</simulation>"),
        &dir,
    );
    assert!(
        e.contains("bad.xml:1:1") && e.contains("seed must be a whole number ≥ 0, got 'lots'"),
        "{e}"
    );

    // A start inside the wall at x ∈ [5, 6).
    let e = config_error(
        &format!(
            "<simulation>\n<map file=\"small.stmap\"/>\n{}\n</simulation>",
            group.replace("/>", " start=\"5.5,10\"/>")
        ),
        &dir,
    );
    assert!(
        e.contains("bad.xml:3:1") && e.contains("starts at (5.5, 10), which is inside an obstacle"),
        "{e}"
    );

    // A missing map file, on the <map> line.
    let e = config_error(
        &format!("<simulation>\n  <map file=\"nope.stmap\"/>\n{group}\n</simulation>"),
        &dir,
    );
    assert!(
        e.contains("bad.xml:2:3") && e.contains("nope.stmap does not exist"),
        "{e}"
    );

    // An unknown element or attribute is refused, naming it.
    let e = config_error(
        &format!("<simulation>\n<map file=\"small.stmap\" scale=\"2\"/>\n{group}\n</simulation>"),
        &dir,
    );
    assert!(e.contains("bad.xml") && e.contains("scale"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_corrupt_map_file_is_a_clear_error() {
    let dir = scratch("corrupt");
    let map = small_map(&dir);
    let mut bytes = std::fs::read(&map).unwrap();
    let n = bytes.len();
    bytes.truncate(n - 7);
    std::fs::write(&map, bytes).unwrap();
    let e = config_error(
        "<simulation>\n<map file=\"small.stmap\"/>\n<group count=\"1\" type=\"explorer\" strategy=\"frontier\"/>\n</simulation>",
        &dir,
    );
    assert!(e.contains("small.stmap") && e.contains("truncated"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Rounds until `count` robots running `strategy` have explored 95 % of the example rooms
/// map (128 m × 96 m, walls with doors), or `None` within `budget` rounds.
fn rounds_to_explore_rooms(strategy: &str, count: u32, budget: u64) -> Option<u64> {
    let map = Arc::new(MapData::load(&repo().join("maps/rooms.stmap")).unwrap());
    let registry = StrategyRegistry::with_builtins();
    let scenario = sim_core::engine::ScenarioBuilder::new(map)
        .with_name("rooms")
        .with_seed(1)
        .with_rounds(budget)
        .with_types(vec![sim_core::world::RobotType::explorer()])
        .with_group(sim_core::engine::Group::new(strategy, 0, count).with_name("explorers"))
        .build(&registry)
        .unwrap();
    let mut sim = Simulation::new(scenario).unwrap();
    while sim.round() < budget {
        if sim.step().metrics.explored_fraction >= 0.95 {
            return Some(sim.round());
        }
    }
    None
}

#[test]
fn frontier_exploration_covers_the_example_rooms_map() {
    // One frontier explorer: ≥ 95 % within 3,000 rounds.
    let one = rounds_to_explore_rooms("frontier", 1, 3000);
    assert!(one.is_some(), "frontier x1 did not reach 95 % in 3000 rounds");
    // Eight cooperative explorers (frontiers + shared maps + claimed goals): within 1,000.
    let eight = rounds_to_explore_rooms("cooperative", 8, 1000);
    assert!(eight.is_some(), "cooperative x8 did not reach 95 % in 1000 rounds");
    eprintln!("rooms map, 95 %: frontier x1 after {one:?} rounds, cooperative x8 after {eight:?}");
}
