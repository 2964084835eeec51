//! `smartteams run` as a user types it: scenario errors found when tried as a new user
//! would (issue 10), each refused before the run with the place that caused it.

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
fn issue10_a_crowd_that_cannot_fit_at_home_is_refused_at_once() {
    let started = Instant::now();
    let (ok, err) = run_config(
        "crowd.xml",
        r#"<simulation rounds="5">
  <map file="MAP"/>
  <group name="crowd" count="100000000" type="explorer" strategy="random_walk"/>
</simulation>"#,
        &[],
    );
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
    // Refused before anything is built for each robot (it used to run on for minutes).
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "took {:?}",
        started.elapsed()
    );
}

#[test]
fn issue10_team_with_a_huge_timeout_is_refused_with_its_range() {
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
}

#[test]
fn issue10_team_with_the_largest_timeout_runs() {
    let (ok, err) = run_config(
        "team.xml",
        r#"<simulation rounds="30">
  <map file="MAP"/>
  <group name="t" count="4" type="explorer" strategy="team">
    <param name="timeout_rounds" value="1000000000"/>
  </group>
</simulation>"#,
        &[],
    );
    assert!(ok, "{err}");
}

#[test]
fn issue10_a_bad_map_argument_is_named_as_the_argument() {
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
