//! Benchmarks of the spatial structures (fixed seeds). Run:
//! `cargo bench -p sim-core --bench spatial`. Memory figures are printed to stderr.
//!
//! - `paper/*`: the paper's workload, a white-noise map of ~750,000 quadtree leaves and
//!   30,000 random 10 m disc queries, against an `rstar` R*-tree bulk-loaded with the same
//!   blocked leaf rectangles.
//! - `known_map/*`: marking a 10 m view disc along a 10,000-step random walk.
//! - `mapfile/*`: loading the 750k-leaf map.
//! - `robot_index/*`: 100,000 robots, neighbours within 10 m, against a linear scan.

use std::alloc::System;
use std::hint::black_box;

use cap::Cap;
use criterion::{Criterion, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rstar::RTree;
use rstar::primitives::Rectangle;
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, KnownMap, ObstacleMap, RobotId, RobotIndex};
use sim_core::world::{HomeBase, MapData};

#[global_allocator]
static ALLOC: Cap<System> = Cap::new(System, usize::MAX);

const SIDE: u32 = 1024;
/// Chosen so the 1024 × 1024 white-noise map has about 750,000 leaves.
const DENSITY: f64 = 0.215;
const QUERIES: usize = 30_000;
const VIEW_RADIUS_M: f64 = 10.0;

fn white_noise_map() -> ObstacleMap {
    let grid = Grid::new(DVec2::ZERO, 1.0, SIDE, SIDE).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2007);
    ObstacleMap::from_fn(grid, |_, _| rng.random_bool(DENSITY))
}

fn query_points(n: usize) -> Vec<DVec2> {
    let mut rng = ChaCha8Rng::seed_from_u64(30_000);
    (0..n)
        .map(|_| {
            DVec2::new(
                rng.random_range(0.0..f64::from(SIDE)),
                rng.random_range(0.0..f64::from(SIDE)),
            )
        })
        .collect()
}

fn paper_workload(c: &mut Criterion) {
    let before = ALLOC.allocated();
    let map = white_noise_map();
    let quadtree_heap = ALLOC.allocated() - before;
    let leaves = map.leaf_count();
    let blocked = map.blocked_leaf_count();

    let mut rects = Vec::with_capacity(blocked);
    map.for_each_blocked_in_box(map.grid().extent(), |b| {
        rects.push(Rectangle::from_corners(b.min.to_array(), b.max.to_array()));
    });
    let before = ALLOC.allocated();
    let rtree = RTree::bulk_load(rects);
    let rtree_heap = ALLOC.allocated() - before;
    let points = query_points(QUERIES);

    // Same answers from both (random centres: boundary cases have measure zero).
    let r2 = VIEW_RADIUS_M * VIEW_RADIUS_M;
    for p in points.iter().take(2000) {
        let mut n = 0;
        map.for_each_blocked_in_disc(*p, VIEW_RADIUS_M, |_| n += 1);
        assert_eq!(n, rtree.locate_within_distance(p.to_array(), r2).count(), "at {p}");
    }
    eprintln!(
        "paper map: {leaves} leaves ({blocked} blocked); quadtree {} bytes = {:.2} B/leaf (heap {} B); \
         rstar {} bytes = {:.2} B/blocked leaf",
        map.memory_bytes(),
        map.memory_bytes() as f64 / leaves as f64,
        quadtree_heap,
        rtree_heap,
        rtree_heap as f64 / blocked as f64,
    );

    let mut g = c.benchmark_group("paper");
    g.sample_size(10);
    g.bench_function("quadtree_30k_disc_queries", |b| {
        b.iter(|| {
            let mut hits = 0usize;
            for p in &points {
                map.for_each_blocked_in_disc(*p, VIEW_RADIUS_M, |_| hits += 1);
            }
            black_box(hits)
        });
    });
    g.bench_function("rstar_30k_disc_queries", |b| {
        b.iter(|| {
            let mut hits = 0usize;
            for p in &points {
                hits += rtree.locate_within_distance(p.to_array(), r2).count();
            }
            black_box(hits)
        });
    });
    g.bench_function("quadtree_30k_disc_free_tests", |b| {
        b.iter(|| points.iter().filter(|p| map.is_disc_free(**p, 0.125)).count());
    });
    g.finish();

    let data = MapData {
        home: HomeBase::Disc {
            center: DVec2::splat(512.0),
            radius_m: 2.0,
        },
        obstacles: map,
        treasures: Vec::new(),
    };
    let bytes = data.to_bytes();
    eprintln!(
        "map file: {} bytes for {leaves} leaves = {:.3} bytes/leaf ({:.2} bits/leaf)",
        bytes.len(),
        bytes.len() as f64 / leaves as f64,
        8.0 * bytes.len() as f64 / leaves as f64
    );
    let path = std::path::Path::new("bench.stmap");
    let mut g = c.benchmark_group("mapfile");
    g.sample_size(10);
    g.bench_function("load_750k_leaves", |b| {
        b.iter(|| MapData::from_bytes(black_box(&bytes), path).unwrap());
    });
    g.bench_function("save_750k_leaves", |b| b.iter(|| data.to_bytes().len()));
    g.finish();
}

