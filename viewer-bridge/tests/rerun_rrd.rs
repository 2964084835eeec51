//! Recordings checked with the real Rerun tools: the `.rrd` of a short run is read back
//! with the official Python SDK (rerun-sdk 0.36.3) and verified with `rerun rrd verify`,
//! and a run streams live to a `rerun` receiver on loopback, which is killed mid-run.
//!
//! They need `SMARTTEAMS_RERUN_PYTHON` (a Python with `rerun-sdk==0.36.3`;
//! `scripts/test.sh` makes a venv and sets it) and skip with a note when it is unset. The
//! native `rerun` binary is taken from `SMARTTEAMS_RERUN_BIN`, else from that Python's
//! `rerun_cli` package. Not the `rerun` script of the venv: it runs the binary as a child
//! process, so killing or stopping the script would leave the real receiver running.

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

#[path = "../../tests/src/skip.rs"]
mod skip;

/// The Python with `rerun-sdk`, or `None` (the caller returns) after recording the skip.
fn python(test: &str) -> Option<PathBuf> {
    let p = std::env::var_os("SMARTTEAMS_RERUN_PYTHON");
    if p.is_none() {
        skip::skip(
            "rerun",
            test,
            "SMARTTEAMS_RERUN_PYTHON is unset (scripts/test.sh makes the venv and sets it)",
        );
    }
    p.map(PathBuf::from)
}

