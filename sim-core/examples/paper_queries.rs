//! The paper's query workload as a plain program, for instruction-count profiling:
//! `valgrind --tool=callgrind target/release/examples/paper_queries quadtree 3000`.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rstar::RTree;
use rstar::primitives::Rectangle;
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};

fn main() {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "quadtree".into());
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(30_000);
    let grid = Grid::new(DVec2::ZERO, 1.0, 1024, 1024).expect("grid");
    let mut rng = ChaCha8Rng::seed_from_u64(2007);
    let map = ObstacleMap::from_fn(grid, |_, _| rng.random_bool(0.215));
    let mut rng = ChaCha8Rng::seed_from_u64(30_000);
    let points: Vec<DVec2> = (0..n)
        .map(|_| DVec2::new(rng.random_range(0.0..1024.0), rng.random_range(0.0..1024.0)))
        .collect();
    let start = std::time::Instant::now();
    let hits: usize = if which == "rstar" {
        let mut rects = Vec::new();
        map.for_each_blocked_in_box(grid.extent(), |b| {
            rects.push(Rectangle::from_corners(b.min.to_array(), b.max.to_array()));
        });
        let tree = RTree::bulk_load(rects);
        let t = std::time::Instant::now();
        let h = points
            .iter()
            .map(|p| tree.locate_within_distance(p.to_array(), 100.0).count())
            .sum();
        eprintln!("queries {:?}", t.elapsed());
        h
    } else {
        let t = std::time::Instant::now();
        let mut h = 0;
        for p in &points {
            map.for_each_blocked_in_disc(*p, 10.0, |_| h += 1);
        }
        eprintln!("queries {:?}", t.elapsed());
        h
    };
    println!("{which}: {hits} hits in {:?}", start.elapsed());
}
