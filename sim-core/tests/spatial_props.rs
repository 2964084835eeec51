//! Property tests of every spatial structure against brute force over random rasters and
//! random shapes. Seeds are fixed, so a failure reproduces.

use std::collections::BTreeSet;
use std::ops::ControlFlow;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::glam::DVec2;
use sim_core::spatial::PartialCells;
use sim_core::spatial::TreasureIndex;
use sim_core::spatial::{Aabb, Capsule, Disc, DiscBeyond, Overlap, Shape, clip_line};
use sim_core::spatial::{BitGrid, Region};
use sim_core::spatial::{CellSet, RegionQuadtree, Square};
use sim_core::spatial::{Grid, KnownMap, ObstacleMap, RobotId, RobotIndex, TreasureId};

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x5EED_0002),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A random map: grid with a random origin and cell size, and a raster of blocked cells.
#[derive(Debug, Clone)]
struct World {
    grid: Grid,
    bits: BitGrid,
}

impl World {
    fn generate(w: u32, h: u32, density: f64, cell_m: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let origin = DVec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
        let grid = Grid::new(origin, cell_m, w, h).unwrap();
        let mut bits = BitGrid::new(w, h);
        // Clumps as well as noise, so merged leaves of every size appear.
        let clumpy = rng.random_bool(0.5);
        for y in 0..h {
            for x in 0..w {
                let v = if clumpy {
                    ((x / 4 + y / 3) % 3 == 0) != rng.random_bool(density * 0.2)
                } else {
                    rng.random_bool(density)
                };
                bits.set(x, y, v);
            }
        }
        Self { grid, bits }
    }

    /// Blocked value of a cell of the covering square (padding is blocked).
    fn blocked(&self, x: u32, y: u32) -> bool {
        !self.grid.in_map(x, y) || self.bits.get(x, y)
    }

    fn cells(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        let side = self.grid.side_cells();
        (0..side).flat_map(move |y| (0..side).map(move |x| (x, y)))
    }

    fn map(&self) -> ObstacleMap {
        ObstacleMap::from_bitgrid(self.grid, &self.bits).unwrap()
    }

    /// A move between two points: long, short, or along a cell edge.
    fn random_move(&self, rng: &mut ChaCha8Rng) -> (DVec2, DVec2) {
        let a = self.random_point(rng);
        let b = match rng.random_range(0..3) {
            0 => self.random_point(rng),
            1 => a + DVec2::new(rng.random_range(-2.0..2.0), 0.0) * self.grid.cell_m(),
            _ => a + DVec2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)),
        };
        (a, b)
    }

    fn random_point(&self, rng: &mut ChaCha8Rng) -> DVec2 {
        let e = self.grid.extent();
        let pad = DVec2::splat(3.0 * self.grid.cell_m());
        let lo = e.min - pad;
        let hi = e.max + pad;
        DVec2::new(rng.random_range(lo.x..hi.x), rng.random_range(lo.y..hi.y))
    }
}

fn world_strategy() -> impl Strategy<Value = World> {
    (
        1u32..40,
        1u32..40,
        0.0f64..1.0,
        prop_oneof![Just(1.0), Just(0.5), Just(0.25), 0.1f64..3.0],
        any::<u64>(),
    )
        .prop_map(|(w, h, d, c, s)| World::generate(w, h, d, c, s))
}

/// Cells of the covering square lying in the returned leaves and overlapping the shape.
fn cells_from_leaves<S: Shape>(map: &ObstacleMap, shape: &S) -> BTreeSet<(u32, u32)> {
    let g = *map.grid();
    let mut out = BTreeSet::new();
    let _ = map.visit_blocked(shape, |sq: Square, b| {
        assert_ne!(
            shape.classify(&b),
            Overlap::Disjoint,
            "visited leaf {b:?} misses the shape"
        );
        for y in sq.y..sq.y + sq.side_cells() {
            for x in sq.x..sq.x + sq.side_cells() {
                if shape.classify(&g.square(x, y, 0)) != Overlap::Disjoint {
                    assert!(out.insert((x, y)), "cell ({x}, {y}) reported twice");
                }
            }
        }
        ControlFlow::Continue(())
    });
    out
}

/// The cells of a set, listed one by one.
fn set_cells(set: &CellSet) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    set.for_each_cell(|x, y| out.push((x, y)));
    out
}

fn brute_cells<S: Shape>(w: &World, shape: &S) -> BTreeSet<(u32, u32)> {
    w.cells()
        .filter(|&(x, y)| w.blocked(x, y) && shape.classify(&w.grid.square(x, y, 0)) != Overlap::Disjoint)
        .collect()
}

fn brute_free<S: Shape>(w: &World, shape: &S) -> bool {
    w.grid.extent().contains_box(&shape.bounds()) && brute_cells(w, shape).is_empty()
}

