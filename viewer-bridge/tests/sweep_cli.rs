//! `smartteams sweep` and `smartteams merge` as a user types them: shards merged back give
//! the bytes of the whole sweep, an interrupted sweep resumes without redoing finished
//! runs, and bad sweep files are refused with the place that is wrong.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod common;

use common::{err, ok, smartteams, workspace};

/// A sweep of the demo config: `seeds` seeds × 2 team sizes, `rounds` rounds.
fn write_sweep(dir: &Path, seeds: u32, rounds: u32) -> PathBuf {
    let path = dir.join("sweep.xml");
    let config = workspace().join("configs/demo.xml");
    std::fs::write(
        &path,
        format!(
            r#"<sweep config="{}" rounds="{rounds}">
  <seed from="1" to="{seeds}"/>
  <count group="scouts" values="3,6"/>
</sweep>"#,
            config.display()
        ),
    )
    .unwrap();
    path
}

#[test]
fn sharded_sweep_merged_is_the_whole_sweep_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = write_sweep(d, 3, 40);
    let sweep = sweep.to_str().unwrap();
    let whole = ok(&smartteams(d, &["sweep", sweep, "-o", "whole.csv"]));
    assert!(whole.contains("6 runs of 6 (0 resumed), 240 rows"), "{whole}");
    let whole_csv = std::fs::read_to_string(d.join("whole.csv")).unwrap();

    // One row per run and round, runs in grid order (seed slowest), the swept columns first.
    let mut lines = whole_csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("run,seed,scouts.count,round,explored_fraction,"),
        "{whole_csv}"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 6 * 40);
    for (i, row) in rows.iter().enumerate() {
        let run = i / 40;
        assert_eq!(row[0], run.to_string());
        assert_eq!(row[1], (1 + run / 2).to_string(), "seed of run {run}");
        assert_eq!(row[2], ["3", "6"][run % 2], "team size of run {run}");
        assert_eq!(row[3], (1 + i % 40).to_string(), "round");
    }
    // Shards, merged in any order, give the same bytes; one shard comes from a Slurm array.
    ok(&smartteams(
        d,
        &["sweep", sweep, "-o", "p0.csv", "--shard", "0/3", "-q"],
    ));
    ok(&smartteams(
        d,
        &["sweep", sweep, "-o", "p2.csv", "--shard", "2/3", "-q"],
    ));
    let slurm = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .args(["sweep", sweep, "-o", "p1.csv", "-q"])
        .current_dir(d)
        .env("SLURM_ARRAY_TASK_ID", "8")
        .env("SLURM_ARRAY_TASK_MIN", "7")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .output()
        .unwrap();
    ok(&slurm);
    let p1 = std::fs::read_to_string(d.join("p1.csv")).unwrap();
    assert!(
        p1.lines().skip(1).all(|l| l.starts_with("1,") || l.starts_with("4,")),
        "{p1}"
    );
    let merged = ok(&smartteams(
        d,
        &["merge", "p2.csv", "p0.csv", "p1.csv", "-o", "merged.csv"],
    ));
    assert!(merged.contains("6 runs of 6, 240 rows"), "{merged}");
    assert_eq!(std::fs::read(d.join("merged.csv")).unwrap(), whole_csv.as_bytes());

    // A shard left out, or given twice, is an error naming what is wrong.
    let missing = err(&smartteams(d, &["merge", "p0.csv", "p2.csv", "-o", "m.csv"]));
    assert!(missing.contains("2 are in none of the parts (runs 1, 4)"), "{missing}");
    let twice = err(&smartteams(d, &["merge", "p0.csv", "p1.csv", "p0.csv", "-o", "m.csv"]));
    assert!(twice.contains("p0.csv:2:1: run 0 is also in p0.csv"), "{twice}");
}

