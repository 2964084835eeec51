//! The logging threads' priority (`SMARTTEAMS_LOGGING_PRIORITY`): a recording that other
//! programs starve of the CPU says so, and logging at normal priority keeps it going.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// A busy loop at normal priority on the first CPU, stopped when dropped.
struct Hog(Child);

impl Hog {
    /// The loop, once it has run for 50 ms of CPU time: a run started before it spins could
    /// get its logging done unhindered.
    fn on_cpu_0() -> Self {
        let child = Command::new("taskset")
            .args(["-c", "0", "sh", "-c", "while :; do :; done"])
            .spawn()
            .expect("taskset (util-linux) runs");
        let hog = Self(child);
        let started = std::time::Instant::now();
        while hog.cpu_ticks() < 5 {
            assert!(
                started.elapsed() < std::time::Duration::from_secs(10),
                "the busy loop did not run"
            );
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        hog
    }

    /// The loop's user and system time so far, in ticks of 10 ms (fields 14 and 15 of its
    /// `/proc/PID/stat`; `taskset` and `sh` keep the PID, as each execs the next).
    fn cpu_ticks(&self) -> u64 {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.0.id())).unwrap_or_default();
        let after_name = stat.rfind(')').map_or("", |k| &stat[k + 1..]);
        after_name
            .split_whitespace()
            .skip(11)
            .take(2)
            .filter_map(|t| t.parse::<u64>().ok())
            .sum()
    }
}

impl Drop for Hog {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Two rounds of `configs/bench-1000.xml` (1,000 robots on a 1 km map of 177,346 leaves)
/// recorded to `rrd`, the run on the first CPU only, with `SMARTTEAMS_LOGGING_PRIORITY` set
/// to `priority` (or unset).
fn recorded_run_on_cpu_0(rrd: &Path, priority: Option<&str>) -> Output {
    let mut cmd = Command::new("taskset");
    cmd.args([
        "-c",
        "0",
        env!("CARGO_BIN_EXE_smartteams"),
        "run",
        "configs/bench-1000.xml",
        "--rounds",
        "2",
        "--rrd",
    ])
    .arg(rrd)
    .current_dir(workspace())
    .env_remove("SMARTTEAMS_LOGGING_PRIORITY");
    if let Some(p) = priority {
        cmd.env("SMARTTEAMS_LOGGING_PRIORITY", p);
    }
    cmd.output().unwrap()
}

/// With a busy loop on its only CPU, logging at the lowest priority gets no core while the
/// run waits for it: the run says so and names the setting. At normal priority the
/// recording keeps up, with no warning. Both recordings hold the three rounds (the start
/// and two played). The recording is large enough that the starved run waits well beyond
/// [`STARVED_AFTER`](viewer_bridge::priority::STARVED_AFTER) for it: a smaller one, as the
/// demo's, can be done before the warning is due.
#[cfg(target_os = "linux")]
#[test]
fn a_recording_starved_of_the_cpu_says_so_and_normal_priority_keeps_up() {
    let dir = tempfile::tempdir().unwrap();
    let _hog = Hog::on_cpu_0();
    let starved = recorded_run_on_cpu_0(&dir.path().join("idle.rrd"), None);
    let normal = recorded_run_on_cpu_0(&dir.path().join("normal.rrd"), Some("normal"));
    for (out, name) in [(&starved, "idle"), (&normal, "normal")] {
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("(3 rounds of world state;"), "{name}: {stdout}");
    }
    let warning = "the recording has fallen behind: other programs keep every core busy";
    let stderr = String::from_utf8_lossy(&starved.stderr);
    assert!(
        stderr.contains(warning),
        "no warning; stderr: {stderr}; stdout: {}",
        String::from_utf8_lossy(&starved.stdout)
    );
    assert!(stderr.contains("SMARTTEAMS_LOGGING_PRIORITY=normal"), "{stderr}");
    assert_eq!(stderr.matches(warning).count(), 1, "warned once: {stderr}");
    let stderr = String::from_utf8_lossy(&normal.stderr);
    assert!(!stderr.contains(warning), "{stderr}");
}

/// A value other than `idle` or `normal` is refused before the first round, naming the
/// variable and what it takes.
#[test]
fn an_unknown_logging_priority_is_refused_naming_the_variable() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .args(["run", "configs/demo.xml", "--rounds", "2", "--rrd"])
        .arg(dir.path().join("x.rrd"))
        .current_dir(workspace())
        .env("SMARTTEAMS_LOGGING_PRIORITY", "high")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("SMARTTEAMS_LOGGING_PRIORITY=high: expected `idle` or `normal`"),
        "{stderr}"
    );
    assert!(!String::from_utf8_lossy(&out.stdout).contains("rounds with"));
}
