//! `smartteams run --checkpoint` and `smartteams resume` as a user types them: a run killed
//! with SIGKILL and resumed ends in the same state, with the same metrics and robot
//! statistics, byte for byte, as a run that was never stopped; damaged checkpoints,
//! checkpoints of another version and checkpoints whose map changed are refused by name.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

mod common;

use common::{err, ok, smartteams, workspace};

/// `run` of the demo config with outputs and checkpoints named after `tag`.
fn run_args(config: &Path, tag: &str, rounds: &str) -> Vec<String> {
    [
        "run",
        &config.display().to_string(),
        "--quiet",
        "--no-viewer",
        "--threads",
        "1",
        "--rounds",
        rounds,
        "--metrics",
        &format!("{tag}.csv"),
        "--robot-stats",
        &format!("{tag}-robots.csv"),
        "--checkpoint",
        &format!("{tag}.ckpt"),
        "--checkpoint-every",
        "25",
    ]
    .iter()
    .map(ToString::to_string)
    .collect()
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Run `smartteams ARGS` in `dir` and kill it (SIGKILL, no clean-up) once it has written
/// `checkpoint`, before the end; the checkpoint's round.
fn killed_after_a_checkpoint(dir: &Path, args: &[String], checkpoint: &str) -> u64 {
    let mut child = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .args(args)
        .current_dir(dir)
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !dir.join(checkpoint).exists() {
        assert!(started.elapsed() < Duration::from_mins(2), "no checkpoint written");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let at = sim_core::io::Checkpoint::read(&dir.join(checkpoint)).unwrap().round();
    assert!(at > 0 && at < 600 && at.is_multiple_of(25), "checkpoint at round {at}");
    at
}

/// In `dir`, the demo run whole (outputs `whole*`), then killed once it has written a
/// checkpoint (outputs `cut*`).
fn whole_and_killed_runs(dir: &Path) {
    let config = workspace().join("configs/demo.xml");
    ok(&smartteams(dir, &strs(&run_args(&config, "whole", "600"))));
    killed_after_a_checkpoint(dir, &run_args(&config, "cut", "600"), "cut.ckpt");
}

/// The resume of `cut.ckpt` in `dir`, whose summary is `out`, ended where the whole run
/// did, with the same CSV files, byte for byte.
fn assert_resumed_as_whole(dir: &Path, out: &str) {
    assert!(out.contains("600 rounds"), "{out}");
    assert_eq!(read(dir, "cut.csv"), read(dir, "whole.csv"), "metrics CSV differs");
    assert_eq!(
        read(dir, "cut-robots.csv"),
        read(dir, "whole-robots.csv"),
        "robot stats differ"
    );
}

#[test]
fn a_killed_run_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The demo, and the same run killed (SIGKILL, no clean-up) after a checkpoint.
    whole_and_killed_runs(d);
    // The killed run's metrics stop short of the end.
    let cut = String::from_utf8(read(d, "cut.csv")).unwrap_or_default();
    assert!(cut.lines().count() < 601, "the killed run wrote every round");

    // Resume with the same outputs: every file is the uninterrupted run's, byte for byte.
    let out = ok(&smartteams(
        d,
        &[
            "resume",
            "cut.ckpt",
            "--no-viewer",
            "--metrics",
            "cut.csv",
            "--robot-stats",
            "cut-robots.csv",
        ],
    ));
    assert_resumed_as_whole(d, &out);
    // Both wrote a last checkpoint at round 600: the whole final state, the same bytes (the
    // headers name each run's own output files).
    let last = |name: &str| sim_core::io::Checkpoint::read(&d.join(name)).unwrap();
    let (cut, whole) = (last("cut.ckpt"), last("whole.ckpt"));
    assert_eq!((cut.round(), cut.metrics()), (600, whole.metrics()));
    assert!(cut.state() == whole.state(), "final state differs");
    assert!(!d.join("cut.ckpt.tmp").exists());
}

/// `resume FILE` alone, typed in another folder, writes what the run wrote: the same CSV
/// files, whole, and no recording after `--no-viewer`; a recorded run's resume records
/// beside it, or says the folder is gone.
#[test]
fn a_resume_told_nothing_writes_what_its_run_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    whole_and_killed_runs(d);
    std::fs::create_dir(d.join("elsewhere")).unwrap();
    let out = ok(&smartteams(&d.join("elsewhere"), &["resume", "../cut.ckpt"]));
    assert_resumed_as_whole(d, &out);
    assert_eq!(
        std::fs::read_dir(d.join("elsewhere")).unwrap().count(),
        0,
        "the resume wrote a file here"
    );
    assert!(!out.contains("recording"), "{out}");

    let config = workspace().join("configs/demo.xml");
    let mut recorded = run_args(&config, "rec", "600");
    let no_viewer = recorded.iter().position(|a| a == "--no-viewer").unwrap();
    recorded[no_viewer] = "--rrd=recordings/first.rrd".to_owned();
    recorded.push("--log-every=7".to_owned());
    std::fs::create_dir(d.join("recordings")).unwrap();
    let at = killed_after_a_checkpoint(d, &recorded, "rec.ckpt");
    let out = ok(&smartteams(&d.join("elsewhere"), &["resume", "../rec.ckpt"]));
    let continued = d.join(format!("recordings/first-from-{at}.rrd"));
    assert!(
        continued.metadata().is_ok_and(|m| m.len() > 0),
        "no {}",
        continued.display()
    );
    // As the run logged: the state it starts from, then every 7th round and the last.
    let logged: usize = out
        .split_once(" rounds of world state")
        .and_then(|(before, _)| before.rsplit('(').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no count of logged rounds: {out}"));
    let every_7th = (at + 1..=600).filter(|r| r % 7 == 0 || *r == 600).count();
    assert_eq!(logged, 1 + every_7th, "{out}");
    assert_eq!(read(d, "rec.csv"), read(d, "whole.csv"), "metrics CSV differs");

    // The recording's folder is gone: the resume says so, and how to write elsewhere.
    std::fs::rename(d.join("recordings"), d.join("moved")).unwrap();
    let e = err(&smartteams(d, &["resume", "rec.ckpt", "--quiet"]));
    assert!(
        e.contains("wrote its recording to")
            && e.contains("no longer exists: --rrd FILE or --no-viewer writes elsewhere"),
        "{e}"
    );
    ok(&smartteams(d, &["resume", "rec.ckpt", "--quiet", "--no-viewer"]));
}

#[test]
fn damaged_and_foreign_checkpoints_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A config and map of our own, so the map can change under the checkpoint.
    std::fs::copy(workspace().join("maps/demo.stmap"), d.join("map.stmap")).unwrap();
    let demo = std::fs::read_to_string(workspace().join("configs/demo.xml")).unwrap();
    let start = demo.find("<map").unwrap();
    let end = start + demo[start..].find("/>").unwrap() + 2;
    std::fs::write(
        d.join("run.xml"),
        format!("{}<map file=\"map.stmap\"/>{}", &demo[..start], &demo[end..]),
    )
    .unwrap();
    ok(&smartteams(d, &strs(&run_args(&d.join("run.xml"), "good", "50"))));
    let good = read(d, "good.ckpt");
    let resume = |name: &str, bytes: &[u8]| {
        std::fs::write(d.join(name), bytes).unwrap();
        err(&smartteams(d, &["resume", name, "--no-viewer", "--quiet"]))
    };

    let mut flipped = good.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    let e = resume("flipped.ckpt", &flipped);
    assert!(e.contains("checkpoint flipped.ckpt: corrupt: checksum"), "{e}");

    let e = resume("short.ckpt", &good[..good.len() - 100]);
    assert!(e.contains("checkpoint short.ckpt:") && e.contains("cut short"), "{e}");

    let mut other_format = good.clone();
    other_format[16] = other_format[16].wrapping_add(1);
    let e = resume("old.ckpt", &other_format);
    assert!(
        e.contains("checkpoint old.ckpt: written by Smart Teams")
            && e.contains(&format!("checkpoint format {}", sim_core::io::CHECKPOINT_FORMAT + 1)),
        "{e}"
    );

    let e = resume("notes.ckpt", b"round 50, all fine\n");
    assert!(e.contains("checkpoint notes.ckpt: not a Smart Teams checkpoint"), "{e}");

    let e = err(&smartteams(d, &["resume", "missing.ckpt", "--no-viewer"]));
    assert!(e.contains("missing.ckpt"), "{e}");

    // The map changed since: refused, naming the map.
    std::fs::copy(workspace().join("maps/rooms.stmap"), d.join("map.stmap")).unwrap();
    let e = resume("good.ckpt", &good);
    assert!(
        e.contains("checkpoint good.ckpt: the map file") && e.contains("changed since the checkpoint was written"),
        "{e}"
    );
}

