//! `smartteams run` as a user types it: scenario errors a new user runs into, each refused
//! before the run with the place that caused it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Write `xml` as a config beside the demo map's folder and run it headless.
fn run_config(name: &str, xml: &str, extra: &[&str]) -> (bool, String) {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join(name);
    let map = workspace().join("maps/demo.stmap");
    std::fs::write(&config, xml.replace("MAP", &map.display().to_string())).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .arg("run")
        .arg(&config)
        .args(["--no-viewer", "-q"])
        .args(extra)
        .current_dir(dir.path())
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn a_crowd_that_cannot_fit_at_home_is_refused_at_once() {
    let started = Instant::now();
    let (ok, err) = run_config("crowd.xml", &random_walkers(100_000_000, 5), &[]);
    assert!(!ok, "a crowd of 10^8 robots was accepted");
    // The demo map is 128 m × 128 m: 16,384 m², and explorer discs of radius 0.125 m
    // cover 0.049 m² each, so at most 16,384 / 0.0491 ≈ 333,772 fit even with no walls.
    assert!(err.contains("crowd.xml:3:3"), "{err}");
    assert!(err.contains("100000000 robots start around"), "{err}");
    let at_most: u64 = err
        .split("at most ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no 'at most N' in: {err}"));
    assert!(at_most > 0 && at_most <= 333_772, "{err}");
    // Refused before anything is built for each robot, so at once.
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "took {:?}",
        started.elapsed()
    );
}

#[test]
fn team_with_a_huge_timeout_is_refused_with_its_range() {
    let (ok, err) = run_config(
        "team.xml",
        r#"<simulation rounds="5">
  <map file="MAP"/>
  <group name="t" count="4" type="explorer" strategy="team">
    <param name="timeout_rounds" value="18446744073709551615"/>
  </group>
</simulation>"#,
        &[],
    );
    assert!(!ok);
    assert!(
        err.contains("team.xml:3:3") && err.contains("timeout_rounds") && err.contains("[0, 1000000000]"),
        "{err}"
    );
    // Found as the run is set up, the error names the file once, with its place.
    assert_eq!(err.matches("team.xml").count(), 1, "{err}");
}

/// The largest timeout the range allows: the run works, through the binary, and the team
/// really forms: every follower joins robot 0's group, never leaves it (the leader is heard
/// every round), and keeps near its slot, `spacing_m` (2 m) from where the leader was.
#[test]
fn team_with_the_largest_timeout_forms_and_keeps_its_group() {
    let xml = r#"<simulation rounds="60">
  <map file="MAP"/>
  <group name="t" count="4" type="explorer" strategy="team">
    <param name="timeout_rounds" value="1000000000"/>
  </group>
</simulation>"#;
    let (ok, err) = run_config("team.xml", xml, &[]);
    assert!(ok, "{err}");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("team.xml");
    let map = workspace().join("maps/demo.stmap");
    std::fs::write(&path, xml.replace("MAP", &map.display().to_string())).unwrap();
    let config = sim_core::io::SimConfig::load(&path).unwrap();
    let registry = sim_core::agent::StrategyRegistry::with_builtins();
    let mut sim = sim_core::engine::Simulation::new(config.scenario(&registry).unwrap()).unwrap();
    let (mut joined, mut left) = (Vec::new(), Vec::new());
    let mut distances_m = vec![Vec::new(); 3];
    while sim.round() < sim.total_rounds() {
        sim.step();
        for e in &sim.report().events {
            match *e {
                sim_core::world::Event::GroupJoined { robot, leader } => joined.push((robot.get(), leader.get())),
                sim_core::world::Event::GroupLeft { robot, leader } => left.push((robot.get(), leader.get())),
                _ => {}
            }
        }
        if sim.round() > 20 {
            let leader = sim.robots()[0].position;
            for (d, r) in distances_m.iter_mut().zip(&sim.robots()[1..]) {
                d.push(r.position.distance(leader));
            }
        }
    }
    joined.sort_unstable();
    assert_eq!(joined, [(1, 0), (2, 0), (3, 0)], "group events");
    assert!(left.is_empty(), "left: {left:?}");
    // A slot is 2 m from the leader's announced place, which is at most one round's move
    // (1 m for an explorer) old; a follower settles within a quarter of the spacing of it.
    // Rocks hold a follower back now and then, so this holds for most rounds: the median.
    for (i, d) in distances_m.iter_mut().enumerate() {
        d.sort_by(f64::total_cmp);
        let median = d[d.len() / 2];
        assert!(
            median <= 2.0 + 1.0 + 0.5,
            "follower {}: median {median:.2} m from its leader",
            i + 1
        );
    }
}

#[test]
fn a_bad_map_argument_is_named_as_the_argument() {
    let (ok, err) = run_config(
        "demo.xml",
        r#"<simulation rounds="5">
  <map file="MAP"/>
  <group count="1" type="explorer" strategy="random_walk"/>
</simulation>"#,
        &["--map", "no-such-map.stmap"],
    );
    assert!(!ok);
    assert!(err.contains("--map no-such-map.stmap: map file"), "{err}");
    assert!(!err.contains("demo.xml:2"), "blamed the XML for the argument: {err}");
}

