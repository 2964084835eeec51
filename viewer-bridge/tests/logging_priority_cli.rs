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
    fn on_cpu_0() -> Self {
        let child = Command::new("taskset")
            .args(["-c", "0", "sh", "-c", "while :; do :; done"])
            .spawn()
            .expect("taskset (util-linux) runs");
        Self(child)
    }
}

impl Drop for Hog {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Two rounds of the demo recorded to `rrd`, the run on the first CPU only, with
/// `SMARTTEAMS_LOGGING_PRIORITY` set to `priority` (or unset).
fn recorded_run_on_cpu_0(rrd: &Path, priority: Option<&str>) -> Output {
    let mut cmd = Command::new("taskset");
    cmd.args([
        "-c",
        "0",
        env!("CARGO_BIN_EXE_smartteams"),
        "run",
        "configs/demo.xml",
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
/// recording keeps up, with no warning. Both recordings hold the three rounds.
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
    assert!(stderr.contains(warning), "{stderr}");
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