#[test]
fn a_sweep_run_is_the_run_that_smartteams_run_plays() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = d.join("s.xml");
    std::fs::write(
        &sweep,
        format!(
            r#"<sweep config="{}" rounds="30"><seed values="7,2"/></sweep>"#,
            workspace().join("configs/demo.xml").display()
        ),
    )
    .unwrap();
    ok(&smartteams(d, &["sweep", sweep.to_str().unwrap(), "-o", "s.csv", "-q"]));
    let demo = workspace().join("configs/demo.xml");
    let args = [
        "run",
        demo.to_str().unwrap(),
        "--seed",
        "2",
        "--rounds",
        "30",
        "--no-viewer",
        "-q",
    ];
    ok(&smartteams(d, &[&args[..], &["--metrics", "run.csv"]].concat()));
    let run = std::fs::read_to_string(d.join("run.csv")).unwrap();
    let swept: Vec<String> = std::fs::read_to_string(d.join("s.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| l.starts_with("1,2,"))
        .map(|l| l["1,2,".len()..].to_owned())
        .collect();
    let played: Vec<&str> = run.lines().skip(1).collect();
    assert_eq!(swept.len(), 30);
    assert_eq!(swept, played);
}

#[test]
fn an_interrupted_sweep_resumes_without_redoing_finished_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = write_sweep(d, 12, 300);
    let sweep = sweep.to_str().unwrap();
    ok(&smartteams(d, &["sweep", sweep, "-o", "whole.csv", "-q"]));
    let whole = std::fs::read(d.join("whole.csv")).unwrap();

    // Kill a one-thread sweep once a few runs are written.
    let mut child = Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .args(["sweep", sweep, "-o", "again.csv", "-q", "--threads", "1"])
        .current_dir(d)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .spawn()
        .unwrap();
    let parts = d.join("again.csv.parts");
    let finished = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|r| r.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        v.retain(|p| p.extension().is_some_and(|e| e == "csv"));
        v.sort();
        v
    };
    let started = Instant::now();
    while finished(&parts).len() < 3 {
        assert!(started.elapsed() < Duration::from_mins(1), "no runs written");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sweep ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL: no clean-up
    child.wait().unwrap();
    assert!(!d.join("again.csv").exists());
    let done = finished(&parts);
    assert!(done.len() >= 3 && done.len() < 24, "{} runs done", done.len());

    // Mark a finished run's rows: if it were redone the mark would vanish.
    let marked = &done[0];
    let rows = std::fs::read_to_string(marked).unwrap();
    std::fs::write(marked, rows.replacen(",300,", ",300 (kept),", 1)).unwrap();
    let out = ok(&smartteams(d, &["sweep", sweep, "-o", "again.csv"]));
    assert!(
        out.contains(&format!("24 runs of 24 ({} resumed)", done.len())),
        "{out}"
    );
    let again = std::fs::read_to_string(d.join("again.csv")).unwrap();
    assert!(again.contains(",300 (kept),"), "a finished run was redone");
    assert_eq!(again.replacen(",300 (kept),", ",300,", 1).as_bytes(), &whole[..]);
    assert!(!parts.exists(), "parts left behind");
}

#[test]
fn parts_of_another_sweep_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = write_sweep(d, 1, 5);
    std::fs::create_dir(d.join("out.csv.parts")).unwrap();
    std::fs::write(d.join("out.csv.parts/sweep.key"), "00000000 other.xml\n").unwrap();
    let e = err(&smartteams(d, &["sweep", sweep.to_str().unwrap(), "-o", "out.csv"]));
    assert!(e.contains("out.csv.parts holds runs of another sweep"), "{e}");
}