fn rerun_bin(python: &Path) -> PathBuf {
    if let Some(bin) = std::env::var_os("SMARTTEAMS_RERUN_BIN") {
        return PathBuf::from(bin);
    }
    let out = Command::new(python)
        .args([
            "-c",
            "import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), 'rerun'))",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
}

fn smartteams() -> Command {
    Command::new(env!("CARGO_BIN_EXE_smartteams"))
}

/// `smartteams run configs/demo.xml --rounds ROUNDS`, for more arguments to follow.
fn demo_run(rounds: u64) -> Command {
    let mut cmd = smartteams();
    cmd.arg("run")
        .arg(workspace().join("configs/demo.xml"))
        .args(["--rounds", &rounds.to_string()]);
    cmd
}

/// Run the demo for `rounds` rounds into `dir`, with extra arguments; returns the metrics CSV.
fn run_demo(dir: &Path, rounds: u64, extra: &[&str]) -> PathBuf {
    run_demo_with_stderr(dir, rounds, extra).0
}

/// [`run_demo`], with what the run printed on stderr.
fn run_demo_with_stderr(dir: &Path, rounds: u64, extra: &[&str]) -> (PathBuf, Vec<u8>) {
    let metrics = dir.join("metrics.csv");
    let out = demo_run(rounds)
        .args(["-q", "--metrics"])
        .arg(&metrics)
        .arg("--robot-stats")
        .arg(dir.join("robots.csv"))
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "smartteams run failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    (metrics, out.stderr)
}

fn summarise(python: &Path, rrd: &Path) -> Value {
    try_summarise(python, rrd).unwrap_or_else(|e| panic!("rrd_summary.py failed: {e}"))
}

fn try_summarise(python: &Path, rrd: &Path) -> Result<Value, String> {
    let out = Command::new(python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/rrd_summary.py"))
        .arg(rrd)
        .output()
        .unwrap();
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    serde_json::from_slice(&out.stdout).map_err(|e| e.to_string())
}

/// Polls the recording a receiver is saving until `complete` holds for its summary, for at
/// most a minute; returns the summary. A receiver writes chunks in its own order, not the
/// order they were sent, so a test waits for everything it then checks.
/// `run_stderr` is what the run that streamed to the receiver printed on stderr: a warning
/// there (a flush that timed out, a stream left) says why the file never completed.
fn wait_until(python: &Path, rrd: &Path, what: &str, run_stderr: &[u8], complete: impl Fn(&Value) -> bool) -> Value {
    let t0 = Instant::now();
    loop {
        let read = try_summarise(python, rrd);
        if let Ok(s) = &read
            && complete(s)
        {
            return read.unwrap();
        }
        assert!(
            t0.elapsed() < Duration::from_mins(1),
            "{} never held {what}; the run's stderr: {}; last read: {}",
            rrd.display(),
            String::from_utf8_lossy(run_stderr),
            read.map_or_else(
                |e| format!("failed: {e}"),
                |s| format!("rounds {}, rows {}", s["rounds"], s["rows"])
            )
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Whether a summary holds the robots of `round`.
fn holds_round(s: &Value, round: u64) -> bool {
    s["rounds"]["/world/robots"]
        .as_array()
        .is_some_and(|r| r.iter().any(|v| v.as_u64() == Some(round)))
}

/// How many rounds of the explored fraction a summary holds.
fn explored_metric_rounds(s: &Value) -> usize {
    s["scalars"]["/metrics/exploration/explored_fraction"]
        .as_object()
        .map_or(0, serde_json::Map::len)
}

/// Waits (at most a minute) until `run` has written rounds to its metrics CSV, and asserts
/// that it is still going: it is streaming, and what happens to its viewer next happens
/// mid-run.
fn wait_for_rounds(metrics: &Path, run: &mut Child) {
    let t0 = Instant::now();
    let rows = || std::fs::read_to_string(metrics).map_or(0, |s| s.lines().count().saturating_sub(1));
    while rows() == 0 {
        if let Some(status) = run.try_wait().unwrap() {
            let mut err = String::new();
            if let Some(mut e) = run.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut e, &mut err);
            }
            panic!("the run ended ({status}) before writing a round: {err}");
        }
        assert!(t0.elapsed() < Duration::from_mins(1), "the run wrote no round");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        run.try_wait().unwrap().is_none(),
        "the run ended before its viewer could be stopped: give it more rounds"
    );
}

/// Start the demo for `rounds` rounds with `args` and its metrics in `metrics`, and return
/// once it has written a round (see [`wait_for_rounds`]).
fn start_demo(rounds: u64, metrics: &Path, args: impl IntoIterator<Item = impl AsRef<OsStr>>) -> Child {
    let mut run = demo_run(rounds)
        .args(args)
        .arg("--metrics")
        .arg(metrics)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_rounds(metrics, &mut run);
    run
}

/// Stop `run` with SIGINT; its output, and the round its summary says it stopped at.
fn stop_with_sigint(run: Child) -> (std::process::Output, u64) {
    assert!(
        Command::new("kill")
            .args(["-INT", &run.id().to_string()])
            .status()
            .unwrap()
            .success()
    );
    let out = run.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let round = stdout
        .split("interrupted at round ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}"));
    (out, round)
}

fn rounds_of(summary: &Value, entity: &str) -> Vec<u64> {
    summary["rounds"][format!("/{entity}")]
        .as_array()
        .unwrap_or_else(|| panic!("no rounds for {entity}"))
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

/// The known-region entities of a summary, sorted.
fn known_entities(summary: &Value) -> Vec<&str> {
    summary["rounds"]
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| k.starts_with("/world/known/"))
        .map(String::as_str)
        .collect()
}

/// Metrics CSV → column → round → value.
fn read_metrics(path: &Path) -> BTreeMap<String, BTreeMap<u64, f64>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let headers = r.headers().unwrap().clone();
    let mut out: BTreeMap<String, BTreeMap<u64, f64>> = BTreeMap::new();
    for rec in r.records() {
        let rec = rec.unwrap();
        let round: u64 = rec[0].parse().unwrap();
        for (h, v) in headers.iter().zip(rec.iter()).skip(1) {
            out.entry(h.to_owned()).or_default().insert(round, v.parse().unwrap());
        }
    }
    out
}

#[test]
fn rrd_reads_back_with_the_python_sdk_and_verifies() {
    let Some(python) = python("rrd_reads_back_with_the_python_sdk_and_verifies") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("demo.rrd");
    let rounds = 40;
    let metrics = run_demo(
        dir.path(),
        rounds,
        &[
            "--log-every",
            "4",
            "--known-every",
            "10",
            "--rrd",
            rrd.to_str().unwrap(),
        ],
    );
    let s = summarise(&python, &rrd);
    check_layers(&s, rounds);
    check_robot_detail(&s, rounds, &dir.path().join("robots.csv"));
    check_metrics(&s, rounds, &metrics);
    rrd_verify(&python, &rrd);
}

/// Beyond `--known-per-robot-max` robots, known regions are one entity per robot type, each
/// box tagged with its robot: the demo's 12 scouts (ids 0–11), 4 excavators, 4 transporters.
#[test]
fn known_regions_of_a_large_swarm_are_one_entity_per_type() {
    let Some(python) = python("known_regions_of_a_large_swarm_are_one_entity_per_type") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("demo.rrd");
    let rounds = 20;
    run_demo(
        dir.path(),
        rounds,
        &[
            "--known-every",
            "10",
            "--known-per-robot-max",
            "5",
            "--rrd",
            rrd.to_str().unwrap(),
        ],
    );
    let s = summarise(&python, &rrd);
    assert_eq!(
        known_entities(&s),
        [
            "/world/known/excavator",
            "/world/known/scout",
            "/world/known/transporter"
        ],
        "one entity per type"
    );
    let owners = |entity: &str| -> Vec<u64> {
        s["owners"][entity]
            .as_array()
            .unwrap_or_else(|| panic!("no robot column on {entity}"))
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect()
    };
    assert_eq!(owners("/world/known/scout"), (0..12).collect::<Vec<_>>());
    assert_eq!(owners("/world/known/excavator"), (12..16).collect::<Vec<_>>());
    assert_eq!(owners("/world/known/transporter"), (16..20).collect::<Vec<_>>());
    rrd_verify(&python, &rrd);
}

/// The static layers once each; the world state at round 0 and every 4th round up to the
/// last; the explored layer thinned; one known-region entity per robot.
fn check_layers(s: &Value, rounds: u64) {
    // The static layers, once each.
    for entity in [
        "world",
        "world/obstacles/raster",
        "world/obstacles/boxes",
        "world/home",
        "world3d/ground",
        "world3d/obstacles",
    ] {
        let rows = s["rows"][format!("/{entity}|1")].as_u64();
        assert!(rows.is_some_and(|r| r >= 1), "static {entity} missing: {}", s["rows"]);
    }

    // World state: round 0 and every 4th round up to the last.
    let logged: Vec<u64> = (0..=rounds).step_by(4).collect();
    // Treasures are logged again only when one changes (the viewer keeps the last rows).
    let treasure_rounds = rounds_of(s, "world/treasures");
    assert_eq!(treasure_rounds.first(), Some(&0));
    assert!(
        treasure_rounds.iter().all(|r| logged.contains(r)),
        "treasures outside logged rounds: {treasure_rounds:?}"
    );
    for entity in ["world/robots", "world/paths", "world/links", "world3d/robots"] {
        // Links belong to a round's messages: none before the first round.
        let expected: Vec<u64> = logged
            .iter()
            .copied()
            .filter(|&r| r > 0 || entity != "world/links")
            .collect();
        assert_eq!(rounds_of(s, entity), expected, "{entity}");
        assert_eq!(
            s["rows"][format!("/{entity}|0")].as_u64(),
            Some(expected.len() as u64),
            "{entity}"
        );
    }
    for r in &logged {
        assert_eq!(
            s["instances"]["/world/robots"][r.to_string()].as_u64(),
            Some(20),
            "robots at {r}"
        );
    }
    // Columns are logged again only when they change: positions every logged round, the
    // robots' types (fixed) once.
    let column_rows = |name: &str| s["robot_column_rows"][name].as_u64();
    assert_eq!(column_rows("x"), Some(logged.len() as u64));
    assert_eq!(column_rows("type"), Some(1));
    let explored = rounds_of(s, "world/explored");
    assert_eq!(explored.first(), Some(&0));
    assert_eq!(explored.last(), Some(&rounds));
    assert!(explored.len() < logged.len(), "explored is thinned: {explored:?}");
    let known = known_entities(s);
    assert_eq!(known.len(), 20, "one known-region entity per robot: {known:?}");
}

/// The selection panel's detail of the last round equals the robot-stats CSV of the same run.
fn check_robot_detail(s: &Value, rounds: u64, robot_stats: &Path) {
    // The selection panel's detail of the last round = the robot-stats CSV of the same run.
    let robots = &s["robots"];
    assert_eq!(robots["round"].as_u64(), Some(rounds));
    let column = |name: &str| {
        robots[name]
            .as_array()
            .unwrap_or_else(|| panic!("no detail column {name}: {robots}"))
            .clone()
    };
    let (energy, kind, alive) = (column("energy"), column("type"), column("alive"));
    let (x, y, positions) = (column("x"), column("y"), column("Points2D:positions"));
    for name in ["action", "outcome", "goal_x", "goal_y", "load"] {
        assert_eq!(column(name).len(), 20, "{name}");
    }
    let mut stats = csv::Reader::from_path(robot_stats).unwrap();
    let headers = stats.headers().unwrap().clone();
    let at = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let mut n = 0;
    for (i, rec) in stats.records().enumerate() {
        let rec = rec.unwrap();
        let energy_left: f64 = rec[at("energy_left")].parse().unwrap();
        assert!(
            (energy[i].as_f64().unwrap() - energy_left).abs() < 1e-3,
            "robot {i} energy"
        );
        assert_eq!(kind[i].as_str(), Some(&rec[at("type")]), "robot {i} type");
        assert_eq!(alive[i].as_bool(), Some(&rec[at("alive")] == "true"), "robot {i} alive");
        // The 2D view shows north up: (x, −y) (as f32).
        let (px, py) = (positions[i][0].as_f64().unwrap(), positions[i][1].as_f64().unwrap());
        assert!((px - x[i].as_f64().unwrap()).abs() < 1e-3, "robot {i} x");
        assert!((py + y[i].as_f64().unwrap()).abs() < 1e-3, "robot {i} y");
        n += 1;
    }
    assert_eq!(n, 20);
}

/// Metrics: one row per round, equal to the CSV of the same run.
fn check_metrics(s: &Value, rounds: u64, metrics: &Path) {
    let csv = read_metrics(metrics);
    for (column, entity) in viewer_bridge::rerun_observer::metric_entities() {
        let values = s["scalars"][format!("/{entity}")]
            .as_object()
            .unwrap_or_else(|| panic!("no scalars for {entity}"));
        assert_eq!(values.len() as u64, rounds, "{entity}");
        assert_eq!(s["rows"][format!("/{entity}|0")].as_u64(), Some(rounds), "{entity}");
        for (round, expected) in &csv[column] {
            let got = values[&round.to_string()].as_f64().unwrap();
            // The CSV prints at most 6 decimals.
            assert!(
                (got - expected).abs() <= 1e-3 * expected.abs().max(1.0),
                "{column} at round {round}: rrd {got}, csv {expected}"
            );
        }
    }
}

fn rrd_verify(python: &Path, rrd: &Path) {
    let verify = Command::new(rerun_bin(python))
        .args(["rrd", "verify"])
        .arg(rrd)
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify failed: {}{}",
        String::from_utf8_lossy(&verify.stdout),
        String::from_utf8_lossy(&verify.stderr)
    );
}

/// `view` logs the map: every layer, and a raster whose pixels are the map's cells (the maze
/// is small enough for a pixel a cell), rock where a cell is blocked, row 0 at the north edge.
#[test]
fn view_logs_the_maps_cells() {
    let Some(python) = python("view_logs_the_maps_cells") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("maze.rrd");
    let map_path = workspace().join("maps/maze.stmap");
    let out = smartteams()
        .arg("view")
        .arg(&map_path)
        .arg("--rrd")
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s = summarise(&python, &rrd);
    for entity in [
        "world/obstacles/raster",
        "world/home",
        "world/treasures",
        "world3d/obstacles",
    ] {
        assert!(
            s["rows"][format!("/{entity}|1")].as_u64().is_some(),
            "{entity}: {}",
            s["rows"]
        );
    }
    let map = sim_core::world::MapData::load(&map_path).unwrap();
    let grid = map.obstacles.grid();
    let (w, h) = (grid.width_cells(), grid.height_cells());
    let image = &s["images"]["/world/obstacles/raster"];
    assert_eq!(
        image["format"]["width"].as_u64(),
        Some(u64::from(w)),
        "{}",
        image["format"]
    );
    assert_eq!(image["format"]["height"].as_u64(), Some(u64::from(h)));
    let pixels: Vec<u8> = image["buffer"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| u8::try_from(v.as_u64().unwrap()).unwrap())
        .collect();
    assert_eq!(pixels.len(), (w * h * 3) as usize, "RGB, a pixel a cell");
    let (rock, ground) = (viewer_bridge::layers::ROCK_RGB, viewer_bridge::layers::GROUND_RGB);
    let mut blocked = 0;
    for y in 0..h {
        for x in 0..w {
            let row = h - 1 - y;
            let at = ((row * w + x) * 3) as usize;
            let want = if map.obstacles.tree().cell_value(x, y) {
                rock
            } else {
                ground
            };
            blocked += u32::from(want == rock);
            assert_eq!(pixels[at..at + 3], want, "cell ({x}, {y})");
        }
    }
    assert!(blocked > w * h / 4, "a maze is mostly walls: {blocked} blocked cells");
}

/// Held by each test that streams to a live receiver, for the whole test: on two cores,
/// two runs streaming at once, their receivers and the polls of what those saved starve each
/// other, and a receiver that takes no data for 10 s makes its run give up the rest (as
/// runs do: "could not flush the Rerun stream").
fn one_live_stream_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LIVE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A headless `rerun` that receives on a free port and saves what arrives to `save`; returns
/// it and its port.
///
/// Receivers start one at a time: a port is free only until the receiver binds it (about a
/// second later), and a second receiver handed the same port would fail to bind while the
/// first one's listener made it look started.
fn receiver(python: &Path, save: &Path) -> (Child, u16) {
    listening_on_a_free_port(|port| {
        Command::new(rerun_bin(python))
            .args(["--bind", "127.0.0.1", "--port", &port.to_string(), "--save"])
            .arg(save)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    })
}

/// A process `start`ed on a free local port, once it listens there.
fn listening_on_a_free_port(start: impl Fn(u16) -> Child) -> (Child, u16) {
    static STARTING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = STARTING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // A port picked free can be taken again before the process binds it (a receiver just
    // killed by another test may still hold it): then the process exits, and a new port
    // is tried.
    for _ in 0..5 {
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let mut child = start(port);
        if listening(&mut child, port) {
            return (child, port);
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    panic!("no rerun process started listening in 5 attempts");
}

/// Whether `child` listens on `port` within 30 s, and still does a moment later.
fn listening(child: &mut Child, port: u16) -> bool {
    let t0 = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "rerun receiver did not start");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(300));
    child.try_wait().unwrap().is_none() && std::net::TcpStream::connect(("127.0.0.1", port)).is_ok()
}

#[test]
fn live_stream_arrives_and_a_vanishing_viewer_does_not_stop_the_run() {
    let _live = one_live_stream_at_a_time();
    let Some(python) = python("live_stream_arrives_and_a_vanishing_viewer_does_not_stop_the_run") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();

    // 1. A short run streamed to a receiver arrives whole.
    let saved = dir.path().join("received.rrd");
    let (mut rx, port) = receiver(&python, &saved);
    let url = format!("--connect=127.0.0.1:{port}");
    let (_, stderr) = run_demo_with_stderr(dir.path(), 20, &[url.as_str()]);
    let said = String::from_utf8_lossy(&stderr);
    assert!(
        !said.contains("stopped taking the stream"),
        "a viewer that stayed: {said}"
    );
    // The receiver writes as data arrives: read until the last round is there.
    let s = wait_until(&python, &saved, "round 20 and its metrics", &stderr, |s| {
        holds_round(s, 20) && explored_metric_rounds(s) >= 20
    });
    rx.kill().unwrap();
    rx.wait().unwrap();
    assert_eq!(rounds_of(&s, "world/robots"), (0..=20).collect::<Vec<_>>());
    assert_eq!(explored_metric_rounds(&s), 20);

    // 2. The receiver is killed mid-run: the run says so at once, and completes without
    // logging the rest.
    let (mut rx, port) = receiver(&python, &dir.path().join("killed.rrd"));
    let rounds = 20_000;
    let mut run = demo_run(rounds)
        .arg("-q")
        .arg(format!("--connect=127.0.0.1:{port}"))
        // No warning of slow decisions on a loaded machine: the viewer's is the one looked for.
        .args(["--decide-limit-ms", "0"])
        .arg("--metrics")
        .arg(dir.path().join("m2.csv"))
        .arg("--robot-stats")
        .arg(dir.path().join("r2.csv"))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_rounds(&dir.path().join("m2.csv"), &mut run);
    rx.kill().unwrap();
    rx.wait().unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(status) = run.try_wait().unwrap() {
            break status;
        }
        if t0.elapsed() > Duration::from_mins(5) {
            run.kill().ok();
            panic!("the run hangs after its viewer vanished");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut run.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(status.success(), "the run failed after its viewer vanished: {stderr}");
    let rows = csv::Reader::from_path(dir.path().join("m2.csv"))
        .unwrap()
        .records()
        .count();
    assert_eq!(rows, rounds as usize, "every round was played");
    let gone = ": the Rerun viewer stopped taking the stream (";
    let lost_at: u64 = stderr
        .lines()
        .find(|line| line.contains(gone) && line.ends_with("the run goes on without it"))
        .and_then(|line| line.strip_prefix("warning: round ")?.split(':').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no warning that the viewer went: {stderr}"));
    assert!((1..=rounds).contains(&lost_at), "{stderr}");
    assert_eq!(stderr.matches(gone).count(), 1, "said once: {stderr}");
    assert!(!stderr.contains("could not flush"), "not again at the end: {stderr}");
}

#[test]
fn same_seed_same_recording_whatever_the_thread_count() {
    let Some(python) = python("same_seed_same_recording_whatever_the_thread_count") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let record = |name: &str, extra: &[&str]| {
        let rrd = dir.path().join(name);
        let mut args = vec!["--rrd", rrd.to_str().unwrap()];
        args.extend_from_slice(extra);
        run_demo(dir.path(), 30, &args);
        rrd
    };
    let one = record("one.rrd", &["--threads", "1"]);
    let two = record("two.rrd", &["--threads", "2"]);
    let other_seed = record("seed.rrd", &["--threads", "2", "--seed", "99"]);
    // Chunking follows wall-clock batching and recording ids are random, so the files differ
    // in bytes; their contents (every entity, time and value) must not.
    let compare = |a: &Path, b: &Path| {
        Command::new(rerun_bin(&python))
            .args(["rrd", "compare", "--unordered"])
            .args([a, b])
            .output()
            .unwrap()
            .status
            .success()
    };
    assert!(compare(&one, &two), "1 and 2 threads recorded different data");
    assert!(!compare(&one, &other_seed), "rrd compare cannot tell two seeds apart");
}

/// A live viewer that stops reading (here: SIGSTOP) must not hold up the run: the rounds'
/// world is left out while it is behind, and the run ends on time with all its outputs.
#[cfg(unix)]
#[test]
fn a_paused_viewer_does_not_hold_up_the_run() {
    let _live = one_live_stream_at_a_time();
    let Some(python) = python("a_paused_viewer_does_not_hold_up_the_run") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (mut rx, port) = receiver(&python, &dir.path().join("paused.rrd"));
    let rounds = 10_000;
    let mut run = start_demo(
        rounds as u64,
        &dir.path().join("m.csv"),
        [format!("--connect=127.0.0.1:{port}")],
    );
    let stop = |signal: &str| {
        Command::new("kill")
            .args([signal, &rx.id().to_string()])
            .status()
            .unwrap()
    };
    assert!(stop("-STOP").success());
    let t0 = Instant::now();
    let status = loop {
        if let Some(status) = run.try_wait().unwrap() {
            break status;
        }
        if t0.elapsed() > Duration::from_mins(3) {
            run.kill().ok();
            stop("-CONT");
            panic!("the run hangs on a paused viewer");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    stop("-CONT");
    rx.kill().unwrap();
    rx.wait().unwrap();
    let out = run.wait_with_output().unwrap();
    assert!(status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows = csv::Reader::from_path(dir.path().join("m.csv"))
        .unwrap()
        .records()
        .count();
    assert_eq!(rows, rounds, "every round was played and written");
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains(&format!("{rounds} rounds with 20 robots")),
        "{summary}"
    );
}

/// A run stopped by a signal between the rounds `--log-every` logs still shows where it
/// stopped: its recording holds the world, and the explored area, of its last round.
#[cfg(unix)]
#[test]
fn a_stopped_run_logs_the_world_of_its_last_round() {
    let Some(python) = python("a_stopped_run_logs_the_world_of_its_last_round") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("stopped.rrd");
    let every = 1000;
    let every_arg = every.to_string();
    let run = start_demo(
        100_000,
        &dir.path().join("m.csv"),
        [
            OsStr::new("--log-every"),
            OsStr::new(&every_arg),
            OsStr::new("--rrd"),
            rrd.as_os_str(),
        ],
    );
    // Past a round or two that `--log-every` logs.
    std::thread::sleep(Duration::from_millis(1500));
    let (_, round) = stop_with_sigint(run);
    let mut logged: Vec<u64> = (0..=round).step_by(every).collect();
    if !round.is_multiple_of(every as u64) {
        logged.push(round);
    }
    let s = summarise(&python, &rrd);
    assert_eq!(rounds_of(&s, "world/robots"), logged, "stopped at round {round}");
    assert_eq!(rounds_of(&s, "world/explored").last(), Some(&round));
}

/// A port nobody listens on now. Rerun streams to whatever already listens on a spawned
/// viewer's port, so each `--spawn` test asks for a port of its own.
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// `smartteams run … --spawn=PORT` of the demo for `rounds` rounds, with `path` as its `PATH`.
fn run_spawned(dir: &Path, rounds: u64, port: u16, path: &std::ffi::OsStr) -> std::process::Output {
    demo_run(rounds)
        .arg("-q")
        .arg(format!("--spawn={port}"))
        .arg("--metrics")
        .arg(dir.join("metrics.csv"))
        .env("PATH", path)
        .output()
        .unwrap()
}

/// `--spawn` starts the `rerun` found on `PATH` and streams the run to it. The `rerun` put on
/// `PATH` here wraps the real binary and adds `--save` (there is no display for a window), so
/// what the spawned process received can be read back.
#[cfg(unix)]
#[test]
fn spawn_starts_the_rerun_on_path_and_streams_to_it() {
    use std::os::unix::fs::PermissionsExt;
    let _live = one_live_stream_at_a_time();

    let Some(python) = python("spawn_starts_the_rerun_on_path_and_streams_to_it") else {
        return;
    };
    let port = free_port();
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    let saved = dir.path().join("spawned.rrd");
    let pid_file = dir.path().join("viewer.pid");
    let args_file = dir.path().join("viewer.args");
    let script = format!(
        "#!/bin/sh\n\
         # `rerun --version` is how the SDK checks the viewer's version first.\n\
         [ \"$1\" = --version ] && exec '{real}' --version\n\
         echo $$ > '{pid}'\n\
         echo \"$@\" > '{args}'\n\
         # The viewer's output would keep the run's pipes open after it ends.\n\
         exec '{real}' \"$@\" --bind 127.0.0.1 --save '{saved}' >/dev/null 2>&1\n",
        real = rerun_bin(&python).display(),
        pid = pid_file.display(),
        args = args_file.display(),
        saved = saved.display(),
    );
    let wrapper = bin.join("rerun");
    std::fs::write(&wrapper, script).unwrap();
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = std::env::join_paths(
        std::iter::once(bin.clone()).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .unwrap();

    let out = run_spawned(dir.path(), 20, port, &path);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let args = std::fs::read_to_string(&args_file).expect("the run did not start `rerun` from PATH");
    assert!(args.contains(&format!("--port={port}")), "viewer started with {args}");
    // The spawned viewer outlives the run (as a real one would): read what it saved until
    // the last round is there, then stop it.
    let s = wait_until(&python, &saved, "round 20 and the static map", &out.stderr, |s| {
        holds_round(s, 20) && s["rows"]["/world/obstacles/raster|1"].is_u64()
    });
    let pid = std::fs::read_to_string(&pid_file).unwrap();
    Command::new("kill").arg(pid.trim()).status().unwrap();
    assert_eq!(rounds_of(&s, "world/robots"), (0..=20).collect::<Vec<_>>());
    assert_eq!(
        s["rows"]["/world/obstacles/raster|1"].as_u64(),
        Some(1),
        "the static map arrived"
    );
}

#[test]
fn spawn_without_a_viewer_on_path_says_how_to_get_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = run_spawned(dir.path(), 2, free_port(), dir.path().as_os_str());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot start the Rerun viewer") && err.contains("pip install rerun-sdk==0.36.3"),
        "{err}"
    );
}

#[test]
fn bad_viewer_options_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-folder/run.rrd");
    let run = |viewer: &[&str]| {
        let out = demo_run(2).arg("-q").args(viewer).output().unwrap();
        assert!(!out.status.success(), "{viewer:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = run(&["--rrd", missing.to_str().unwrap()]);
    assert!(
        err.contains(&missing.display().to_string()) && err.contains("does not exist"),
        "{err}"
    );
    let err = run(&["--connect=ftp://viewer:21"]);
    assert!(
        err.contains("ftp://viewer:21") && err.contains("expected HOST"),
        "{err}"
    );
    // Port 1 (tcpmux, privileged) has no listener on any machine this runs on; a port picked
    // as free could be taken meanwhile by another test's receiver.
    let err = run(&["--connect=127.0.0.1:1"]);
    assert!(err.contains("no Rerun viewer listens"), "{err}");
}

/// A viewer address or port after a space, which clap takes for another argument, gets a
/// message showing it written with `=`, before the config or after it.
#[test]
fn a_viewer_value_after_a_space_is_shown_written_with_equals() {
    let config = workspace().join("configs/demo.xml");
    let cases: [(&[&str], &str); 2] = [
        (&["--connect", "127.0.0.1:1"], "--connect=127.0.0.1:1"),
        (&["--spawn", "9000"], "--spawn=9000"),
    ];
    for (viewer, shown) in cases {
        for config_first in [true, false] {
            let mut cmd = smartteams();
            cmd.arg("run");
            if config_first {
                cmd.arg(&config).args(viewer);
            } else {
                cmd.args(viewer).arg(&config);
            }
            let out = cmd.output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{viewer:?}: {err}");
            assert!(err.contains(shown) && err.contains("not a space"), "{viewer:?}: {err}");
        }
    }
}

/// `--connect` to a `rerun server` (a data server, which refuses streams) fails at once
/// with an error naming the address and what to stream to, instead of playing the rounds
/// and losing them.
#[test]
fn a_server_that_refuses_the_stream_is_a_clear_error_before_any_round() {
    let Some(python) = python("a_server_that_refuses_the_stream_is_a_clear_error_before_any_round") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (mut server, port) = listening_on_a_free_port(|port| {
        Command::new(rerun_bin(&python))
            .args(["server", "--host", "127.0.0.1", "-p", &port.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    });
    let metrics = dir.path().join("m.csv");
    let out = demo_run(100_000)
        .arg(format!("--connect=127.0.0.1:{port}"))
        .arg("--metrics")
        .arg(&metrics)
        .output()
        .unwrap();
    server.kill().unwrap();
    server.wait().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("127.0.0.1:{port}"))
            && err.contains("refused the stream")
            && err.contains("rerun --serve-grpc"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // No round was played: the metrics file holds its header at most.
    let rows = std::fs::read_to_string(&metrics).unwrap_or_default().lines().count();
    assert!(rows <= 1, "{rows} lines of metrics");
}

/// Ctrl-C on a run streaming to a live viewer ends the stream as the end of a run does:
/// the viewer gets every round up to the one the run stopped at.
#[cfg(unix)]
#[test]
fn a_stopped_run_ends_its_live_stream_normally() {
    let _live = one_live_stream_at_a_time();
    let Some(python) = python("a_stopped_run_ends_its_live_stream_normally") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("stopped.rrd");
    let (mut rx, port) = receiver(&python, &saved);
    let run = start_demo(
        100_000,
        &dir.path().join("m.csv"),
        [format!("--connect=127.0.0.1:{port}")],
    );
    let (out, round) = stop_with_sigint(run);
    let s = wait_until(
        &python,
        &saved,
        &format!("round {round} and its metrics"),
        &out.stderr,
        |s| holds_round(s, round) && explored_metric_rounds(s) as u64 >= round,
    );
    rx.kill().unwrap();
    rx.wait().unwrap();
    assert_eq!(
        explored_metric_rounds(&s) as u64,
        round,
        "the metrics of every round played arrived"
    );
}

/// An address of this machine that is not a loopback address (the one its route out
/// leaves from; UDP's `connect` sends nothing), or `None` on a machine without a network.
fn non_loopback_address() -> Option<std::net::IpAddr> {
    let socket = std::net::UdpSocket::bind("0.0.0.0:0").ok()?;
    ["192.0.2.1:9", "10.0.0.1:9", "172.16.0.1:9", "192.168.0.1:9"]
        .iter()
        .filter(|target| socket.connect(target).is_ok())
        .filter_map(|_| socket.local_addr().ok())
        .map(|a| a.ip())
        .find(|ip| !ip.is_loopback() && !ip.is_unspecified())
}

/// The bytes a relay has sent on, shared with its threads.
type Relayed = std::sync::Arc<std::sync::Mutex<Vec<u8>>>;

/// A TCP relay on a free port of `ip` to `to` on this machine: its address, and the bytes
/// sent through it towards `to`.
fn relay(ip: std::net::IpAddr, to: u16) -> (std::net::SocketAddr, Relayed) {
    use std::io::{Read, Write};
    let listener = TcpListener::bind((ip, 0)).unwrap();
    let at = listener.local_addr().unwrap();
    let sent = Relayed::default();
    let kept = sent.clone();
    std::thread::spawn(move || {
        for client in listener.incoming().map_while(Result::ok) {
            let Ok(server) = std::net::TcpStream::connect(("127.0.0.1", to)) else {
                continue;
            };
            let (mut from_client, mut to_server) = (client.try_clone().unwrap(), server.try_clone().unwrap());
            let kept = kept.clone();
            std::thread::spawn(move || {
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n @ 1..) = from_client.read(&mut buf) {
                    kept.lock().unwrap().extend_from_slice(&buf[..n]);
                    if to_server.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
                let _ = to_server.shutdown(std::net::Shutdown::Write);
            });
            let (mut from_server, mut to_client) = (server, client);
            std::thread::spawn(move || std::io::copy(&mut from_server, &mut to_client));
        }
    });
    (at, sent)
}

/// A stream to a viewer on another host is LZ4-compressed, as Rerun sends it; one to a
/// viewer on this machine is sent uncompressed. Both arrive whole. The other host is this
/// machine under its network address, through a relay that keeps the bytes. How much LZ4
/// still shrinks them tells the two apart: the uncompressed stream to under 0.6 times the
/// part the compressed one shrinks to (its gRPC framing and chunk headers stay plain, so it
/// still shrinks). The streams' sizes alone would not: how many chunks, each with its
/// schema, a stream is cut into depends on how fast the run goes.
#[test]
fn a_stream_to_another_host_is_compressed_and_one_to_this_machine_is_not() {
    let _live = one_live_stream_at_a_time();
    let test = "a_stream_to_another_host_is_compressed_and_one_to_this_machine_is_not";
    let Some(python) = python(test) else {
        return;
    };
    let Some(ip) = non_loopback_address() else {
        eprintln!("{test}: skipped, this machine has no network address but loopback");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut shrunk = Vec::new();
    for (name, relay_ip) in [("remote", ip), ("local", std::net::IpAddr::from([127, 0, 0, 1]))] {
        let saved = dir.path().join(format!("{name}.rrd"));
        let (mut rx, port) = receiver(&python, &saved);
        let (at, sent) = relay(relay_ip, port);
        let (_, stderr) = run_demo_with_stderr(dir.path(), 20, &[&format!("--connect={at}")]);
        let s = wait_until(&python, &saved, "round 20", &stderr, |s| holds_round(s, 20));
        rx.kill().unwrap();
        rx.wait().unwrap();
        assert_eq!(rounds_of(&s, "world/robots"), (0..=20).collect::<Vec<_>>(), "{name}");
        let bytes = sent.lock().unwrap();
        shrunk.push((bytes.len(), lz4_flex::compress(&bytes).len()));
    }
    let ratio = |(sent, compressed): (usize, usize)| compressed as f64 / sent as f64;
    let (remote, local) = (ratio(shrunk[0]), ratio(shrunk[1]));
    // Were both streams compressed, or both not, LZ4 would shrink them alike.
    assert!(
        local < 0.6 * remote,
        "LZ4 shrinks the stream to {ip} to {remote:.2} of its {} bytes, to 127.0.0.1 to {local:.2} of {}",
        shrunk[0].0,
        shrunk[1].0
    );
}

/// A run stopped by an output that fails mid-way (here a checkpoint whose path is a
/// folder, found at the first checkpoint) still closes its recording: it verifies and holds
/// the rounds played.
#[test]
fn a_run_stopped_by_a_failing_checkpoint_keeps_its_recording() {
    let Some(python) = python("a_run_stopped_by_a_failing_checkpoint_keeps_its_recording") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let checkpoint = dir.path().join("c.ckpt");
    std::fs::create_dir(&checkpoint).unwrap();
    std::fs::write(checkpoint.join("keep"), b"").unwrap();
    let rrd = dir.path().join("x.rrd");
    let out = demo_run(20)
        .arg("-q")
        .arg("--metrics")
        .arg(dir.path().join("m.csv"))
        .arg("--robot-stats")
        .arg(dir.path().join("r.csv"))
        .arg("--checkpoint")
        .arg(&checkpoint)
        .args(["--checkpoint-every", "5", "--rrd"])
        .arg(&rrd)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "the checkpoint could not be written: {stderr}");
    assert!(
        stderr.contains("run stopped at round 5") && stderr.contains("c.ckpt"),
        "{stderr}"
    );
    rrd_verify(&python, &rrd);
    assert_eq!(
        rounds_of(&summarise(&python, &rrd), "world/robots"),
        (0..=5).collect::<Vec<_>>()
    );
}
