//! The kernel at the paper's scale (fixed seeds): rounds per second for 100 and 1,000
//! robots running cooperative frontier exploration (sensing, known maps, messages, map
//! sharing) on a generated map of ≥ 1,000,000 quadtree leaves ([`scale::Kernel`]). Run:
//! `cargo bench -p scale --bench kernel`. Set-up time, memory (peak RSS, known maps)
//! and exploration progress are printed to stderr.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use scale::Kernel;
use sim_core::engine::Simulation;
use sim_core::world::MapData;

/// Peak resident set size of this process, in MiB.
fn peak_rss_mib() -> f64 {
    scale::peak_rss_bytes() as f64 / f64::from(1 << 20)
}

fn simulation(map: &Arc<MapData>, robots: u32) -> Simulation {
    let scenario = Kernel {
        robots,
        ..Kernel::default()
    }
    .scenario(map)
    .unwrap();
    Simulation::new(scenario).unwrap()
}

fn kernel(c: &mut Criterion) {
    let t = Instant::now();
    let map = Kernel::map();
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