#[test]
fn bad_sweep_files_are_refused_with_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let config = workspace().join("configs/demo.xml");
    let cases = [
        (
            "<sweep rounds=\"5\">\n</sweep>",
            "s.xml:1:1: <sweep> needs a config attribute",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <count group=\"nobody\" values=\"1\"/>\n</sweep>",
            "s.xml:2:3: no group 'nobody'",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <count group=\"scouts\" values=\"4,many\"/>\n</sweep>",
            "s.xml:2:3: robot counts must be whole numbers, got 'many'",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <colour values=\"red\"/>\n</sweep>",
            "s.xml:2:3: unknown axis <colour>",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <seed values=\"1\"/>\n  <seed values=\"2\"/>\n</sweep>",
            "s.xml:3:3: column 'seed' is varied twice (first at line 2)",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <strategy group=\"scouts\" values=\"frontier,teleport\"/>\n</sweep>",
            "s.xml:2:3: unknown strategy 'teleport'",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <param group=\"scouts\" name=\"share_evry\" values=\"5\"/>\n</sweep>",
            "s.xml:2:3: scouts.share_evry=5: strategy 'cooperative': unknown parameter 'share_evry'",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <strategy group=\"scouts\" values=\"cooperative,random_walk\"/>\n  <param group=\"scouts\" name=\"share_every\" values=\"5\"/>\n</sweep>",
            "s.xml:2:3: scouts.strategy=random_walk: strategy 'random_walk': unknown parameter",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <map values=\"nowhere.stmap\"/>\n</sweep>",
            "s.xml:2:3: map file",
        ),
        ("<sweep config=\"CONFIG\">\n  <seed values=\"1\">\n</sweep>", "s.xml:3:"),
        (
            "<sweep config=\"CONFIG\">\n  <seed values=\"1\" step=\"2\"/>\n</sweep>",
            "s.xml:2:3: <seed> has no attribute 'step'",
        ),
        (
            "<sweep config=\"CONFIG\">\n  <seed from=\"1\" to=\"100000\"/>\n  <count group=\"scouts\" values=\"1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18,19,20,21,22,23,24,25,26,27,28,29,30,31,32,33,34,35,36,37,38,39,40,41,42,43,44,45,46,47,48,49,50,51,52,53,54,55,56,57,58,59,60,61,62,63,64,65,66,67,68,69,70,71,72,73,74,75,76,77,78,79,80,81,82,83,84,85,86,87,88,89,90,91,92,93,94,95,96,97,98,99,100,101\"/>\n</sweep>",
            "s.xml:1:1: the grid has more than 10000000 runs",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(d.join("s.xml"), text.replace("CONFIG", config.to_str().unwrap())).unwrap();
        let e = err(&smartteams(d, &["sweep", "s.xml", "-o", "out.csv"]));
        assert!(e.contains(want), "for\n{text}\nwanted '{want}', got: {e}");
        assert!(!d.join("out.csv").exists());
    }
}

/// `configs/sweep-slurm.sh`'s rule: each task, once its shard is written, merges every
/// part there is; the merge refuses while a shard is missing, so whatever the order the
/// shards finish in, only the last task's merge succeeds, with the single machine's bytes.
#[test]
fn the_last_task_to_finish_merges_whatever_the_order() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = write_sweep(d, 3, 20);
    let sweep = sweep.to_str().unwrap();
    ok(&smartteams(d, &["sweep", sweep, "-o", "whole.csv", "-q"]));
    let whole = std::fs::read(d.join("whole.csv")).unwrap();
    for i in 0..3 {
        let shard = format!("{i}/3");
        let out = format!("shard{i}.csv");
        ok(&smartteams(d, &["sweep", sweep, "-o", &out, "--shard", &shard, "-q"]));
    }
    for order in [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] {
        let results = tempfile::tempdir_in(d).unwrap();
        let r = results.path();
        for (k, &i) in order.iter().enumerate() {
            // Task i finishes: its shard (CSV and manifest) appears, then it tries to merge.
            for ext in ["csv", "manifest.json"] {
                std::fs::copy(d.join(format!("shard{i}.{ext}")), r.join(format!("out.part{i}.{ext}"))).unwrap();
            }
            let mut parts: Vec<String> = std::fs::read_dir(r)
                .unwrap()
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("out.part") && Path::new(n).extension().is_some_and(|x| x == "csv"))
                .collect();
            parts.sort();
            let mut args = vec!["merge"];
            args.extend(parts.iter().map(String::as_str));
            args.extend(["-o", "out.csv"]);
            let merged = smartteams(r, &args);
            if k < 2 {
                assert!(!merged.status.success(), "{order:?}: merged with {parts:?}");
                assert!(!r.join("out.csv").exists());
            } else {
                ok(&merged);
                assert_eq!(std::fs::read(r.join("out.csv")).unwrap(), whole, "{order:?}");
            }
        }
    }
}