/// First entry of the ray into a blocked cell's interior, or its exit from the extent.
fn brute_first_hit(w: &World, o: DVec2, dir: DVec2, max: f64) -> Option<f64> {
    let mut best = match clip_line(o, dir, 0.0, f64::INFINITY, &w.grid.extent()) {
        Some((t0, t1)) if t0 <= 0.0 => t1,
        _ => 0.0,
    };
    for (x, y) in w.cells() {
        if !w.blocked(x, y) {
            continue;
        }
        let b = w.grid.square(x, y, 0);
        if let Some((t0, t1)) = clip_line(o, dir, 0.0, max, &b)
            && b.contains_strictly(o + dir * (0.5 * (t0 + t1)))
        {
            best = best.min(t0);
        }
    }
    (best <= max).then_some(best)
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn obstacle_map_matches_its_raster(w in world_strategy()) {
        let map = w.map();
        map.validate().unwrap();
        for (x, y) in w.cells() {
            prop_assert_eq!(map.tree().cell_value(x, y), w.blocked(x, y), "cell ({}, {})", x, y);
        }
        let cell_area = w.grid.cell_area_m2();
        let blocked = w.bits.count_ones() as f64 * cell_area;
        let total = f64::from(w.grid.width_cells()) * f64::from(w.grid.height_cells()) * cell_area;
        prop_assert!((map.blocked_area_m2() - blocked).abs() < 1e-6);
        prop_assert!((map.free_area_m2() - (total - blocked)).abs() < 1e-6);
        // Built from a predicate, a raster and region classification: one canonical tree.
        let by_fn = ObstacleMap::from_fn(w.grid, |x, y| w.bits.get(x, y));
        prop_assert_eq!(by_fn.leaf_count(), map.leaf_count());
        let by_regions = ObstacleMap::from_regions(w.grid, |sq| {
            let cells: Vec<bool> = (sq.y..sq.y + sq.side_cells())
                .flat_map(|y| (sq.x..sq.x + sq.side_cells()).map(move |x| (x, y)))
                .map(|(x, y)| w.bits.get(x, y))
                .collect();
            if cells.iter().all(|&c| c) { Region::Full } else if cells.iter().all(|&c| !c) { Region::Empty } else { Region::Mixed }
        });
        by_regions.validate().unwrap();
        prop_assert_eq!(by_regions.leaf_count(), map.leaf_count());
        // Merging: no two leaves could be one, so the leaf count is the canonical minimum.
        prop_assert_eq!(map.leaf_count(), map.tree().count_leaves(true) + map.tree().count_leaves(false));
    }

    #[test]
    fn disc_and_box_queries_match_brute_force(w in world_strategy(), seed in any::<u64>()) {
        let map = w.map();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..20 {
            let c = w.random_point(&mut rng);
            let r = rng.random_range(0.0..10.0) * w.grid.cell_m();
            let disc = Disc { center: c, radius: r };
            prop_assert_eq!(cells_from_leaves(&map, &disc), brute_cells(&w, &disc));
            prop_assert_eq!(map.is_disc_free(c, r), brute_free(&w, &disc));
            let mut n = 0;
            map.for_each_blocked_in_disc(c, r, |_| n += 1);
            let mut leaves = 0;
            let _ = map.visit_blocked(&disc, |_, _| { leaves += 1; ControlFlow::Continue(()) });
            prop_assert_eq!(n, leaves);

            let b = Aabb::from_corners(w.random_point(&mut rng), w.random_point(&mut rng));
            prop_assert_eq!(cells_from_leaves(&map, &b), brute_cells(&w, &b));
            prop_assert_eq!(map.is_point_free(c), w.grid.extent().contains_box(&Aabb { min: c, max: c })
                && w.grid.cell_of(c).is_some_and(|(x, y)| !w.blocked(x, y)));
        }
    }

    #[test]
    fn movement_tests_match_brute_force(w in world_strategy(), seed in any::<u64>()) {
        let map = w.map();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..20 {
            let (a, b) = w.random_move(&mut rng);
            let r = if rng.random_bool(0.3) { 0.0 } else { rng.random_range(0.0..2.0) * w.grid.cell_m() };
            let cap = Capsule { a, b, radius: r };
            prop_assert_eq!(cells_from_leaves(&map, &cap), brute_cells(&w, &cap));
            prop_assert_eq!(map.is_swept_disc_free(a, b, r), brute_free(&w, &cap));
            if r == 0.0 {
                prop_assert_eq!(map.is_segment_free(a, b), brute_free(&w, &cap));
            }
            let dir = DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU));
            let max = rng.random_range(0.0..60.0);
            let got = map.first_hit(a, dir, max);
            let want = brute_first_hit(&w, a, dir, max);
            match (got, want) {
                (Some(g), Some(e)) => prop_assert!((g - e).abs() < 1e-9, "hit {} vs {}", g, e),
                (g, e) => prop_assert_eq!(g, e),
            }
        }
    }

    /// Reading the cells near a capsule (routes' legs, corner cuts over the known map)
    /// answers as the tree walk does whenever it answers, for either value, for moves of a
    /// few cells and legs across the map, with any budget of blocks; with budget enough it
    /// answers every capsule but those passing within a part in 10⁷ of the radius of a cell
    /// of the value.
    #[test]
    fn capsule_meets_cells_is_the_walks(w in world_strategy(), seed in any::<u64>()) {
        let map = w.map();
        let tree = map.tree();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for k in 0..30 {
            let radius = rng.random_range(0.01..3.0) * w.grid.cell_m();
            let (a, b) = if k % 3 == 0 {
                // Passing a cell's corner at the radius, as a leg pulled round a corner does:
                // too near to tell by distance.
                let c = w.grid.corner(rng.random_range(0..=w.grid.width_cells()), rng.random_range(0..=w.grid.height_cells()));
                let u = DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU));
                let at = c + u.perp() * radius;
                (at - u * rng.random_range(0.0..20.0) * w.grid.cell_m(), at + u * rng.random_range(0.0..20.0) * w.grid.cell_m())
            } else {
                w.random_move(&mut rng)
            };
            let cap = Capsule { a, b, radius };
            let r2 = cap.radius * cap.radius;
            for value in [true, false] {
                let distances: Vec<f64> = w
                    .cells()
                    .filter(|&(x, y)| w.blocked(x, y) == value)
                    .map(|(x, y)| sim_core::spatial::segment_box_distance_squared(a, b, &w.grid.square(x, y, 0)))
                    .collect();
                let walk = tree.any_leaf_in(&cap, value);
                prop_assert_eq!(walk, distances.iter().any(|&d| d < r2), "the walk is brute force's");
                for budget in [0, 3, 64, u32::MAX] {
                    if let Some(meets) = tree.capsule_meets_cells(&cap, value, budget) {
                        prop_assert_eq!(meets, walk, "{:?}, value {}, budget {}", cap, value, budget);
                    }
                }
                let ties = distances.iter().filter(|&&d| (d - r2).abs() <= 1e-7 * r2).count();
                let in_square = w.grid.extent().contains_box(&cap.bounds());
                if w.grid.depth() >= 3 && in_square && ties <= 8 {
                    prop_assert!(tree.capsule_meets_cells(&cap, value, u32::MAX).is_some(), "{:?} undecided", cap);
                }
            }
        }
    }

    /// The free fraction of a blocked move is exactly what a 24-step bisection on the
    /// swept-disc test finds (robots' moves are trimmed with it).
    #[test]
    fn swept_disc_free_fraction_is_the_bisections(w in world_strategy(), seed in any::<u64>()) {
        let map = w.map();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..20 {
            let (a, b) = w.random_move(&mut rng);
            let d = b - a;
            let r = if rng.random_bool(0.2) { 0.0 } else { rng.random_range(0.0..0.6) * w.grid.cell_m() };
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..24 {
                let mid = 0.5 * (lo + hi);
                if map.is_swept_disc_free(a, a + d * mid, r) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            prop_assert_eq!(map.swept_disc_free_fraction(a, d, r).to_bits(), f64::to_bits(lo), "from {:?} by {:?} r {}", a, d, r);
        }
    }

    /// Setting a grid square by a descent along its coordinates is the fill of its box: the
    /// same cells, the same canonical tree, the same changed cells reported.
    #[test]
    fn filling_a_square_is_filling_its_box(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut by_box = RegionQuadtree::from_bitgrid(w.grid, &w.bits, true).unwrap();
        let mut by_square = by_box.clone();
        let cells_of = |sq: Square| (0..1u32 << sq.level).flat_map(move |dy| (0..1u32 << sq.level).map(move |dx| (sq.x + dx, sq.y + dy)));
        for step in 0..30 {
            let level = rng.random_range(0..=w.grid.depth());
            let side = 1u32 << level;
            let n = w.grid.side_cells() / side;
            let sq = Square { x: rng.random_range(0..n) * side, y: rng.random_range(0..n) * side, level };
            let value = rng.random_bool(0.6);
            let (mut a, mut b) = (BTreeSet::new(), BTreeSet::new());
            by_box.fill_reporting(&w.grid.square(sq.x, sq.y, sq.level), value, PartialCells::Exclude, |r| a.extend(cells_of(r)));
            by_square.fill_square_reporting(sq, value, |r| b.extend(cells_of(r)));
            prop_assert_eq!(&a, &b, "step {} square {:?}", step, sq);
            by_square.validate().unwrap();
            prop_assert_eq!(by_box.leaf_count(), by_square.leaf_count());
            let leaves = |t: &RegionQuadtree| { let mut v = Vec::new(); t.for_each_leaf(|q, x| v.push((q.x, q.y, q.level, x))); v };
            prop_assert_eq!(leaves(&by_box), leaves(&by_square), "step {}", step);
        }
    }

    #[test]
    fn fill_matches_a_raster_and_stays_canonical(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tree = RegionQuadtree::from_bitgrid(w.grid, &w.bits, true).unwrap();
        let side = w.grid.side_cells();
        let mut cells: Vec<bool> = w.cells().map(|(x, y)| w.blocked(x, y)).collect();
        for _ in 0..12 {
            let value = rng.random_bool(0.5);
            let partial = if rng.random_bool(0.5) { PartialCells::Include } else { PartialCells::Exclude };
            let a = w.random_point(&mut rng);
            let shape: Box<dyn Shape> = match rng.random_range(0..3) {
                0 => Box::new(Disc { center: a, radius: rng.random_range(0.0..8.0) * w.grid.cell_m() }),
                1 => Box::new(Aabb::from_corners(a, w.random_point(&mut rng))),
                _ => Box::new(Capsule { a, b: w.random_point(&mut rng), radius: rng.random_range(0.0..2.0) }),
            };
            let changed = tree.fill(&&*shape, value, partial);
            let mut expect_change = false;
            for (i, (x, y)) in w.cells().enumerate() {
                let o = shape.classify(&w.grid.square(x, y, 0));
                let hit = o == Overlap::Contains || (o == Overlap::Partial && partial == PartialCells::Include);
                if hit && cells[i] != value {
                    cells[i] = value;
                    expect_change = true;
                }
            }
            tree.assert_well_formed();
            prop_assert_eq!(changed, expect_change);
            for (i, (x, y)) in w.cells().enumerate() {
                prop_assert_eq!(tree.cell_value(x, y), cells[i], "cell ({}, {}) of {}", x, y, side);
            }
            prop_assert_eq!(tree.count_cells(true), cells.iter().filter(|&&c| c).count() as u64);
        }
    }

    /// A view that moves (only what lies outside the last view is visited) marks exactly
    /// the cells that marking each whole disc would, on a walk that also jumps, changes
    /// radius and stays put, with merges from another map in between.
    #[test]
    fn moving_views_mark_exactly_what_whole_discs_mark(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut by_view = KnownMap::new(w.grid);
        let mut by_disc = KnownMap::new(w.grid);
        let mut c = w.random_point(&mut rng);
        let mut r = rng.random_range(0.5..4.0) * w.grid.cell_m();
        for step in 0..24 {
            if rng.random_bool(0.2) {
                c = w.random_point(&mut rng);
                r = rng.random_range(0.0..4.0) * w.grid.cell_m();
            } else if rng.random_bool(0.15) {
                // The same view again (a robot that did not move), merges in between or not.
            } else {
                c += DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..0.7) * w.grid.cell_m();
            }
            if step % 7 == 6 {
                let mut other = KnownMap::new(w.grid);
                other.mark_disc(w.random_point(&mut rng), 2.0 * w.grid.cell_m());
                by_view.merge(&other);
                by_disc.merge(&other);
            }
            let grew_view = by_view.mark_view(c, r);
            let grew_disc = by_disc.mark_disc(c, r);
            by_view.validate().unwrap();
            prop_assert_eq!(grew_view, grew_disc);
            prop_assert_eq!(by_view.known_cells(), by_disc.known_cells());
        }
        for (x, y) in w.cells() {
            prop_assert_eq!(by_view.tree().cell_value(x, y), by_disc.tree().cell_value(x, y));
        }
    }

    /// Views marked from their cells worked out at once (one walk that goes only where the
    /// cells are, no shape tests) hold exactly the cells the general walk marks, and report
    /// exactly the cells that changed, each once; the collective map fed those reports
    /// holds the same cells; obstacle counts over the reported sets match brute force.
    /// `validate` also checks the blocks each map caches beside its tree against the tree,
    /// after every mark and merge.
    #[test]
    fn views_marked_by_blocks_are_the_walks_cells(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let obstacles = w.map();
        let mut by_view = KnownMap::new(w.grid);
        let mut by_walk = KnownMap::new(w.grid);
        let mut explored = KnownMap::new(w.grid);
        let mut c = w.random_point(&mut rng);
        let mut r = rng.random_range(0.5..6.0) * w.grid.cell_m();
        for step in 0..20 {
            if rng.random_bool(0.25) {
                c = w.random_point(&mut rng);
                r = rng.random_range(0.0..20.0) * w.grid.cell_m();
            } else {
                c += DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..1.5) * w.grid.cell_m();
            }
            if step % 6 == 5 {
                let mut other = KnownMap::new(w.grid);
                other.mark_disc(w.random_point(&mut rng), 3.0 * w.grid.cell_m());
                other.complete_hashes();
                by_view.merge(&other);
                by_walk.merge(&other);
                explored.merge(&other);
            }
            if step % 4 == 1 {
                // Content hashes kept from here on: each mark and merge below must forget
                // those it changes (`validate` checks them). A hashed copy of the same
                // cells, merged in, adds nothing (equal subtrees are skipped).
                by_view.complete_hashes();
                explored.complete_hashes();
                let mut copy = by_view.clone();
                copy.complete_hashes();
                prop_assert!(!by_walk.merge(&copy));
                by_walk.validate().unwrap();
            }
            let before: Vec<bool> = w.cells().map(|(x, y)| by_view.tree().cell_value(x, y)).collect();
            let mut reported = BTreeSet::new();
            let mut sets = Vec::new();
            let grew = by_view.mark_view_reporting(c, r, |set| {
                set.for_each_cell(|x, y| assert!(reported.insert((x, y)), "cell ({x}, {y}) reported twice"));
                sets.push(set);
            });
            by_walk.mark_reporting(&Disc { center: c, radius: r }, |_| {});
            by_view.validate().unwrap();
            prop_assert_eq!(by_view.known_cells(), by_walk.known_cells());
            prop_assert_eq!(grew, !reported.is_empty());
            let changed: BTreeSet<(u32, u32)> = w
                .cells()
                .zip(&before)
                .filter(|&((x, y), &was)| !was && by_view.tree().cell_value(x, y))
                .map(|(cell, _)| cell)
                .collect();
            prop_assert_eq!(&reported, &changed);
            for set in sets {
                let free = set_cells(&set).iter().filter(|&&(x, y)| !w.blocked(x, y)).count() as u64;
                prop_assert_eq!(obstacles.tree().count_cells_in_set(set, false), free);
                explored.mark_cells_reporting(set, |_| {});
            }
            explored.validate().unwrap();
        }
        for (x, y) in w.cells() {
            let v = by_walk.tree().cell_value(x, y);
            prop_assert_eq!(by_view.tree().cell_value(x, y), v, "cell ({}, {})", x, y);
            prop_assert_eq!(explored.tree().cell_value(x, y), v, "explored cell ({}, {})", x, y);
        }
        prop_assert_eq!(explored.known_cells(), by_walk.known_cells());
    }

    /// A view's rows (found by following the ends of each row's run) are exactly the cells
    /// a brute-force test over every cell finds wholly inside the disc and the clip, and
    /// taking one view's rows out of another's leaves exactly the set difference.
    #[test]
    fn view_rows_are_the_cells_wholly_inside(
        cell in prop_oneof![Just(1.0), 0.05f64..4.0], seed in any::<u64>()
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let origin = DVec2::new(rng.random_range(-900.0..900.0), rng.random_range(-900.0..900.0));
        let grid = Grid::new(origin, cell, 96, 80).unwrap();
        let e = grid.extent();
        let clip = if rng.random_bool(0.5) {
            e
        } else {
            let a = e.min + (e.max - e.min) * DVec2::new(rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            let b = e.min + (e.max - e.min) * DVec2::new(rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            Aabb { min: a.min(b), max: a.max(b) }
        };
        let brute = |d: &Disc| -> BTreeSet<(u32, u32)> {
            let r2 = d.radius * d.radius;
            (0..96u32).flat_map(|x| (0..80u32).map(move |y| (x, y))).filter(|&(x, y)| {
                let b = grid.square(x, y, 0);
                b.farthest_corner_distance_squared(d.center) <= r2 && b.distance_squared_to(d.center) < r2
                    && clip.contains_box(&b)
            }).collect()
        };
        let cells_of = |rows: &sim_core::spatial::CellRows| -> BTreeSet<(u32, u32)> {
            let mut out = BTreeSet::new();
            for (j, &row) in rows.rows[..rows.len].iter().enumerate() {
                for i in 0..64 {
                    if row >> i & 1 == 1 {
                        out.insert((rows.x0 + i, rows.y0 + j as u32));
                    }
                }
            }
            out
        };
        let mut c = e.min + (e.max - e.min) * DVec2::new(rng.random_range(-0.1..1.1), rng.random_range(-0.1..1.1));
        let mut last: Option<(sim_core::spatial::CellRows, BTreeSet<(u32, u32)>)> = None;
        for _ in 0..12 {
            let disc = Disc { center: c, radius: rng.random_range(0.0..31.0) * cell };
            let rows = disc.contained_rows(&grid, &clip).expect("at most 63 cells across");
            let want = brute(&disc);
            prop_assert_eq!(cells_of(&rows), want.clone(), "disc {:?}", disc);
            if let Some((old_rows, old)) = &last {
                // What marking takes of a view: its rows less the last view's (`row_from`).
                let mut fresh = rows.clone();
                for (j, row) in fresh.rows[..fresh.len].iter_mut().enumerate() {
                    *row &= !old_rows.row_from(fresh.y0 + j as u32, fresh.x0);
                }
                prop_assert_eq!(cells_of(&fresh), want.difference(old).copied().collect::<BTreeSet<_>>());
            }
            last = Some((rows, want));
            c += DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..70.0) * cell;
        }
    }

    /// Views wider than 64 cells take the walk that skips the last view; views jumping
    /// between both paths on a map of a few hundred cells mark what whole discs mark.
    #[test]
    fn wide_and_narrow_views_mark_what_whole_discs_mark(
        w in 65u32..300, h in 65u32..300, cell in prop_oneof![Just(1.0), 0.1f64..3.0], seed in any::<u64>()
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let origin = DVec2::new(rng.random_range(-500.0..500.0), rng.random_range(-500.0..500.0));
        let grid = Grid::new(origin, cell, w, h).unwrap();
        let mut by_view = KnownMap::new(grid);
        let mut by_disc = KnownMap::new(grid);
        let e = grid.extent();
        let mut c = e.min + (e.max - e.min) * DVec2::new(rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
        for _ in 0..12 {
            let r = rng.random_range(0.0..45.0) * cell;
            c += DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..8.0) * cell;
            prop_assert_eq!(by_view.mark_view(c, r), by_disc.mark_disc(c, r));
            by_view.validate().unwrap();
            prop_assert_eq!(by_view.known_cells(), by_disc.known_cells());
        }
        let mut a = Vec::new();
        by_view.tree().for_each_leaf(|sq, v| a.push((sq, v)));
        let mut b = Vec::new();
        by_disc.tree().for_each_leaf(|sq, v| b.push((sq, v)));
        prop_assert_eq!(a, b);
    }

    /// `may_mark` never says no where marking would add a cell: against brute force
    /// (an unknown cell of the map wholly inside the shape), for discs and for views beyond
    /// the last one, on maps partly known, partly in the map.
    #[test]
    fn may_mark_is_true_wherever_marking_adds(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut known = KnownMap::new(w.grid);
        for step in 0..24 {
            let c = w.random_point(&mut rng);
            let r = rng.random_range(0.0..5.0) * w.grid.cell_m();
            let seen = rng.random_bool(0.5).then(|| Disc {
                center: c + DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..1.5) * w.grid.cell_m(),
                radius: rng.random_range(0.0..5.0) * w.grid.cell_m(),
            });
            let shape = DiscBeyond { disc: Disc { center: c, radius: r }, seen };
            let adds = w.cells().any(|(x, y)| {
                let cell = w.grid.square(x, y, 0);
                w.grid.in_map(x, y)
                    && !known.tree().cell_value(x, y)
                    && shape.classify(&cell) == Overlap::Contains
            });
            let may = known.may_mark(&shape);
            prop_assert!(may || !adds, "step {step}: marking adds cells, may_mark says no");
            let before = known.known_cells();
            known.mark(&shape);
            prop_assert!(may || known.known_cells() == before);
            if step % 3 == 0 {
                known.mark_disc(w.random_point(&mut rng), rng.random_range(0.0..4.0) * w.grid.cell_m());
            }
        }
    }

    #[test]
    fn known_maps_mark_conservatively_and_merge_as_union(w in world_strategy(), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut maps = [KnownMap::new(w.grid), KnownMap::new(w.grid)];
        let mut truth = [vec![false; w.cells().count()], vec![false; w.cells().count()]];
        for step in 0..16 {
            let k = step % 2;
            let c = w.random_point(&mut rng);
            let r = rng.random_range(0.0..6.0) * w.grid.cell_m();
            let before = maps[k].known_cells();
            let grew = maps[k].mark_disc(c, r);
            maps[k].validate().unwrap();
            prop_assert_eq!(grew, maps[k].known_cells() > before);
            for (i, (x, y)) in w.cells().enumerate() {
                let cell = w.grid.square(x, y, 0);
                // Known iff wholly inside some marked disc, and inside the map.
                if w.grid.in_map(x, y) && cell.farthest_corner_distance_squared(c) <= r * r {
                    truth[k][i] = true;
                }
            }
        }
        for k in 0..2 {
            for (i, (x, y)) in w.cells().enumerate() {
                prop_assert_eq!(maps[k].tree().cell_value(x, y), truth[k][i]);
            }
        }
        let obstacles = w.map();
        let [mut a, b] = maps;
        a.merge(&b);
        a.validate().unwrap();
        let mut known_free = 0u64;
        for (i, (x, y)) in w.cells().enumerate() {
            let union = truth[0][i] || truth[1][i];
            prop_assert_eq!(a.tree().cell_value(x, y), union);
            known_free += u64::from(union && !w.blocked(x, y));
        }
        let cell_area = w.grid.cell_area_m2();
        prop_assert!((a.known_free_area_m2(&obstacles) - known_free as f64 * cell_area).abs() < 1e-6);
        // Merging again changes nothing; merging into an empty map copies exactly.
        prop_assert!(!a.merge(&b));
        let mut c = KnownMap::new(w.grid);
        c.merge(&a);
        c.validate().unwrap();
        prop_assert_eq!(c.leaf_count(), a.leaf_count());
    }

    #[test]
    /// With `lattice`, points and radii on a 2.5 m lattice, which the index's split lines
    /// (halvings of the area) fall on too: treasures and discs exactly on a split line or
    /// exactly a radius beyond it (the disc walk skips children across a split line farther
    /// than the radius).
    fn treasure_index_matches_brute_force(seed in any::<u64>(), n in 1usize..300, clustered in any::<bool>(), lattice in any::<bool>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let area = Aabb::from_corners(DVec2::new(-20.0, 5.0), DVec2::new(80.0, 45.0));
        let mut index = TreasureIndex::new(area).unwrap();
        let mut live: Vec<(TreasureId, DVec2, u32)> = Vec::new();
        let point = |rng: &mut ChaCha8Rng| if lattice {
            DVec2::new(-20.0 + 2.5 * f64::from(rng.random_range(0..40)), 5.0 + 2.5 * f64::from(rng.random_range(0..16)))
        } else if clustered {
            DVec2::new(10.0 + rng.random_range(0.0..0.5), 20.0 + rng.random_range(0.0..0.5))
        } else {
            DVec2::new(rng.random_range(-20.0..80.0), rng.random_range(5.0..45.0))
        };
        for _ in 0..n {
            match rng.random_range(0..10) {
                0..=5 => {
                    let p = point(&mut rng);
                    let q = rng.random_range(1..100);
                    let id = index.insert(p, q).unwrap();
                    live.push((id, p, q));
                }
                6..=7 if !live.is_empty() => {
                    let (id, p, q) = live.swap_remove(rng.random_range(0..live.len()));
                    let t = index.remove(id).unwrap();
                    prop_assert_eq!((t.position, t.quantity), (p, q));
                    prop_assert!(index.remove(id).is_none());
                }
                _ if !live.is_empty() => {
                    let i = rng.random_range(0..live.len());
                    live[i].2 = rng.random_range(0..100);
                    prop_assert!(index.set_quantity(live[i].0, live[i].2));
                }
                _ => {}
            }
            index.validate().unwrap();
            prop_assert_eq!(index.len(), live.len());
            let c = point(&mut rng);
            let r = if lattice { 2.5 * f64::from(rng.random_range(0..8)) } else { rng.random_range(0.0..30.0) };
            let mut got = Vec::new();
            index.for_each_in_disc(c, r, |t| got.push((t.id, t.quantity)));
            got.sort();
            let mut want: Vec<_> = live.iter().filter(|t| t.1.distance(c) <= r).map(|t| (t.0, t.2)).collect();
            want.sort();
            prop_assert_eq!(got, want);
            let best = live.iter().min_by(|a, b| a.1.distance_squared(c).total_cmp(&b.1.distance_squared(c)).then(a.0.cmp(&b.0)));
            prop_assert_eq!(index.nearest(c).map(|t| t.id), best.map(|t| t.0));
            let best_rich = live.iter().filter(|t| t.2 >= 50)
                .min_by(|a, b| a.1.distance_squared(c).total_cmp(&b.1.distance_squared(c)).then(a.0.cmp(&b.0)));
            prop_assert_eq!(index.nearest_where(c, |t| t.quantity >= 50).map(|t| t.id), best_rich.map(|t| t.0));
        }
    }

    #[test]
    fn robot_index_matches_brute_force(seed in any::<u64>(), n in 0usize..400, cell in 0.2f64..30.0, dense in any::<bool>(), lattice in any::<bool>()) {
        robot_index_against_brute_force(seed, n, cell, dense, lattice)?;
    }
}