/// The summary's lines from "explored" on (what the rounds did), without timings and files.
fn outcome(summary: &str) -> String {
    summary
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("explored"))
        .filter(|l| !l.trim_start().starts_with("recording") && !l.trim_start().starts_with("written"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Resuming a checkpoint of the final round plays nothing and reports what the run did, as
/// the run itself reported it (the milestones and counts of its last round).
#[test]
fn resuming_a_finished_run_reports_its_outcome() {
    let dir = tempfile::tempdir().unwrap();
    let config = workspace().join("configs/demo.xml");
    let config = config.display().to_string();
    // The outputs go to the test's folder, not beside the config.
    let files = ["--no-viewer", "--metrics", "m.csv", "--robot-stats", "r.csv"];
    let run = [
        &["run", &config, "--rounds", "200"][..],
        &["--checkpoint", "f.ckpt", "--checkpoint-every", "100"],
        &files,
    ];
    let run = ok(&smartteams(dir.path(), &run.concat()));
    let resumed = ok(&smartteams(dir.path(), &[&["resume", "f.ckpt"][..], &files].concat()));
    assert!(resumed.contains("resumed at round 200: 0 played now"), "{resumed}");
    assert!(outcome(&run).contains("50 % at round"), "{run}");
    assert_eq!(outcome(&resumed), outcome(&run));
}

/// A run started with its config named relative to the folder it ran in resumes from any
/// other folder: the checkpoint holds where the config, and so its map, are.
#[test]
fn a_run_resumes_from_another_folder() {
    let dir = tempfile::tempdir().unwrap();
    let tag = dir.path().join("cut").display().to_string();
    let args = run_args(Path::new("configs/demo.xml"), &tag, "600");
    killed_after_a_checkpoint(&workspace(), &args, &format!("{tag}.ckpt"));
    let out = ok(&smartteams(dir.path(), &["resume", "cut.ckpt", "--no-viewer"]));
    assert!(out.contains("600 rounds"), "{out}");
}
