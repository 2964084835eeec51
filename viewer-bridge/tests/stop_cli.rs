//! Clean stops through the binary: SIGINT or SIGTERM ends `smartteams run`, `resume` and
//! `sweep` after the round in progress, keeping everything played (CSV rows, recording,
//! checkpoint, finished sweep runs), with exit status 130 or 143; a second signal ends the
//! process at once.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[path = "../../tests/src/skip.rs"]
mod skip;

fn smartteams(dir: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_smartteams"));
    cmd.current_dir(dir).env_remove("SLURM_ARRAY_TASK_ID");
    cmd
}

fn demo() -> String {
    common::workspace().join("configs/demo.xml").display().to_string()
}

/// Data rows in a CSV file (0 if it is missing or has only its header).
fn csv_rows(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |s| s.lines().count().saturating_sub(1))
}

/// Waits (at most a minute) until `ready` holds, asserting `child` is still running then.
fn wait_until(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !ready() {
        assert!(child.try_wait().unwrap().is_none(), "it ended before {what}");
        assert!(t0.elapsed() < Duration::from_mins(1), "never {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        child.try_wait().unwrap().is_none(),
        "it ended before it could be stopped"
    );
}

fn signal(child: &Child, name: &str) {
    let ok = Command::new("kill")
        .args([name, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// The round the summary says the run stopped at.
fn interrupted_round(stdout: &str) -> u64 {
    stdout
        .split("interrupted at round ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no 'interrupted at round N' in:\n{stdout}"))
}

#[test]
fn sigint_keeps_every_round_played_and_a_recording_that_verifies() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut run = smartteams(d)
        .args([
            "run",
            &demo(),
            "--rounds",
            "100000",
            "--rrd",
            "stopped.rrd",
            "--metrics",
            "m.csv",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut run, "it wrote rounds", || csv_rows(&d.join("m.csv")) > 0);
    signal(&run, "-INT");
    let out = run.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let round = interrupted_round(&stdout);
    assert!(stdout.contains("by SIGINT"), "{stdout}");
    // Every round played is in the CSV, and no other.
    let csv = std::fs::read_to_string(d.join("m.csv")).unwrap();
    assert_eq!(csv.lines().count() - 1, round as usize);
    assert!(csv.lines().last().unwrap().starts_with(&format!("{round},")));
    let Some(rerun) = std::env::var_os("SMARTTEAMS_RERUN_BIN") else {
        skip::skip(
            "rerun",
            "sigint_keeps_every_round_played_and_a_recording_that_verifies",
            "SMARTTEAMS_RERUN_BIN is unset: the recording was not verified",
        );
        return;
    };
    let verify = Command::new(rerun)
        .args(["rrd", "verify"])
        .arg(d.join("stopped.rrd"))
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify: {}{}",
        String::from_utf8_lossy(&verify.stdout),
        String::from_utf8_lossy(&verify.stderr)
    );
}

#[test]
fn sigterm_writes_a_checkpoint_that_resumes_to_the_uninterrupted_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = smartteams(d)
        .args([
            "run",
            &demo(),
            "--rounds",
            "3000",
            "--no-viewer",
            "-q",
            "--metrics",
            "whole.csv",
        ])
        .output()
        .unwrap();
    assert!(whole.status.success());
    // A checkpoint every 1,000 rounds: the stop's own checkpoint is what resumes.
    let mut run = smartteams(d)
        .args([
            "run",
            &demo(),
            "--rounds",
            "3000",
            "--no-viewer",
            "-q",
            "--metrics",
            "cut.csv",
        ])
        .args(["--checkpoint", "cut.ckpt", "--checkpoint-every", "1000"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut run, "it wrote rounds", || csv_rows(&d.join("cut.csv")) > 0);
    signal(&run, "-TERM");
    let out = run.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(143));
    // Quiet: one line, where it stopped.
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    let round = interrupted_round(&stdout);
    assert!(round < 3000, "stopped at {round}");
    let checkpoint = sim_core::io::Checkpoint::read(&d.join("cut.ckpt")).unwrap();
    assert_eq!(checkpoint.round(), round, "the checkpoint holds the last round played");
    let resumed = smartteams(d)
        .args(["resume", "cut.ckpt", "--no-viewer", "-q", "--metrics", "resumed.csv"])
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert_eq!(
        std::fs::read(d.join("resumed.csv")).unwrap(),
        std::fs::read(d.join("whole.csv")).unwrap()
    );
}

/// A sweep of the demo: 8 runs of 2,000 rounds.
fn write_sweep(dir: &Path) -> PathBuf {
    let path = dir.join("sweep.xml");
    std::fs::write(
        &path,
        format!(
            r#"<sweep name="stop" config="{}" rounds="2000">
  <seed from="1" to="8"/>
</sweep>"#,
            demo()
        ),
    )
    .unwrap();
    path
}

#[test]
fn a_sweep_stopped_by_sigterm_resumes_to_the_uninterrupted_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = write_sweep(d);
    let sweep = sweep.to_str().unwrap();
    let whole = smartteams(d)
        .args(["sweep", sweep, "-o", "whole.csv", "--quiet"])
        .output()
        .unwrap();
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    let mut run = smartteams(d)
        .args(["sweep", sweep, "-o", "cut.csv", "--quiet", "--threads", "1"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let finished = |p: &Path| {
        std::fs::read_dir(p).map_or(0, |r| {
            r.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "csv"))
            })
            .count()
        })
    };
    wait_until(&mut run, "it finished a run", || finished(&d.join("cut.csv.parts")) > 0);
    signal(&run, "-TERM");
    let out = run.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(143));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("stopped after") && said.contains("of 8 runs"), "{said}");
    assert!(!d.join("cut.csv").exists(), "a stopped sweep wrote its whole CSV");
    let kept = finished(&d.join("cut.csv.parts"));
    assert!((1..8).contains(&kept), "{kept} runs kept");
    let resumed = smartteams(d).args(["sweep", sweep, "-o", "cut.csv"]).output().unwrap();
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert!(
        String::from_utf8_lossy(&resumed.stdout).contains(&format!("8 runs of 8 ({kept} resumed)")),
        "{}",
        String::from_utf8_lossy(&resumed.stdout)
    );
    assert_eq!(
        std::fs::read(d.join("cut.csv")).unwrap(),
        std::fs::read(d.join("whole.csv")).unwrap()
    );
}

#[test]
fn a_second_signal_ends_the_run_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Ten thousand robots recorded to a file: a round and the recording's close take long
    // enough that the second signal comes before the clean stop is over.
    let config = common::workspace()
        .join("configs/bench-10000.xml")
        .display()
        .to_string();
    let mut run = smartteams(d)
        .args([
            "run",
            &config,
            "--rounds",
            "100000",
            "--metrics",
            "m.csv",
            "--rrd",
            "r.rrd",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut run, "it played a round", || d.join("r.rrd").exists());
    signal(&run, "-INT");
    std::thread::sleep(Duration::from_millis(20));
    signal(&run, "-INT");
    let out = run.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130));
    // Ended by the second signal, not by a clean stop: no summary was printed.
    assert!(
        !String::from_utf8_lossy(&out.stdout).contains("interrupted at round"),
        "the run stopped cleanly before the second signal came"
    );
}