/// Robots in a random index, queried at random discs, against a scan of them all.
fn robot_index_against_brute_force(
    seed: u64,
    n: usize,
    cell: f64,
    dense: bool,
    lattice: bool,
) -> Result<(), TestCaseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // From robots sharing a few cells (laid out densely when allowed) to robots spread
    // over thousands of cells each (hashed).
    let spread = rng.random_range(0.1..5_000.0);
    // On a lattice of half cells, robots, query centres and radii meet cell edges and
    // disc rims exactly.
    let snap = |v: f64| {
        if lattice {
            (v / (0.5 * cell)).round() * 0.5 * cell
        } else {
            v
        }
    };
    let robots: Vec<(RobotId, DVec2)> = (0..n)
        .map(|i| {
            (
                RobotId::new(i as u32),
                DVec2::new(
                    snap(rng.random_range(-spread..spread)),
                    snap(rng.random_range(-spread..spread)),
                ),
            )
        })
        .collect();
    let mut index = if dense {
        RobotIndex::dense_when_compact()
    } else {
        RobotIndex::new()
    };
    // Rebuilt twice, as every round does, to catch stale state.
    index.rebuild(robots.iter().rev().copied(), cell * 2.0);
    index.rebuild(robots.iter().copied(), cell);
    prop_assert_eq!(index.len(), n);
    for _ in 0..20 {
        let p = DVec2::new(
            snap(rng.random_range(-spread..spread)),
            snap(rng.random_range(-spread..spread)),
        );
        let r = if rng.random_bool(0.5) {
            snap(rng.random_range(0.0..spread))
        } else {
            rng.random_range(0.0..4.0 * cell)
        };
        let mut got = Vec::new();
        index.for_each_within(p, r, |id, q| got.push((id, q.x.to_bits(), q.y.to_bits())));
        got.sort();
        let want: Vec<_> = robots
            .iter()
            .filter(|(_, q)| q.distance_squared(p) <= r * r)
            .map(|(id, q)| (*id, q.x.to_bits(), q.y.to_bits()))
            .collect();
        prop_assert_eq!(got, want);
    }
    Ok(())
}