/// `smartteams tactics` lists the tactics by name, and the shipped config that composes
/// strategies of them runs through the binary: the explorers explore and come home to
/// recharge, the courier gets to its corner and stays there.
#[test]
fn tactics_listed_and_composed_by_name_in_a_config() {
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .arg("tactics")
        .output()
        .unwrap();
    let listed = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    for name in ["collision", "energy", "boundary", "shortest_path", "frontier", "team"] {
        assert!(
            listed.lines().any(|l| l.starts_with(name)),
            "{name} not listed:\n{listed}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .arg("run")
        .arg(workspace().join("configs/tactics.xml"))
        .args(["--no-viewer", "-q", "--robot-stats", "robots.csv", "--metrics", "m.csv"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats = std::fs::read_to_string(dir.path().join("robots.csv")).unwrap();
    let rows: Vec<Vec<&str>> = stats.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8);
    // robot, group, type, strategy, alive, distance_m, explored_m2, …, energy_used (10), …
    for r in &rows {
        assert_eq!(r[3], "tactics");
        assert_eq!(r[4], "true", "{r:?}");
    }
    // The explorers used more than a tank (300) each: they recharged on the way.
    for r in rows.iter().filter(|r| r[1] == "explorers") {
        let used: f64 = r[10].parse().unwrap();
        assert!(used > 300.0, "{r:?}");
    }
    // The courier's corner is 89 m away by the shortest path; round obstacles through the
    // unknown it walks more, then it stops there (600 rounds at 1 m would be 600 m).
    let courier = rows.iter().find(|r| r[1] == "courier").unwrap();
    let walked: f64 = courier[5].parse().unwrap();
    assert!((89.0..200.0).contains(&walked), "{courier:?}");
    let metrics = std::fs::read_to_string(dir.path().join("m.csv")).unwrap();
    let last = metrics.lines().last().unwrap();
    let explored: f64 = last.split(',').nth(1).unwrap().parse().unwrap();
    assert!(explored > 0.5, "{last}");
}

/// `count` random-walking explorers on the demo map for `rounds` rounds (their group on
/// line 3, column 3).
fn random_walkers(count: u64, rounds: u64) -> String {
    format!(
        r#"<simulation rounds="{rounds}">
  <map file="MAP"/>
  <group name="g" count="{count}" type="explorer" strategy="random_walk"/>
</simulation>"#
    )
}

/// One explorer on the demo map for `rounds` rounds.
fn one_explorer(rounds: u64) -> String {
    random_walkers(1, rounds)
}

#[test]
fn a_config_without_robots_is_refused_at_its_group() {
    let (ok, err) = run_config("none.xml", &random_walkers(0, 5), &[]);
    assert!(!ok);
    assert!(
        err.contains("none.xml:3:3: no robots to simulate: every <group> has count 0"),
        "{err}"
    );
}

/// Output files that cannot be written are refused before the first round, with the file
/// named: the rounds of a long run would otherwise be played for nothing.
#[test]
fn outputs_that_cannot_be_written_are_refused_before_the_first_round() {
    let cases: [(&[&str], &str); 3] = [
        (
            &["--robot-stats", "no/such/folder/r.csv"],
            "cannot create robot stats file no/such/folder/r.csv",
        ),
        (
            &["--checkpoint", "no/such/folder/c.ckpt"],
            "cannot write the checkpoint no/such/folder/c.ckpt: the folder no/such/folder does not exist",
        ),
        (&["--threads", "100000"], "--threads must be from 1 to 1024, got 100000"),
    ];
    for (args, expected) in cases {
        let kept = tempfile::tempdir().unwrap();
        let metrics = kept.path().join("m.csv");
        let mut all = vec!["--metrics", metrics.to_str().unwrap()];
        all.extend_from_slice(args);
        let (ok, err) = run_config("long.xml", &one_explorer(2000), &all);
        assert!(!ok && err.contains(expected), "{args:?}: {err}");
        // No round was played: the metrics CSV, if made, holds no row.
        let rows = std::fs::read_to_string(&metrics).map_or(0, |t| t.lines().count().saturating_sub(1));
        assert_eq!(rows, 0, "{args:?}: rounds were played");
    }
}

/// `view MAP` without a viewer option writes `<map>-map.rrd`, leaving a run's recording of
/// the same name (`demo.rrd` of `configs/demo.xml` on `maps/demo.stmap`) as it was.
#[test]
fn view_writes_its_own_recording_beside_a_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("demo.rrd"), b"a run's recording").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .arg("view")
        .arg(workspace().join("maps/demo.stmap"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        std::fs::read(dir.path().join("demo.rrd")).unwrap(),
        b"a run's recording"
    );
    assert!(std::fs::metadata(dir.path().join("demo-map.rrd")).unwrap().len() > 0);
}

/// The summary names the files the run wrote, the checkpoint of its end among them, also
/// when the run is shorter than `--checkpoint-every`.
#[test]
fn the_summary_names_the_files_written() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("one.xml");
    let map = workspace().join("maps/demo.stmap");
    std::fs::write(&config, one_explorer(20).replace("MAP", &map.display().to_string())).unwrap();
    let summary = |every: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
            .arg("run")
            .arg(&config)
            .args(["--no-viewer", "--metrics", "m.csv", "--robot-stats", "r.csv"])
            .args(["--checkpoint", "c.ckpt", "--checkpoint-every", every])
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let written = |summary: &str| summary.lines().find(|l| l.starts_with("  written ")).map(str::to_owned);
    // Every 10 rounds of 20, and every 100: the run's end is written either way.
    for every in ["10", "100"] {
        let said = summary(every);
        assert_eq!(
            written(&said).as_deref(),
            Some("  written           metrics m.csv, robot stats r.csv, checkpoint c.ckpt"),
            "{said}"
        );
        let checkpoint = sim_core::io::Checkpoint::read(&dir.path().join("c.ckpt")).unwrap();
        assert_eq!(checkpoint.round(), 20, "every {every}");
        std::fs::remove_file(dir.path().join("c.ckpt")).unwrap();
    }
}

/// Tactics that only follow a goal, with no goal given and none to set one (alone or with
/// tactics that only react), are refused: the robots would stand still.
#[test]
fn goal_following_tactics_without_a_goal_are_refused() {
    let config = |params: &str| {
        format!(
            r#"<simulation rounds="5">
  <map file="MAP"/>
  <group name="g" count="1" type="explorer" strategy="tactics">{params}</group>
</simulation>"#
        )
    };
    let (ok, err) = run_config("t.xml", &config(r#"<param name="tactics" value="boundary"/>"#), &[]);
    assert!(!ok, "accepted");
    assert!(
        err.contains("t.xml:3:3") && err.contains("tactics boundary go to a goal and none sets one"),
        "{err}"
    );
    // Tactics that only react (to mates too near, to a low battery) set no goal either.
    let reacting = r#"<param name="tactics" value="collision,shortest_path,energy,boundary"/>"#;
    let (ok, err) = run_config("t.xml", &config(reacting), &[]);
    assert!(!ok, "accepted");
    assert!(
        err.contains("tactics collision, shortest_path, energy, boundary go to a goal and none sets one"),
        "{err}"
    );
    let with_goal = r#"<param name="tactics" value="boundary"/><param name="goal" value="70,70"/>"#;
    let (ok, err) = run_config("t.xml", &config(with_goal), &[]);
    assert!(ok, "{err}");
}

/// A negative count is refused as a bad value of its option, not as an unknown option.
#[test]
fn negative_numbers_are_bad_values_of_their_option() {
    let (ok, err) = run_config("one.xml", &one_explorer(5), &["--rounds", "-5"]);
    assert!(!ok);
    assert!(err.contains("invalid value '-5' for '--rounds"), "{err}");
}

/// Outputs that name one file twice, or the run's config or map, or a recording that names
/// a folder, are refused before anything is written: the other output is not lost, and the config and the map keep
/// their bytes.
#[test]
fn outputs_that_would_overwrite_each_other_or_an_input_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for file in ["configs/demo.xml", "maps/demo.stmap"] {
        std::fs::create_dir_all(d.join(file).parent().unwrap()).unwrap();
        std::fs::copy(workspace().join(file), d.join(file)).unwrap();
    }
    let before = |file: &str| std::fs::read(d.join(file)).unwrap();
    let (config, map) = (before("configs/demo.xml"), before("maps/demo.stmap"));
    let cases: [(&[&str], &str); 4] = [
        (&["--rrd", "maps"], "cannot write the recording maps: it is a folder"),
        (
            &["--no-viewer", "--metrics", "same.csv", "--robot-stats", "./same.csv"],
            "the metrics file and the robot stats file are both ./same.csv",
        ),
        (
            &["--rrd", "configs/demo.xml"],
            "the recording configs/demo.xml is the run's config",
        ),
        (
            &["--no-viewer", "--metrics", "configs/../maps/demo.stmap"],
            "the metrics file configs/../maps/demo.stmap is the run's map",
        ),
    ];
    for (args, expected) in cases {
        let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
            .args(["run", "configs/demo.xml", "--rounds", "3", "-q"])
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(expected), "{args:?}: {err}");
    }
    assert!(!d.join("same.csv").exists(), "an output was written");
    assert_eq!(before("configs/demo.xml"), config, "the config changed");
    assert_eq!(before("maps/demo.stmap"), map, "the map changed");
}

/// Output to a reader that has gone (`smartteams strategies | head -1`) ends the command
/// quietly, where `println!` panicked.
#[test]
fn a_reader_that_has_gone_ends_a_listing_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .arg("strategies")
        .stdout(writer)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.is_empty(), "{:?}: {err}", out.status);
}
