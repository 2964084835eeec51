//! Golden results of the scale suite's scenarios at reduced sizes: the digest of the final
//! positions and the CRC-32 of the metrics CSV, pinned. Each scenario runs through the
//! library on 1 and 2 threads, and through `smartteams-bench` (which prints the digest).
//!
//! These values change only when behaviour changes. A commit that changes one says why; a
//! failure prints every scenario's new values, to paste once the change is meant.

use std::process::Command;
use std::sync::{Arc, OnceLock};

use scale::{Kernel, RandomWalk, Swarm};
use sim_core::engine::{Scenario, Simulation};
use sim_core::io::MetricsCsv;
use sim_core::world::MapData;

/// One pinned scenario: how to build it, the bench arguments that build the same one, and
/// what it gives after `rounds` rounds.
struct Golden {
    name: &'static str,
    scenario: fn() -> Scenario,
    bench_args: &'static [&'static str],
    rounds: u64,
    digest: u64,
    metrics_crc: u32,
}

fn walk() -> Scenario {
    RandomWalk {
        robots: 300,
        side_m: 256.0,
        ..RandomWalk::default()
    }
    .scenario()
    .unwrap()
}

fn paper() -> Scenario {
    Swarm {
        robots: 200,
        side_m: 10_000.0,
        mesas: 600,
        ..Swarm::paper()
    }
    .scenario()
    .unwrap()
}

fn moonshot() -> Scenario {
    Swarm {
        robots: 2_000,
        side_m: 10_000.0,
        mesas: 5_000,
        home_radius_m: 14.0,
        ..Swarm::moonshot()
    }
    .scenario()
    .unwrap()
}

fn kernel() -> Scenario {
    // The kernel's map takes seconds to generate: once for every run here.
    static MAP: OnceLock<Arc<MapData>> = OnceLock::new();
    Kernel {
        robots: 60,
        ..Kernel::default()
    }
    .scenario(MAP.get_or_init(Kernel::map))
    .unwrap()
}

const GOLDEN: &[Golden] = &[
    Golden {
        name: "random walk",
        scenario: walk,
        bench_args: &["random-walk", "--robots", "300", "--side-m", "256"],
        rounds: 60,
        digest: 0x813a_3fb5_ee15_196a,
        metrics_crc: 0x0cd1_698e,
    },
    Golden {
        name: "paper scale",
        scenario: paper,
        bench_args: &["swarm", "--robots", "200", "--side-m", "10000", "--mesas", "600"],
        rounds: 60,
        digest: 0xd4d8_4484_c193_b726,
        metrics_crc: 0x2a71_ec94,
    },
    Golden {
        name: "moonshot",
        scenario: moonshot,
        bench_args: &[
            "swarm",
            "--robots",
            "2000",
            "--side-m",
            "10000",
            "--mesas",
            "5000",
            "--home-radius-m",
            "14",
        ],
        rounds: 15,
        digest: 0x2607_2cf2_4692_f4ef,
        metrics_crc: 0xe5a8_49cd,
    },
    Golden {
        name: "kernel",
        scenario: kernel,
        bench_args: &["kernel", "--robots", "60"],
        rounds: 60,
        digest: 0x773b_f2c0_72ba_da56,
        metrics_crc: 0xa392_cd0d,
    },
];

/// (digest, CRC-32 of the metrics CSV) of `rounds` rounds on `threads` threads.
fn through_library(g: &Golden, threads: usize) -> (u64, u32) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let mut sim = Simulation::new((g.scenario)()).unwrap();
        let mut csv = MetricsCsv::new(Vec::new()).unwrap();
        for _ in 0..g.rounds {
            sim.step();
            sim_core::io::Observer::on_round(&mut csv, &sim, sim.report()).unwrap();
        }
        (sim.positions_digest(), crc32fast::hash(&csv.into_inner().unwrap()))
    })
}

/// The digest `smartteams-bench` prints for the same scenario.
fn through_bench(g: &Golden, threads: usize) -> u64 {
    let out = Command::new(env!("CARGO_BIN_EXE_smartteams-bench"))
        .args(g.bench_args)
        .args(["--rounds", &g.rounds.to_string(), "--threads", &threads.to_string()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}: {}",
        g.name,
        String::from_utf8_lossy(&out.stderr)
    );
    text.split("digest ")
        .nth(1)
        .and_then(|rest| rest.get(..16))
        .and_then(|hex| u64::from_str_radix(hex, 16).ok())
        .unwrap_or_else(|| panic!("no digest in {text}"))
}

#[test]
fn scale_scenarios_give_their_pinned_results_through_the_library_and_the_bench() {
    let mut wrong = Vec::new();
    for g in GOLDEN {
        for threads in [1, 2] {
            let (digest, metrics_crc) = through_library(g, threads);
            let bench = through_bench(g, threads);
            if (digest, metrics_crc, bench) != (g.digest, g.metrics_crc, g.digest) {
                wrong.push(format!(
                    "{} on {threads} thread(s): digest: 0x{digest:016x}, metrics_crc: 0x{metrics_crc:08x} \
                     (the bench's digest: 0x{bench:016x})",
                    g.name
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