/// A robot exactly on a query's rim (within it by the distance test's rounding) but an ulp
/// beyond the disc's box as computed is found.
#[test]
fn a_robot_on_the_rim_is_found() {
    robot_index_against_brute_force(5_754_087_576_751_234_071, 101, 24.885_231_390_557_37, false, true).unwrap();
}

#[test]
fn marking_the_same_area_again_costs_no_memory() {
    let grid = Grid::new(DVec2::ZERO, 1.0, 512, 512).unwrap();
    let mut known = KnownMap::new(grid);
    for i in 0..50 {
        known.mark_disc(DVec2::new(100.0 + f64::from(i), 100.0), 20.0);
    }
    let bytes = known.memory_bytes();
    let leaves = known.leaf_count();
    for _ in 0..5 {
        for i in 0..50 {
            assert!(!known.mark_disc(DVec2::new(100.0 + f64::from(i), 100.0), 20.0));
        }
    }
    assert_eq!(known.memory_bytes(), bytes);
    assert_eq!(known.leaf_count(), leaves);
    known.validate().unwrap();
}

#[test]
fn known_map_memory_is_reused_after_merges_into_big_leaves() {
    let grid = Grid::new(DVec2::ZERO, 1.0, 256, 256).unwrap();
    let mut known = KnownMap::new(grid);
    // A ring of small discs makes many nodes; covering it all collapses them to one leaf
    // and the released nodes serve later marks without growing the store.
    for i in 0..64 {
        let a = f64::from(i) / 64.0 * std::f64::consts::TAU;
        known.mark_disc(DVec2::new(128.0, 128.0) + DVec2::from_angle(a) * 60.0, 6.0);
    }
    let peak = known.memory_bytes();
    known.mark(&Aabb::from_corners(DVec2::ZERO, DVec2::splat(256.0)));
    assert_eq!(known.leaf_count(), 1);
    assert!((known.known_area_m2() - 65536.0).abs() < 1e-9);
    let mut other = KnownMap::new(grid);
    for i in 0..64 {
        let a = f64::from(i) / 64.0 * std::f64::consts::TAU;
        other.mark_disc(DVec2::new(128.0, 128.0) + DVec2::from_angle(a) * 60.0, 6.0);
    }
    assert_eq!(other.memory_bytes(), peak);
    other.validate().unwrap();
}

