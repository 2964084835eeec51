//! Golden results of the example configs: the digest of the final positions and the CRC-32
//! of the metrics and robot-stats CSVs, pinned. Each config runs through the library (the
//! calls `smartteams run` makes) and through the `smartteams` binary, on 1 and 2 threads.
//!
//! These values change only when behaviour changes. A commit that changes one says why; a
//! failure prints every config's new values as table rows, to paste once the change is
//! meant.

mod common;

use std::path::Path;

use clap::Parser;
use sim_core::agent::StrategyRegistry;
use viewer_bridge::cli::{Cli, Command};
use viewer_bridge::run::execute;

/// One pinned run: `smartteams run configs/CONFIG --rounds ROUNDS`.
struct Golden {
    config: &'static str,
    rounds: u64,
    digest: u64,
    metrics_crc: u32,
    robots_crc: u32,
}

/// What a run gave.
#[derive(Debug, PartialEq)]
struct Outcome {
    digest: u64,
    metrics_crc: u32,
    robots_crc: u32,
}

const GOLDEN: &[Golden] = &[
    Golden {
        config: "demo.xml",
        rounds: 600,
        digest: 0xbce8_b5f2_7435_5d3f,
        metrics_crc: 0x5eda_225d,
        robots_crc: 0x1409_048d,
    },
    Golden {
        config: "teams.xml",
        rounds: 800,
        digest: 0xeaa2_c270_4dd3_cb71,
        metrics_crc: 0x25e1_68d5,
        robots_crc: 0x3a95_e8fa,
    },
    Golden {
        config: "tactics.xml",
        rounds: 600,
        digest: 0x9528_6b3f_4ccd_31bd,
        metrics_crc: 0xae8e_93ea,
        robots_crc: 0xf573_1399,
    },
    Golden {
        config: "bench-1000.xml",
        rounds: 50,
        digest: 0xfec0_feec_ea2a_15e1,
        metrics_crc: 0xa166_d14c,
        robots_crc: 0x5e36_13f9,
    },
    Golden {
        config: "bench-10000.xml",
        rounds: 5,
        digest: 0xa9f9_2299_6c55_f6c1,
        metrics_crc: 0xaac0_9c0f,
        robots_crc: 0x401a_08ab,
    },
];

fn crc_of(path: &Path) -> u32 {
    crc32fast::hash(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

/// The arguments of one golden run, writing its CSVs into `dir`.
fn run_args(g: &Golden, threads: usize, dir: &Path) -> Vec<String> {
    let config = common::workspace().join("configs").join(g.config);
    [
        "run",
        config.to_str().unwrap(),
        "--no-viewer",
        "--rounds",
        &g.rounds.to_string(),
        "--threads",
        &threads.to_string(),
        "--metrics",
        dir.join("metrics.csv").to_str().unwrap(),
        "--robot-stats",
        dir.join("robots.csv").to_str().unwrap(),
    ]
    .map(str::to_owned)
    .to_vec()
}

fn csv_crcs(dir: &Path, digest: u64) -> Outcome {
    Outcome {
        digest,
        metrics_crc: crc_of(&dir.join("metrics.csv")),
        robots_crc: crc_of(&dir.join("robots.csv")),
    }
}

/// Through the library, as `smartteams run` parses and executes it.
fn through_library(g: &Golden, threads: usize) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let mut argv = vec!["smartteams".to_owned()];
    argv.extend(run_args(g, threads, dir.path()));
    argv.push("--quiet".into());
    let Command::Run(args) = Cli::try_parse_from(argv).unwrap().command else {
        unreachable!("a run command")
    };
    let run = args.resolve().unwrap();
    let summary = execute(&run, &StrategyRegistry::with_builtins(), &mut []).unwrap();
    assert_eq!(summary.rounds, g.rounds, "{}", g.config);
    csv_crcs(dir.path(), summary.digest)
}

/// Counts the rounds it is told of.
struct Rounds(u64);

impl sim_core::io::Observer for Rounds {
    fn on_round(
        &mut self,
        _sim: &sim_core::engine::Simulation,
        _report: &sim_core::world::RoundReport,
    ) -> Result<(), sim_core::io::ObserverError> {
        self.0 += 1;
        Ok(())
    }
}

/// A caller's own observer runs beside the run's recording: both see every round, and the
/// digest is the one without them.
#[test]
fn a_callers_observer_and_the_recording_both_see_every_round() {
    let g = &GOLDEN[0];
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("run.rrd");
    let mut argv = vec!["smartteams".to_owned()];
    argv.extend(run_args(g, 2, dir.path()).into_iter().filter(|a| a != "--no-viewer"));
    argv.extend(["--quiet".to_owned(), "--rrd".to_owned(), rrd.display().to_string()]);
    let Command::Run(args) = Cli::try_parse_from(argv).unwrap().command else {
        unreachable!("a run command")
    };
    let run = args.resolve().unwrap();
    let mut rounds = Rounds(0);
    let summary = execute(&run, &StrategyRegistry::with_builtins(), &mut [&mut rounds]).unwrap();
    assert_eq!(rounds.0, g.rounds);
    let recording = summary.recording.expect("the run was recorded");
    assert_eq!(recording.logged_rounds, g.rounds + 1, "round 0 and every round after");
    assert!(std::fs::metadata(&rrd).unwrap().len() > 0);
    let want = Outcome {
        digest: g.digest,
        metrics_crc: g.metrics_crc,
        robots_crc: g.robots_crc,
    };
    assert_eq!(csv_crcs(dir.path(), summary.digest), want);
}

/// Through the binary, reading the digest from its summary.
fn through_binary(g: &Golden, threads: usize) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let args = run_args(g, threads, dir.path());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = common::ok(&common::smartteams(dir.path(), &args));
    let digest = out
        .lines()
        .find_map(|l| l.trim().strip_prefix("digest"))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|hex| u64::from_str_radix(hex, 16).ok())
        .unwrap_or_else(|| panic!("no digest in the summary of {}:\n{out}", g.config));
    csv_crcs(dir.path(), digest)
}

/// Runs every golden config by `play` on 1 and 2 threads; fails listing every difference.
fn check_all(play: fn(&Golden, usize) -> Outcome) {
    let mut wrong = Vec::new();
    for g in GOLDEN {
        for threads in [1, 2] {
            let got = play(g, threads);
            let want = Outcome {
                digest: g.digest,
                metrics_crc: g.metrics_crc,
                robots_crc: g.robots_crc,
            };
            if got != want {
                wrong.push(format!(
                    "{} on {threads} thread(s): digest: 0x{:016x}, metrics_crc: 0x{:08x}, robots_crc: 0x{:08x}",
                    g.config, got.digest, got.metrics_crc, got.robots_crc
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "results differ from the pinned ones:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn example_configs_give_their_pinned_results_through_the_library() {
    check_all(through_library);
}

#[test]
fn example_configs_give_their_pinned_results_through_the_binary() {
    check_all(through_binary);
}
