//! `smartteams-bench` as a user types it, at sizes that finish at once.

use std::process::Command;

fn bench(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_smartteams-bench"))
        .args(args)
        .output()
        .expect("the bench binary runs")
}

#[test]
fn random_walk_prints_its_measurement() {
    let out = bench(&[
        "random-walk",
        "--robots",
        "20",
        "--side-m",
        "64",
        "--rounds",
        "3",
        "--threads",
        "1",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.starts_with("random-walk: 20 robots, ") && text.contains(" 3 rounds |") && text.contains("rounds/s"),
        "{text}"
    );
}

/// The kernel scenario reports the explorers' planning time per robot-round (the navigation
/// target's measure); 30 explorers for 30 rounds plan a few frontier routes.
#[test]
fn kernel_prints_its_planning_time_per_robot_round() {
    let out = bench(&["kernel", "--robots", "30", "--rounds", "30", "--threads", "2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("kernel: 30 robots, "), "{text}");
    let per_robot_round: f64 = text
        .split("s, ")
        .find_map(|part| part.strip_suffix(" µs per robot-round\n"))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no planning time in {text}"));
    assert!(per_robot_round > 0.0 && per_robot_round < 10_000.0, "{text}");
}

#[test]
fn swarm_csv_row_has_every_column_and_threads_do_not_change_it() {
    let row = |threads: &str| {
        let out = bench(&[
            "swarm",
            "--robots",
            "40",
            "--side-m",
            "1000",
            "--mesas",
            "20",
            "--rounds",
            "5",
            "--threads",
            threads,
            "--csv-row",
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout)
            .trim()
            .split(',')
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    let (one, two) = (row("1"), row("2"));
    assert_eq!(one.len(), scale::Measurement::COLUMNS.len());
    assert_eq!((one[0].as_str(), one[2].as_str()), ("40", "5"));
    assert_eq!(one[9], two[9], "digests differ between 1 and 2 threads");
}

#[test]
fn a_swarm_that_cannot_fit_at_home_is_a_clear_error() {
    // A 40 m map holds some tens of thousands of 0.125 m robots, not 100,000.
    let out = bench(&[
        "swarm",
        "--robots",
        "100000",
        "--side-m",
        "40",
        "--mesas",
        "1",
        "--home-radius-m",
        "3",
        "--rounds",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: ") && err.contains("at most"), "{err}");
}

/// The scaling report runs the scenario at each thread count asked, with one digest, and
/// its steps' times add up to the round's (the partition is the report's invariant).
#[test]
fn scaling_report_lists_every_thread_count_and_one_digest() {
    let out = bench(&[
        "--rounds",
        "40",
        "--threads",
        "1,2",
        "scaling",
        "random-walk",
        "--robots",
        "1000",
        "--side-m",
        "256",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("in every run"), "{text}");
    assert!(text.contains("1 thr (s)") && text.contains("2 thr (s)"), "{text}");
    assert!(text.contains("1 -> 2 threads: "), "{text}");
    let share: f64 = text
        .split("s = ")
        .nth(1)
        .and_then(|rest| rest.split(" %").next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no sequential share in {text}"));
    assert!((0.0..=100.0).contains(&share), "{text}");
    // The first figure of each row is the one-thread time.
    let first_figure = |line: &str| line.split_whitespace().find_map(|w| w.parse::<f64>().ok());
    let steps: f64 = text
        .lines()
        .filter(|l| l.ends_with("one thread") || l.ends_with("all workers"))
        .filter_map(first_figure)
        .sum();
    let wall = text
        .lines()
        .find(|l| l.trim_start().starts_with("round (wall)"))
        .and_then(first_figure)
        .unwrap_or_else(|| panic!("no round time in {text}"));
    // Each of the 10 rows is rounded to the millisecond.
    assert!(
        steps <= wall + 0.006 && steps >= wall * 0.8 - 0.006,
        "{steps} against {wall}: {text}"
    );
}

/// Alternated, the scaling report plays each thread count with each way of sharing turns
/// asked, in turn, to the same digest: side by side and in id order give one outcome.
#[test]
fn alternated_scaling_compares_ways_of_sharing_turns_with_one_digest() {
    let out = bench(&[
        "--rounds",
        "200",
        "--threads",
        "2",
        "scaling",
        "--alternate",
        "30",
        "--turns",
        "in-order,side-by-side",
        "random-walk",
        "--robots",
        "1000",
        "--side-m",
        "256",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(text.contains("in every run"), "{text}");
    assert!(
        text.contains("2 thr in-order (s)") && text.contains("2 thr side-by-side (s)"),
        "{text}"
    );
    assert!(text.contains("2 thr in-order -> 2 thr side-by-side: "), "{text}");
    assert_eq!(err.matches("alternated every 30 rounds").count(), 2, "{err}");
    // Side by side, step 3's turns are shared out; in id order they are not.
    let row = |name: &str| -> Vec<f64> {
        text.lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no {name} row in {text}"))
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    let (in_order, side_by_side) = (row("resolve: turns in id order"), row("resolve: turns side by side"));
    assert!(in_order[0] > 0.0 && in_order[1] == 0.0, "{text}");
    assert!(side_by_side[0] == 0.0 && side_by_side[1] > 0.0, "{text}");
}

/// A parameter the compared explorer does not take stops `exploration` before its table,
/// with an error naming it and the names it takes; one without `=` is refused as typed.
#[test]
fn exploration_refuses_a_parameter_its_strategy_does_not_take() {
    let out = bench(&[
        "exploration",
        "--teams",
        "0",
        "--only",
        "corridor",
        "--param",
        "replan_within_veiw=0.25",
    ]);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty(), "{}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("unknown parameter 'replan_within_veiw'") && err.contains("known: replan_within_view"),
        "{err}"
    );
    let out = bench(&["exploration", "--param", "replan_within_view"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("expected NAME=VALUE, got 'replan_within_view'"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `exploration --trace DIR` plays the same runs as without it (the same table line) and
/// draws both walks on the loop into `DIR/indoor-loop.png`: two panels of 400 px (200 cells
/// of 0.1 m, 2 px a cell) with the start, the walk to 90 %, the walk on to 98 % and what it
/// first saw on the way in each; and one robot's and two robots' walks into
/// `DIR/indoor-loop-teams.png`. With `--starts 1` it draws each start's walks too
/// (`indoor-loop-home.png`, `indoor-loop-start-1.png` and their teams), again without
/// changing the runs, and a folder it cannot make is named.
#[test]
fn exploration_traces_draw_both_walks_without_changing_the_runs() {
    use scale::trace::{FROM_90, GAP_PX, SEEN_FROM_90, START, TO_90};
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "--rounds",
        "3000",
        "exploration",
        "--only",
        "indoor loop",
        "--teams",
        "2",
    ];
    let plain = bench(&args);
    let traced = bench(&[&args[..], &["--trace", dir.path().to_str().unwrap()]].concat());
    assert!(traced.status.success(), "{}", String::from_utf8_lossy(&traced.stderr));
    let line = |out: &std::process::Output| {
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        text.lines().find(|l| l.starts_with("indoor loop |")).map(str::to_owned)
    };
    assert!(line(&plain).is_some());
    assert_eq!(line(&plain), line(&traced));
    let picture = image::open(dir.path().join("indoor-loop.png")).unwrap().to_rgb8();
    assert_eq!(picture.dimensions(), (2 * 400 + GAP_PX, 400));
    for panel in [0..400, 400 + GAP_PX..2 * 400 + GAP_PX] {
        let has = |colour| {
            panel
                .clone()
                .any(|x| (0..400).any(|y| *picture.get_pixel(x, y) == colour))
        };
        assert!(
            has(START) && has(TO_90) && has(FROM_90) && has(SEEN_FROM_90),
            "panel {panel:?}"
        );
    }
    let teams = image::open(dir.path().join("indoor-loop-teams.png")).unwrap();
    assert_eq!((teams.width(), teams.height()), (2 * 400 + GAP_PX, 400));
    let starts = [&args[..], &["--starts", "1"]].concat();
    let starts_dir = dir.path().join("starts");
    let traced_starts = bench(&[&starts[..], &["--trace", starts_dir.to_str().unwrap()]].concat());
    assert!(
        traced_starts.status.success(),
        "{}",
        String::from_utf8_lossy(&traced_starts.stderr)
    );
    assert!(line(&traced_starts).is_some());
    assert_eq!(line(&bench(&starts)), line(&traced_starts));
    for start in ["home", "start-1"] {
        for suffix in ["", "-teams"] {
            let path = starts_dir.join(format!("indoor-loop-{start}{suffix}.png"));
            let picture = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(picture.width(), 2 * 400 + GAP_PX, "{}", path.display());
        }
    }
    let blocked = dir.path().join("indoor-loop.png").join("sub");
    let out = bench(&[&args[..], &["--trace", blocked.to_str().unwrap()]].concat());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot make the folder") && err.contains("indoor-loop.png"),
        "{err}"
    );
}

/// The line of `smartteams-bench --rounds ROUNDS exploration --only MAP --teams TEAMS
/// --starts 1` that starts with `prefix` (with the line after it when that names the runs
/// short of a bar), and the indoor map's maps from home and from that one start, for the
/// library to run.
fn from_every_start(
    map_name: &str,
    rounds: u64,
    teams: &str,
    prefix: &str,
) -> (String, [std::sync::Arc<sim_core::world::MapData>; 2]) {
    use scale::exploration::{indoor_maps, starting_at, starts_along_the_reference};
    let rounds_arg = rounds.to_string();
    let out = bench(&[
        "--rounds",
        &rounds_arg,
        "exploration",
        "--only",
        map_name,
        "--teams",
        teams,
        "--starts",
        "1",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line `{prefix}…` in {text}"));
    let named = lines.get(at + 1).filter(|l| l.starts_with("  short of"));
    let line = named.map_or(lines[at].to_owned(), |n| format!("{}\n{n}", lines[at]));
    let (_, map) = indoor_maps()
        .unwrap()
        .into_iter()
        .find(|(name, _)| name == map_name)
        .unwrap();
    let start = starts_along_the_reference(&map, 1, rounds).unwrap()[0];
    let from_start = starting_at(&map, start);
    (line, [map, from_start])
}

/// `exploration --starts` also runs the teams from every start: the line for 2 robots on the
/// corner maze, from home and one start, gives the mean of the two speed-ups over one robot
/// and the counts of runs at least 1.6× faster and within 1.25× the distance, as the
/// library's own runs from the same starts give them, then names the runs less than 1.6×
/// faster (the test needs one: the run from the start is).
#[test]
fn teams_run_from_every_start_as_the_library_runs_them() {
    let rounds = 3_000;
    let (line, maps) = from_every_start("indoor corner maze", rounds, "2", "2 cooperative robots");
    let (mut speedups, mut ratios) = (Vec::new(), Vec::new());
    for m in &maps {
        let (r1, d1) = scale::exploration::explore(m, "cooperative", 1, rounds)
            .unwrap()
            .at_90
            .unwrap();
        let (r2, d2) = scale::exploration::explore(m, "cooperative", 2, rounds)
            .unwrap()
            .at_90
            .unwrap();
        speedups.push(r1 as f64 / r2 as f64);
        ratios.push(d2 / d1);
    }
    let mut expected = format!(
        "2 cooperative robots, 2 runs (0 short of 90 %): mean {:.2}x faster than one, {} runs at least 1.6x faster; \
         summed distance mean {:.2}x one's, {} runs within 1.25x",
        speedups.iter().sum::<f64>() / 2.0,
        speedups.iter().filter(|&&x| x >= 1.6).count(),
        ratios.iter().sum::<f64>() / 2.0,
        ratios.iter().filter(|&&x| x <= 1.25).count()
    );
    let short: Vec<String> = ["home", "start 1"]
        .iter()
        .zip(&speedups)
        .filter(|&(_, &x)| x < 1.6)
        .map(|(start, x)| format!("indoor corner maze from {start} ({x:.2}x)"))
        .collect();
    assert!(!short.is_empty(), "the runs no team falls short in: {speedups:?}");
    expected.push_str("\n  short of 1.6x: ");
    expected.push_str(&short.join(", "));
    assert_eq!(line, expected);
}

/// `exploration --starts` ends with the means over every start and how many of those runs
/// walked farther than the reference, as the library's runs of both explorers from home and
/// the start give them (the indoor loop, where `frontier` walks farther to 98 %).
#[test]
fn starts_count_the_runs_farther_than_the_reference() {
    use scale::exploration::{GREEDY_REFERENCE, explore};
    let rounds = 20_000;
    let (line, maps) = from_every_start("indoor loop", rounds, "0", "mean over every start");
    let (mut at90, mut at98) = (Vec::new(), Vec::new());
    for m in &maps {
        let built_in = explore(m, "frontier", 1, rounds).unwrap();
        let reference = explore(m, GREEDY_REFERENCE, 1, rounds).unwrap();
        at90.push(built_in.at_90.unwrap().1 / reference.at_90.unwrap().1);
        at98.push(built_in.at_98.unwrap().1 / reference.at_98.unwrap().1);
    }
    let farther = |r: &[f64]| r.iter().filter(|&&x| x > 1.0).count();
    let expected = format!(
        "mean over every start: {:.3} to 90 % (2 runs), {:.3} to 98 % (2 runs); farther than the reference in {} and {} of them",
        at90.iter().sum::<f64>() / 2.0,
        at98.iter().sum::<f64>() / 2.0,
        farther(&at90),
        farther(&at98)
    );
    assert_eq!(line, expected);
}

/// `exploration --only` that names no map is refused, listing the maps (it printed the
/// table's header alone).
#[test]
fn exploration_only_naming_no_map_is_refused() {
    let out = bench(&["exploration", "--only", "nothingmatches"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("--only nothingmatches: no map's name holds it (the maps: demo, rooms"),
        "{err}"
    );
}

/// `exploration --teams 1` is refused: one robot is what every team is timed against (it
/// printed the single robot twice, as `1:` and as a team of 1).
#[test]
fn exploration_teams_of_one_are_refused() {
    let out = bench(&["exploration", "--only", "indoor loop", "--teams", "0,1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("--teams 1: a team has 2 robots or more"), "{err}");
}

/// `--threads 0` in the scaling report is one thread per core, named by its count, never
/// as `0 thr`.
#[test]
fn scaling_with_zero_threads_names_the_core_count() {
    let out = bench(&[
        "--rounds",
        "10",
        "--threads",
        "1,0",
        "scaling",
        "random-walk",
        "--robots",
        "200",
        "--side-m",
        "128",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    assert!(text.contains(&format!("{cores} thr (s)")), "{text}");
    assert!(!text.contains("0 thr"), "{text}");
}

/// `scripts/bench-threads.sh`: each pair's ratio is its 2-thread robot-rounds/s over its
/// 1-thread robot-rounds/s as printed, then come the median of the pairs' ratios (for two
/// pairs, their mean) and the fastest 2-thread run over the fastest 1-thread run, worked
/// out here from the pair lines' figures.
#[test]
fn the_threads_script_prints_each_pair_their_median_and_the_fastest_runs() {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../scripts/bench-threads.sh");
    let run = |args: &[&str]| {
        Command::new("bash")
            .arg(script)
            .args(args)
            .env("SMARTTEAMS_BENCH", env!("CARGO_BIN_EXE_smartteams-bench"))
            .output()
            .expect("bash runs")
    };
    let out = run(&["2", "random-walk", "--robots", "30", "--side-m", "64", "--rounds", "20"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let pairs: Vec<(f64, f64)> = text
        .lines()
        .filter(|l| l.starts_with("pair "))
        .map(|l| {
            let between = |from: &str, to: &str| -> f64 {
                let rest = &l[l.find(from).unwrap_or_else(|| panic!("{from} in {l}")) + from.len()..];
                rest[..rest.find(to).unwrap_or_else(|| panic!("{to} in {l}"))]
                    .parse()
                    .expect("a number")
            };
            let printed: f64 = l
                .rsplit(", ")
                .next()
                .and_then(|r| r.strip_suffix('x'))
                .and_then(|r| r.parse().ok())
                .unwrap_or_else(|| panic!("a ratio ending {l}"));
            let (one, two) = (between("1 thread ", " "), between("2 threads ", ","));
            assert!((two / one - printed).abs() < 0.001, "{l}");
            (one, two)
        })
        .collect();
    assert_eq!(pairs.len(), 2, "{text}");
    let [(one_a, two_a), (one_b, two_b)] = [pairs[0], pairs[1]];
    // The script's median is of the unrounded ratios of the printed figures.
    let median = f64::midpoint(two_a / one_a, two_b / one_b);
    assert!(
        text.contains(&format!("1 -> 2 threads: {median:.3} ("))
            && text.contains("median of 2 pairs; identical digests"),
        "{text}"
    );
    let fastest = two_a.max(two_b) / one_a.max(one_b);
    assert!(text.contains(&format!("fastest runs: {fastest:.3}x")), "{text}");
    let none = run(&["1", "nav-graph"]);
    assert!(!none.status.success(), "a scenario without rounds is an error");
}
