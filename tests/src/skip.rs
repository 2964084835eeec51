//! Tests that cannot run here say so where the summary shows it.
//!
//! A test that lacks something (the real maps of `SMARTTEAMS_DATA`, the Rerun SDK, Slurm) calls
//! [`skip`] and returns. The skip is printed and, when `SMARTTEAMS_SKIP_LOG` names a file,
//! appended to it, so that `scripts/test.sh` counts and lists the skips at the end. When
//! `SMARTTEAMS_REQUIRE` lists the skip's kind (`data`, `rerun`, `slurm`; comma-separated), the test
//! fails instead: CI requires what it installed.
//!
//! Crates outside `tests` include this file with `#[path]`, so it depends on `std` alone.

use std::io::Write;

/// Record that `test` cannot run for want of `kind` (`why` says what is missing), or fail
/// if `SMARTTEAMS_REQUIRE` requires `kind`.
pub fn skip(kind: &str, test: &str, why: &str) {
    let required = std::env::var("SMARTTEAMS_REQUIRE").unwrap_or_default();
    assert!(
        !required.split(',').any(|k| k.trim() == kind),
        "{test} cannot run: {why}; SMARTTEAMS_REQUIRE={required} requires its {kind}"
    );
    println!("SKIPPED {test}: {why}");
    if let Some(log) = std::env::var_os("SMARTTEAMS_SKIP_LOG") {
        let line = format!("{kind}\t{test}\t{why}\n");
        // One write of the whole line: tests of several processes append to the same file.
        let written = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .and_then(|mut f| f.write_all(line.as_bytes()));
        if let Err(e) = written {
            panic!("{test}: cannot note its skip in {}: {e}", log.to_string_lossy());
        }
    }
}