proptest! {
    #![proptest_config(config(128))]

    #[test]
    fn square_value_matches_the_cells(w in world_strategy()) {
        let tree = RegionQuadtree::from_bitgrid(w.grid, &w.bits, true).unwrap();
        let depth = w.grid.depth();
        for level in 0..=depth {
            let side = 1u32 << level;
            for y in (0..w.grid.side_cells()).step_by(side as usize) {
                for x in (0..w.grid.side_cells()).step_by(side as usize) {
                    let cells: Vec<bool> = (y..y + side).flat_map(|cy| (x..x + side).map(move |cx| (cx, cy)))
                        .map(|(cx, cy)| w.blocked(cx, cy)).collect();
                    let want = if cells.iter().all(|&c| c) { Some(true) } else if cells.iter().all(|&c| !c) { Some(false) } else { None };
                    prop_assert_eq!(tree.square_value(Square { x, y, level }), want, "square ({}, {}) level {}", x, y, level);
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// The cells of a small rectangle, visited by descents to its blocks (the robots' move
    /// tests), are exactly the brute-force raster's; rectangles over more than 2 × 2
    /// blocks, and trees too small for blocks, are refused without a visit.
    #[test]
    fn cells_in_small_rectangles_match_the_raster(
        w in world_strategy(),
        corner in (0u32..64, 0u32..64),
        size in (0u32..20, 0u32..20),
        value in any::<bool>(),
    ) {
        let tree = RegionQuadtree::from_bitgrid(w.grid, &w.bits, true).unwrap();
        let side = w.grid.side_cells();
        let (x0, y0) = (corner.0 % side, corner.1 % side);
        let (x1, y1) = ((x0 + size.0).min(side - 1), (y0 + size.1).min(side - 1));
        let mut got = BTreeSet::new();
        let flow = tree.visit_cells_in_rect((x0, y0), (x1, y1), value, |x, y| {
            assert!(got.insert((x, y)), "({x}, {y}) visited twice");
            std::ops::ControlFlow::Continue(())
        });
        let blocks = |a: u32, b: u32| (b >> 3) - (a >> 3) + 1;
        if w.grid.depth() < 3 || blocks(x0, x1) > 2 || blocks(y0, y1) > 2 {
            prop_assert!(flow.is_none() && got.is_empty());
        } else {
            prop_assert!(flow.is_some_and(|f| f.is_continue()));
            let want: BTreeSet<(u32, u32)> = (y0..=y1)
                .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
                .filter(|&(x, y)| w.blocked(x, y) == value)
                .collect();
            prop_assert_eq!(got, want);
        }
    }
}

proptest! {
    #![proptest_config(config(96))]

    #[test]
    fn squares_holding_a_value_cover_exactly_the_coarse_cells_that_hold_it(w in world_strategy()) {
        let tree = RegionQuadtree::from_bitgrid(w.grid, &w.bits, true).unwrap();
        let n = w.grid.side_cells();
        for value in [false, true] {
            for min_level in 0..=w.grid.depth() {
                let side = 1u32 << min_level;
                let mut covered = BTreeSet::new();
                tree.for_each_square_holding(value, min_level, |sq| {
                    assert!(sq.level >= min_level, "{sq:?} finer than level {min_level}");
                    let k = 1u32 << (sq.level - min_level);
                    for y in 0..k {
                        for x in 0..k {
                            assert!(covered.insert(((sq.x >> min_level) + x, (sq.y >> min_level) + y)), "overlap at {sq:?}");
                        }
                    }
                });
                let mut want = BTreeSet::new();
                for cy in 0..n {
                    for cx in 0..n {
                        if w.blocked(cx, cy) == value {
                            want.insert((cx / side, cy / side));
                        }
                    }
                }
                prop_assert_eq!(&covered, &want, "value {} level {}", value, min_level);
            }
        }
    }
}

/// The cells of an 8 × 8 block of `cell_m` cells from `origin`.
fn block_cells(origin: DVec2, cell_m: f64) -> sim_core::spatial::BlockCells {
    let corner = |i: u32| origin + DVec2::splat(f64::from(i) * cell_m);
    sim_core::spatial::BlockCells {
        xs: std::array::from_fn(|i| corner(i as u32).x),
        ys: std::array::from_fn(|i| corner(i as u32).y),
    }
}

proptest! {
    #![proptest_config(config(512))]

    /// The packed bottom trusts `classify_cells` to agree with `classify` on every cell,
    /// for every shape that answers it.
    #[test]
    fn classify_cells_agrees_with_classify_cell_by_cell(
        seed in any::<u64>(),
        cell_m in 0.05f64..5.0,
        kind in 0usize..9,
    ) {
        use sim_core::spatial::{CellMasks, Clipped, DiscBeyond};
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let origin = DVec2::new(rng.random_range(-100.0..100.0), rng.random_range(-100.0..100.0));
        let cells = block_cells(origin, cell_m);
        let side = 8.0 * cell_m;
        let mut point = || origin + DVec2::new(rng.random_range(-0.5..1.5), rng.random_range(-0.5..1.5)) * side;
        let (p, q) = (point(), point());
        // Radii and boxes on the scale of the block, and points on cell corners, so the
        // boundary cases (a corner exactly on the rim) come up.
        let r = side * rng.random_range(0.05..1.0);
        let snapped = (p / cell_m).round() * cell_m;
        let disc = Disc { center: if kind == 4 { snapped } else { p }, radius: r };
        let shape: Box<dyn Shape> = match kind {
            0 | 4 => Box::new(disc),
            1 => Box::new(Aabb { min: p.min(q), max: p.max(q) }),
            2 => Box::new(DiscBeyond { disc, seen: Some(Disc { center: q, radius: r }) }),
            // A robot's move (short, a small radius) and a segment.
            5 => Box::new(Capsule { a: p, b: p + (q - p) * 0.1, radius: r * 0.2 }),
            6 => Box::new(Capsule { a: snapped, b: q, radius: 0.0 }),
            // A route's shortcut (a long slanting leg), and one nearly level, whose rows
            // are bounded without dividing by its rise.
            7 => Box::new(Capsule { a: p, b: q, radius: r * 0.3 }),
            8 => Box::new(Capsule { a: snapped, b: DVec2::new(q.x, snapped.y + (q.y - p.y) * 1e-5), radius: r * 0.3 }),
            _ => Box::new(Clipped { shape: disc, clip: Aabb { min: p.min(q), max: p.max(q) } }),
        };
        let got = shape.classify_cells(&cells).expect("this shape classifies cells at once");
        let mut want = CellMasks { contains: 0, intersects: 0 };
        for j in 0..8 {
            for i in 0..8 {
                let b = Aabb {
                    min: DVec2::new(cells.xs[i], cells.ys[j]),
                    max: DVec2::new(cells.xs[i + 1], cells.ys[j + 1]),
                };
                let bit = 1u64 << (8 * j + i);
                match shape.classify(&b) {
                    Overlap::Disjoint => {}
                    Overlap::Partial => want.intersects |= bit,
                    Overlap::Contains => {
                        want.intersects |= bit;
                        want.contains |= bit;
                    }
                }
            }
        }
        prop_assert_eq!(got, want);
        prop_assert_eq!(shape.intersects_cells(&cells), Some(want.intersects));
    }

    /// A block's cells whose part in a box lies near a point, at once, are those the box
    /// and distance tests find cell by cell, to the last bit (the nearest unknown point's
    /// walk reads a block's cells this way). Boxes on cell edges and points on cell corners
    /// come up, and limits exactly at a cell's distance.
    #[test]
    fn cells_with_part_near_match_the_tests_cell_by_cell(
        seed in any::<u64>(),
        cell_m in 0.05f64..5.0,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let origin = DVec2::new(rng.random_range(-1000.0..1000.0), rng.random_range(-1000.0..1000.0));
        let cells = block_cells(origin, cell_m);
        let side = 8.0 * cell_m;
        let mut point = |snap: bool| {
            let p = origin + DVec2::new(rng.random_range(-0.5..1.5), rng.random_range(-0.5..1.5)) * side;
            if snap { origin + ((p - origin) / cell_m).round() * cell_m } else { p }
        };
        let (a, b, p) = (point(seed % 2 == 0), point(seed % 3 == 0), point(seed % 5 == 0));
        let area = Aabb { min: a.min(b), max: a.max(b) };
        let cell = |i: usize, j: usize| Aabb {
            min: DVec2::new(cells.xs[i], cells.ys[j]),
            max: DVec2::new(cells.xs[i + 1], cells.ys[j + 1]),
        };
        let part_d = |c: &Aabb| Aabb { min: c.min.max(area.min), max: c.max.min(area.max) }.distance_squared_to(p);
        // A limit exactly at some cell's distance half the time (a cell the box meets: only
        // those have a part).
        let (i, j) = (rng.random_range(0..8), rng.random_range(0..8));
        let limit = if rng.random_bool(0.5) && area.overlaps_open(&cell(i, j)) {
            part_d(&cell(i, j))
        } else {
            rng.random_range(0.0..4.0) * side * side
        };
        let mut want = 0u64;
        for j in 0..8 {
            for i in 0..8 {
                let c = cell(i, j);
                if area.overlaps_open(&c) && part_d(&c) <= limit {
                    want |= 1 << (8 * j + i);
                }
            }
        }
        prop_assert_eq!(area.cells_with_part_near(&cells, p, limit), want);
    }
}

/// Views whose rim passes exactly through grid corners (centres on grid corners or cell
/// centres, whole radii: the 3-4-5 corners of a 5-cell view lie on it) keep the cells whose
/// farthest corner is on the rim, as the brute-force test does, near the map's edge as well
/// as away from it (the rows skip the per-line clip tests when the view's cells all lie
/// inside the map).
#[test]
fn view_rows_keep_cells_whose_corner_is_on_the_rim() {
    let grid = Grid::new(DVec2::ZERO, 1.0, 64, 64).unwrap();
    let clip = grid.extent();
    for center in [
        DVec2::new(20.0, 20.0),
        DVec2::new(20.5, 20.5),
        DVec2::new(3.0, 4.0),
        DVec2::new(0.5, 60.5),
    ] {
        for radius in [1.0, 2.0, 5.0, 10.0, 13.0] {
            let disc = Disc { center, radius };
            let rows = disc.contained_rows(&grid, &clip).expect("at most 63 cells across");
            let mut got = BTreeSet::new();
            for (j, &row) in rows.rows[..rows.len].iter().enumerate() {
                for i in 0..64 {
                    if row >> i & 1 == 1 {
                        got.insert((rows.x0 + i, rows.y0 + j as u32));
                    }
                }
            }
            let r2 = radius * radius;
            let want: BTreeSet<(u32, u32)> = (0..64u32)
                .flat_map(|x| (0..64u32).map(move |y| (x, y)))
                .filter(|&(x, y)| {
                    let corners = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)];
                    corners
                        .iter()
                        .all(|&(cx, cy)| (f64::from(cx) - center.x).powi(2) + (f64::from(cy) - center.y).powi(2) <= r2)
                })
                .collect();
            assert_eq!(got, want, "centre {center}, radius {radius}");
        }
    }
    // By hand: the 5-cell view centred on the corner (20, 20) holds cell (22, 23), whose
    // corners lie (2..3, 3..4) off the centre: the farthest, (3, 4), exactly on the rim
    // (3² + 4² = 5²); and not cell (23, 23), whose farthest corner (4, 4) is 32 > 25 away.
    let disc = Disc {
        center: DVec2::new(20.0, 20.0),
        radius: 5.0,
    };
    let rows = disc.contained_rows(&grid, &clip).unwrap();
    assert_eq!(
        rows.row_from(23, 22) & 1,
        1,
        "cell (22, 23), far corner (23, 24) on the rim"
    );
    assert_eq!(
        rows.row_from(23, 23) & 1,
        0,
        "cell (23, 23), far corner (24, 24) outside"
    );
}

proptest! {
    #![proptest_config(config(24))]

    /// Views marked through the window of known cells around them (maps at least 64 cells a
    /// side, views at most 32 cells across) hold exactly the cells the general walk marks
    /// and report exactly the cells that changed; walks that leave the window (it is loaded
    /// again), views too wide for it, views at the map's edges, and merges between views
    /// (the window is forgotten) included. `validate` checks the window against the tree
    /// after every mark and merge.
    #[test]
    fn views_through_the_known_window_are_the_walks_cells(
        size in (64u32..200, 64u32..200),
        cell_m in prop_oneof![Just(1.0), Just(0.5), 0.2f64..2.0],
        seed in any::<u64>(),
    ) {
        let w = World::generate(size.0, size.1, 0.3, cell_m, seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x77);
        let mut by_view = KnownMap::new(w.grid);
        let mut by_walk = KnownMap::new(w.grid);
        let mut c = w.random_point(&mut rng);
        let mut r = rng.random_range(0.5..15.0) * cell_m;
        for step in 0..120 {
            match rng.random_range(0..40) {
                0 => c = w.random_point(&mut rng),
                1 => r = rng.random_range(0.5..15.0) * cell_m,
                2 => r = rng.random_range(16.5..24.0) * cell_m,
                3 => {}
                _ => c += DVec2::from_angle(rng.random_range(0.0..6.3)) * rng.random_range(0.0..2.0) * cell_m,
            }
            if step % 25 == 24 {
                let mut other = KnownMap::new(w.grid);
                other.mark_disc(c + DVec2::new(3.0, -2.0) * cell_m, 4.0 * cell_m);
                by_view.merge(&other);
                by_walk.merge(&other);
                by_view.validate().unwrap();
            }
            let before = by_walk.clone();
            let mut reported = BTreeSet::new();
            let grew = by_view.mark_view_reporting(c, r, |set| {
                set.for_each_cell(|x, y| assert!(reported.insert((x, y)), "cell ({x}, {y}) reported twice"));
            });
            by_walk.mark_reporting(&Disc { center: c, radius: r }, |_| {});
            by_view.validate().unwrap();
            prop_assert_eq!(by_view.known_cells(), by_walk.known_cells());
            prop_assert_eq!(grew, !reported.is_empty());
            for &(x, y) in &reported {
                prop_assert!(!before.tree().cell_value(x, y) && by_walk.tree().cell_value(x, y), "cell ({}, {})", x, y);
            }
            prop_assert_eq!(reported.len() as u64, by_walk.known_cells() - before.known_cells());
        }
        for (x, y) in w.cells() {
            prop_assert_eq!(by_view.tree().cell_value(x, y), by_walk.tree().cell_value(x, y), "cell ({}, {})", x, y);
        }
    }
}
