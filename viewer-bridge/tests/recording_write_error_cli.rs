//! A recording that cannot be written ends the run at once with an error naming the file
//! and the reason, and the run's other outputs keep every round it played.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Data rows in a CSV file (0 if it is missing or has only its header).
fn csv_rows(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |s| s.lines().count().saturating_sub(1))
}

/// The round an error says the run stopped at.
fn stopped_round(stderr: &str) -> usize {
    stderr
        .split("run stopped at round ")
        .nth(1)
        .and_then(|rest| rest.split(':').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no 'run stopped at round N' in:\n{stderr}"))
}

/// The binary runs under `sh` with files capped at 4,000 blocks of 512 bytes and SIGXFSZ
/// ignored, so a write past the cap fails with "File too large", as a write to a full disk
/// fails with "No space left on device". The recording reaches the cap long before the
/// metrics do. Rerun's writer stops at its first failed write, without a word: the run must
/// stop then, not play on without its recording, nor wait for ever on a flush the writer
/// will never answer.
#[cfg(unix)]
#[test]
fn a_recording_that_cannot_be_written_ends_the_run_with_the_reason_and_keeps_the_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let demo = common::workspace().join("configs/demo.xml");
    let mut run = Command::new("sh")
        .arg("-c")
        .arg(r#"trap "" XFSZ; ulimit -f 4000; exec "$0" "$@""#)
        .arg(env!("CARGO_BIN_EXE_smartteams"))
        .arg("run")
        .arg(&demo)
        .args(["--rounds", "100000", "--rrd", "capped.rrd", "--metrics", "m.csv", "-q"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while run.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_mins(2) {
            run.kill().unwrap();
            panic!("the run went on for two minutes after its recording could not be written");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = run.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("cannot write the recording capped.rrd: File too large"),
        "{stderr}"
    );
    assert!(std::fs::metadata(d.join("capped.rrd")).unwrap().len() <= 4000 * 512);
    // Every round played is in the metrics, and no other.
    let round = stopped_round(&stderr);
    assert!(round > 0 && round < 100_000, "{stderr}");
    assert_eq!(csv_rows(&d.join("m.csv")), round);
}
