//! Sweeps on a real Slurm: `configs/sweep-slurm.sh` submitted as README tells a user, from a
//! fresh copy of the repository's configs and maps (no `results/` folder), on the one-node
//! Slurm of `scripts/slurm-local.sh`; a task stopped and requeued mid-sweep resumes, and
//! either way the merged CSV is the single machine's, byte for byte.
//!
//! They need `SLURM_CONF` (set by `scripts/test.sh` once `scripts/slurm-local.sh start`
//! runs) and skip, noting why, without it.

mod common;

use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

#[path = "../../tests/src/skip.rs"]
mod skip;

/// `SLURM_CONF`, or `None` after noting the skip.
fn slurm(test: &str) -> Option<String> {
    let conf = std::env::var("SLURM_CONF").ok();
    if conf.is_none() {
        skip::skip(
            "slurm",
            test,
            "SLURM_CONF is unset (scripts/slurm-local.sh start runs a one-node Slurm)",
        );
    }
    conf
}

/// A folder holding copies of the repository's `configs/` and `maps/`, as a fresh clone has.
fn fresh_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for sub in ["configs", "maps"] {
        let ok = Command::new("cp")
            .arg("-r")
            .arg(common::workspace().join(sub))
            .arg(dir.path())
            .status()
            .unwrap();
        assert!(ok.success());
    }
    assert!(!dir.path().join("results").exists());
    dir
}

/// A command run in `dir` with the `smartteams` binary first on `PATH`.
fn in_dir(dir: &Path, program: &str, conf: &str) -> Command {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_smartteams"));
    let path = std::env::join_paths(
        std::iter::once(bin.parent().unwrap().to_path_buf())
            .chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .unwrap();
    let mut cmd = Command::new(program);
    cmd.current_dir(dir).env("PATH", path).env("SLURM_CONF", conf);
    cmd
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The logs of a job's tasks, for failure messages.
fn logs(dir: &Path) -> String {
    let mut text = String::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        if e.file_name().to_string_lossy().starts_with("slurm-") {
            let _ = write!(
                text,
                "--- {}\n{}",
                e.path().display(),
                std::fs::read_to_string(e.path()).unwrap_or_default()
            );
        }
    }
    text
}

/// The single-machine sweep's CSV of `sweep` (a path inside `dir`).
fn single_machine(dir: &Path, sweep: &str, conf: &str) -> Vec<u8> {
    ok(&in_dir(dir, "smartteams", conf)
        .args(["sweep", sweep, "-o", "single.csv", "--quiet"])
        .output()
        .unwrap());
    std::fs::read(dir.join("single.csv")).unwrap()
}

#[test]
fn the_documented_submission_merges_to_the_single_machine_csv() {
    let Some(conf) = slurm("the_documented_submission_merges_to_the_single_machine_csv") else {
        return;
    };
    let dir = fresh_copy();
    let d = dir.path();
    // README's command for a small node (the script asks for 8 CPUs and 8 GB a task).
    let out = in_dir(d, "sbatch", &conf)
        .args(["--wait", "--cpus-per-task=1", "--mem=500M", "configs/sweep-slurm.sh"])
        .output()
        .unwrap();
    ok(&out);
    let merged =
        std::fs::read(d.join("results/sweep-demo.csv")).unwrap_or_else(|e| panic!("no merged CSV ({e}):\n{}", logs(d)));
    assert!(
        merged == single_machine(d, "configs/sweep-demo.xml", &conf),
        "the merged CSV differs from the single machine's:\n{}",
        logs(d)
    );
}

#[test]
fn a_requeued_task_resumes_and_the_merge_is_unchanged() {
    let Some(conf) = slurm("a_requeued_task_resumes_and_the_merge_is_unchanged") else {
        return;
    };
    let dir = fresh_copy();
    let d = dir.path();
    std::fs::write(
        d.join("configs/sweep-long.xml"),
        r#"<sweep name="sweep-long" config="demo.xml" rounds="3000"><seed from="1" to="6"/></sweep>"#,
    )
    .unwrap();
    let out = in_dir(d, "sbatch", &conf)
        .env("SWEEP", "configs/sweep-long.xml")
        .env("OUT", "results/long")
        .args([
            "--parsable",
            "--array=0-1",
            "--cpus-per-task=1",
            "--mem=500M",
            "configs/sweep-slurm.sh",
        ])
        .output()
        .unwrap();
    let job = ok(&out).trim().to_owned();
    // Once task 0 has finished a run (of its three), Slurm stops and requeues it.
    let parts = d.join("results/long.part0.csv.parts");
    let finished = || {
        std::fs::read_dir(&parts).map_or(0, |r| {
            r.flatten()
                .filter(|e| e.path().extension().is_some_and(|x| x == "csv"))
                .count()
        })
    };
    let t0 = Instant::now();
    while finished() == 0 {
        assert!(
            t0.elapsed() < Duration::from_mins(2),
            "task 0 finished no run:\n{}",
            logs(d)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(finished() < 3, "task 0 finished before it could be requeued");
    ok(&in_dir(d, "scontrol", &conf)
        .args(["requeue", &format!("{job}_0")])
        .output()
        .unwrap());
    // A requeued job waits two minutes before it is eligible again.
    let t0 = Instant::now();
    loop {
        let queued = ok(&in_dir(d, "squeue", &conf).args(["-h", "-j", &job]).output().unwrap());
        if queued.trim().is_empty() {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_mins(8),
            "the job is still queued:\n{queued}\n{}",
            logs(d)
        );
        std::thread::sleep(Duration::from_secs(1));
    }
    let log = logs(d);
    // The sweep stopped at the end of a round, keeping its finished runs, before Slurm
    // requeued the task.
    assert!(
        log.contains("stopped after") && log.contains("interrupted by SIGTERM"),
        "task 0 was not stopped cleanly:\n{log}"
    );
    let merged = std::fs::read(d.join("results/long.csv")).unwrap_or_else(|e| panic!("no merged CSV ({e}):\n{log}"));
    assert!(
        merged == single_machine(d, "configs/sweep-long.xml", &conf),
        "the merged CSV differs from the single machine's:\n{log}"
    );
}
