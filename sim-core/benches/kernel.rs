//! The kernel at the paper's scale (fixed seeds): rounds per second for 100 and 1,000
//! robots running cooperative frontier exploration (sensing, known maps, messages, map
//! sharing) on a generated map of ≥ 1,000,000 quadtree leaves. Run:
//! `cargo bench -p sim-core --bench kernel`. Set-up time, memory (peak RSS, known maps)
//! and exploration progress are printed to stderr.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::agent::{Params, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData, RobotType, TreasureSpec};

/// Peak resident set size of this process, from /proc (Linux), in MiB.
fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// 2048 m × 2048 m: clustered rocks (blobs of 1–6 m) over sparse white noise, a clear
/// 60 m square around home. About 1.3 M leaves.
fn big_map() -> Arc<MapData> {
    let side = 2048;
    let grid = Grid::new(DVec2::ZERO, 1.0, side, side).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1_000_000);
    let home = DVec2::splat(1024.0);
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
        if (p - home).abs().max_element() < 30.0 {
            return false;
        }
        // Hash-like rocks: a cell is rock if its 8 m block is "rocky" and noise agrees.
        let block = (x / 8).wrapping_mul(0x9E37_79B9) ^ (y / 8).wrapping_mul(0x85EB_CA6B);
        let rocky = block.wrapping_mul(0xC2B2_AE35) >> 28 < 4;
        (rocky && rng.random_bool(0.7)) || rng.random_bool(0.08)
    });
    let treasures = (0..200)
        .map(|i| {
            let a = f64::from(i) * 0.7;
            TreasureSpec {
                position: home + DVec2::from_angle(a) * (40.0 + f64::from(i)),
                quantity: 5,
            }
        })
        .filter(|t| obstacles.is_disc_free(t.position, 0.2))
        .collect();
    Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: home,
            radius_m: 5.0,
        },
        treasures,
    })
}

fn simulation(map: &Arc<MapData>, robots: u32) -> Simulation {
    let scenario = ScenarioBuilder::new(map.clone())
        .with_name(format!("bench-{robots}"))
        .with_seed(7)
        .with_rounds(u64::MAX)
        .with_types(vec![RobotType::explorer().with_comm_radius_m(20.0)])
        .with_group(
            Group::new("cooperative", 0, robots)
                .with_name("explorers")
                .with_params(Params::from_pairs([("share_every", "20")])),
        )
        .build(&StrategyRegistry::with_builtins())
        .unwrap();
    Simulation::new(scenario).unwrap()
}

fn kernel(c: &mut Criterion) {
    let t = Instant::now();
    let map = big_map();
    eprintln!(
        "map: {} leaves ({} blocked), built in {:.2} s; peak RSS {:.0} MiB",
        map.obstacles.leaf_count(),
        map.obstacles.blocked_leaf_count(),
        t.elapsed().as_secs_f64(),
        peak_rss_mib()
    );
    let mut g = c.benchmark_group("kernel");
    g.sample_size(10);
    for robots in [100u32, 1000] {
        let t = Instant::now();
        let mut sim = simulation(&map, robots);
        eprintln!(
            "{robots} robots: set-up {:.2} s (nav graph {} nodes, {} edges)",
            t.elapsed().as_secs_f64(),
            sim.nav().len(),
            sim.nav().edge_count()
        );
        // Warm up past the crowded start so the measured rounds are typical.
        let t = Instant::now();
        for _ in 0..100 {
            sim.step();
        }
        eprintln!(
            "{robots} robots: first 100 rounds {:.2} s; explored {:.2} %",
            t.elapsed().as_secs_f64(),
            100.0 * sim.report().metrics.explored_fraction
        );
        g.bench_function(format!("round_{robots}_robots"), |b| {
            b.iter(|| black_box(sim.step().metrics.messages));
        });
        eprintln!(
            "{robots} robots: after {} rounds explored {:.2} %, known maps {:.1} MiB, peak RSS {:.0} MiB",
            sim.round(),
            100.0 * sim.report().metrics.explored_fraction,
            sim.robot_memory_bytes() as f64 / f64::from(1 << 20),
            peak_rss_mib()
        );
    }
    g.finish();
}

criterion_group!(benches, kernel);
criterion_main!(benches);