fn random_walk(steps: usize) -> Vec<DVec2> {
    let mut rng = ChaCha8Rng::seed_from_u64(10_000);
    let mut p = DVec2::splat(512.0);
    (0..steps)
        .map(|_| {
            let step = DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU));
            p = (p + step).clamp(DVec2::splat(20.0), DVec2::splat(1004.0));
            p
        })
        .collect()
}

fn known_map(c: &mut Criterion) {
    let grid = Grid::new(DVec2::ZERO, 1.0, SIDE, SIDE).unwrap();
    let walk = random_walk(10_000);
    let mut known = KnownMap::new(grid);
    let mut report = Vec::new();
    for (i, p) in walk.iter().enumerate() {
        known.mark_disc(*p, VIEW_RADIUS_M);
        if [100, 1_000, 3_000, 10_000].contains(&(i + 1)) {
            report.push(format!(
                "{} steps: {} bytes, {} leaves, {:.0} m² known",
                i + 1,
                known.memory_bytes(),
                known.leaf_count(),
                known.known_area_m2()
            ));
        }
    }
    eprintln!("known map along a random walk (10 m view): {}", report.join("; "));
    let mut g = c.benchmark_group("known_map");
    g.sample_size(10);
    g.bench_function("random_walk_10k_marks", |b| {
        b.iter(|| {
            let mut known = KnownMap::new(grid);
            for p in &walk {
                known.mark_disc(*p, VIEW_RADIUS_M);
            }
            known.leaf_count()
        });
    });
    g.finish();
}

fn robot_index(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(100_000);
    let robots: Vec<(RobotId, DVec2)> = (0..100_000)
        .map(|i| {
            (
                RobotId::new(i),
                DVec2::new(rng.random_range(0.0..3000.0), rng.random_range(0.0..3000.0)),
            )
        })
        .collect();
    let queries: Vec<DVec2> = robots.iter().step_by(100).map(|r| r.1).collect();
    let mut index = RobotIndex::new();
    index.rebuild(robots.iter().copied(), VIEW_RADIUS_M);
    let mut g = c.benchmark_group("robot_index");
    g.sample_size(10);
    g.bench_function("rebuild_100k", |b| {
        b.iter(|| index.rebuild(robots.iter().copied(), VIEW_RADIUS_M));
    });
    g.bench_function("grid_1k_queries_100k_robots", |b| {
        b.iter(|| {
            let mut n = 0;
            for q in &queries {
                index.for_each_within(*q, VIEW_RADIUS_M, |_, _| n += 1);
            }
            n
        });
    });
    g.bench_function("linear_scan_1k_queries_100k_robots", |b| {
        let r2 = VIEW_RADIUS_M * VIEW_RADIUS_M;
        b.iter(|| {
            queries
                .iter()
                .map(|q| robots.iter().filter(|r| r.1.distance_squared(*q) <= r2).count())
                .sum::<usize>()
        });
    });
    g.finish();
}

criterion_group!(benches, paper_workload, known_map, robot_index);
criterion_main!(benches);
