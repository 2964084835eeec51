//! The packed bottom changes storage, not the tree: a packed tree and its unpacked twin
//! (groups down to single cells, no blocks) get the same random updates and must agree on
//! every leaf, count, visit order and byte.

use std::collections::BTreeSet;
use std::ops::ControlFlow;

use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{PartialCells, RegionQuadtree, Square};
use crate::spatial::geometry::{Aabb, Capsule, Clipped, Disc, DiscBeyond, Shape};
use crate::spatial::grid::Grid;

/// A shape of a random kind over the grid: each kind the packed bottom handles by cell
/// masks (disc, box, clipped disc) and one it handles square by square (capsule, which
/// does not classify cells at once).
fn random_shape(rng: &mut ChaCha8Rng, grid: &Grid) -> Box<dyn Shape> {
    let e = grid.extent();
    let size = e.max - e.min;
    let mut point = || e.min - size * 0.1 + size * 1.2 * DVec2::new(rng.random(), rng.random());
    let (p, q) = (point(), point());
    let r = size.max_element() * rng.random_range(0.02..0.4);
    match rng.random_range(0..4) {
        0 => Box::new(Disc { center: p, radius: r }),
        1 => Box::new(Aabb {
            min: p.min(q),
            max: p.max(q),
        }),
        2 => Box::new(Clipped {
            shape: Disc { center: p, radius: r },
            clip: Aabb {
                min: p.min(q),
                max: p.max(q),
            },
        }),
        _ => Box::new(Capsule {
            a: p,
            b: q,
            radius: r * 0.2,
        }),
    }
}

fn leaves(t: &RegionQuadtree) -> Vec<(Square, bool)> {
    let mut out = Vec::new();
    t.for_each_leaf(|sq, v| out.push((sq, v)));
    out
}

fn cells_of(squares: &[Square]) -> BTreeSet<(u32, u32)> {
    let mut out = BTreeSet::new();
    for sq in squares {
        for y in sq.y..sq.y + sq.side_cells() {
            for x in sq.x..sq.x + sq.side_cells() {
                assert!(out.insert((x, y)), "cell ({x}, {y}) reported twice");
            }
        }
    }
    out
}

fn assert_same(packed: &RegionQuadtree, twin: &RegionQuadtree, what: &str) {
    packed.assert_well_formed();
    twin.assert_well_formed();
    assert!(!twin.packed);
    assert_eq!(leaves(packed), leaves(twin), "{what}: leaves");
    assert_eq!(packed.leaf_count(), twin.leaf_count(), "{what}: leaf count");
    assert_eq!(packed.leaf_count(), leaves(packed).len(), "{what}: counted leaves");
    let (mut a, mut b) = (Vec::new(), Vec::new());
    packed.encode_preorder(&mut a);
    twin.encode_preorder(&mut b);
    assert_eq!(a, b, "{what}: encoding");
}

fn random_tree(rng: &mut ChaCha8Rng, grid: Grid) -> RegionQuadtree {
    let density = rng.random_range(0.0..1.0);
    let clumpy = rng.random_bool(0.5);
    RegionQuadtree::from_fn(grid, rng.random(), |x, y| {
        if clumpy {
            (x / 5 + y / 3) % 3 == 0
        } else {
            rng.random_bool(density)
        }
    })
}

/// A tree to merge into `tree`: keeping hashes, mostly a copy of it with one shape filled
/// or cleared, hashed as a shared known map is (alike in most subtrees, so the union skips
/// them); else a random tree.
fn union_partner(rng: &mut ChaCha8Rng, tree: &RegionQuadtree, hashing: bool) -> RegionQuadtree {
    if hashing && rng.random_bool(0.7) {
        let mut copy = tree.clone();
        let shape = random_shape(rng, tree.grid());
        copy.fill(&&*shape, rng.random_bool(0.5), PartialCells::Include);
        copy.complete_hashes();
        copy
    } else {
        random_tree(rng, *tree.grid())
    }
}

#[test]
fn packed_trees_are_the_unpacked_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xB10C);
    for case in 0..120 {
        let (w, h) = (rng.random_range(1..70), rng.random_range(1..70));
        let origin = DVec2::new(rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0));
        let grid = Grid::new(origin, rng.random_range(0.1..3.0), w, h).unwrap();
        let mut packed = random_tree(&mut rng, grid);
        let mut twin = packed.unpacked();
        assert_eq!(packed.packed, grid.depth() >= 3);
        assert_same(&packed, &twin, &format!("case {case}: built"));
        let mut bytes = Vec::new();
        packed.encode_preorder(&mut bytes);
        let decoded = RegionQuadtree::decode_preorder(grid, &bytes, packed.encoded_node_count()).unwrap();
        assert_eq!(decoded.packed, packed.packed);
        assert_same(&decoded, &twin, &format!("case {case}: decoded"));

        // Odd cases keep content hashes (unions skip subtrees equal to the other tree's),
        // worked out again now and then, so that fills and unions must forget those they
        // change: every check below validates each hash kept.
        let hashing = case % 2 == 1;
        for step in 0..12 {
            let what = format!("case {case} step {step}");
            if hashing && (step == 0 || rng.random_bool(0.3)) {
                packed.complete_hashes();
                assert!(packed.keeps_hashes() || packed.groups.is_empty(), "{what}");
            }
            let shape = random_shape(&mut rng, &grid);
            if rng.random_bool(0.25) {
                let other = union_partner(&mut rng, &packed, hashing);
                let added = packed.union_counting(&other);
                assert_eq!(added, twin.union_counting(&other.unpacked()), "{what}: union count");
                assert_same(&packed, &twin, &format!("{what}: union"));
                continue;
            }
            if rng.random_bool(0.2) {
                // A moving view, as known maps mark it: what the last view wholly covered
                // is known already, so squares inside it may be skipped either way.
                let b = shape.bounds();
                let (center, radius) = ((b.min + b.max) * 0.5, (b.max - b.min).min_element() * 0.5);
                let seen = Disc {
                    center: center + DVec2::new(radius * 0.1, 0.0),
                    radius,
                };
                let view = DiscBeyond {
                    disc: Disc { center, radius },
                    seen: Some(seen),
                };
                for t in [&mut packed, &mut twin] {
                    t.fill(&seen, true, PartialCells::Exclude);
                }
                let (mut a, mut b) = (Vec::new(), Vec::new());
                packed.fill_reporting(&view, true, PartialCells::Exclude, |sq| a.push(sq));
                twin.fill_reporting(&view, true, PartialCells::Exclude, |sq| b.push(sq));
                assert_eq!(cells_of(&a), cells_of(&b), "{what}: cells a moving view adds");
                assert_same(&packed, &twin, &format!("{what}: moving view"));
                continue;
            }
            let value = rng.random_bool(0.6);
            let partial = if rng.random_bool(0.5) {
                PartialCells::Include
            } else {
                PartialCells::Exclude
            };
            let (mut a, mut b) = (Vec::new(), Vec::new());
            packed.fill_reporting(&&*shape, value, partial, |sq| a.push(sq));
            twin.fill_reporting(&&*shape, value, partial, |sq| b.push(sq));
            assert_eq!(cells_of(&a), cells_of(&b), "{what}: changed cells");
            assert_same(&packed, &twin, &format!("{what}: fill"));

            // Queries: the same leaves in the same order, the same answers.
            let probe = random_shape(&mut rng, &grid);
            let v = rng.random_bool(0.5);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let _ = packed.visit_leaves_in(&&*probe, v, |sq, _| {
                a.push(sq);
                ControlFlow::Continue(())
            });
            let _ = twin.visit_leaves_in(&&*probe, v, |sq, _| {
                b.push(sq);
                ControlFlow::Continue(())
            });
            if probe
                .classify_cells(&packed.block_cells(Square { x: 0, y: 0, level: 3 }))
                .is_none()
            {
                // Shapes walked square by square keep the order exactly (nearest-point
                // searches break ties by it).
                assert_eq!(a, b, "{what}: visit order");
            }
            let key = |sq: &Square| (sq.x, sq.y, sq.level);
            let (sorted_a, sorted_b): (BTreeSet<_>, BTreeSet<_>) =
                (a.iter().map(key).collect(), b.iter().map(key).collect());
            assert_eq!(a.len(), sorted_a.len(), "{what}: a leaf visited twice");
            assert_eq!(sorted_a, sorted_b, "{what}: visited leaves");
            assert_eq!(packed.count_cells_where(true, &twin, false), 0, "{what}");
            assert_eq!(packed.count_cells(true), twin.count_cells(true), "{what}");
            let (x, y) = (rng.random_range(0..w), rng.random_range(0..h));
            assert_eq!(packed.cell_value(x, y), twin.cell_value(x, y), "{what}");
            let dir = DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU));
            let o = grid.extent().min + (grid.extent().max - grid.extent().min) * rng.random::<f64>();
            assert_eq!(
                packed.first_hit(o, dir, 50.0, v),
                twin.first_hit(o, dir, 50.0, v),
                "{what}"
            );
        }
        packed.compact();
        assert_same(&packed, &twin, &format!("case {case}: compacted"));
    }
}

/// `any_cell_in_rect` and `values_in_rect` against the cells one by one, on random trees
/// (packed and not) and random rectangles.
#[test]
fn any_cell_in_rect_matches_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for case in 0..60 {
        let grid = Grid::new(DVec2::ZERO, 1.0, 40, 24).unwrap();
        let density = rng.random_range(0.0..0.5);
        let blocky = rng.random_bool(0.5);
        let cells: Vec<bool> = (0..40 * 24).map(|_| rng.random_bool(density)).collect();
        let value_at = |x: u32, y: u32| {
            if blocky {
                // Clusters, so that large uniform leaves and mixed nodes both occur.
                cells[((y / 4) * 40 + x / 4) as usize]
            } else {
                cells[(y * 40 + x) as usize]
            }
        };
        let packed = RegionQuadtree::from_fn(grid, false, value_at);
        let unpacked = packed.unpacked();
        // Fingers kept across the queries, so that descents start from where earlier ones
        // passed.
        let mut fingers = [super::Finger::new(&packed), super::Finger::new(&unpacked)];
        let side = grid.side_cells();
        for k in 0..200 {
            let (x0, x1) = (rng.random_range(0..side), rng.random_range(0..side));
            let (y0, y1) = (rng.random_range(0..side), rng.random_range(0..side));
            let (lo, mut hi) = ((x0.min(x1), y0.min(y1)), (x0.max(x1), y0.max(y1)));
            if k % 2 == 0 {
                // Small ones too, as navigation pieces mostly are (the descent goes
                // straight to the square that holds them).
                hi = (
                    (lo.0 + rng.random_range(0..4)).min(side - 1),
                    (lo.1 + rng.random_range(0..4)).min(side - 1),
                );
            }
            let brute = |value: bool| {
                (lo.1..=hi.1).any(|y| {
                    (lo.0..=hi.0).any(|x| {
                        let inside = x < 40 && y < 24;
                        (if inside { value_at(x, y) } else { false }) == value
                    })
                })
            };
            for (tree, finger) in [&packed, &unpacked].into_iter().zip(&mut fingers) {
                assert_eq!(
                    tree.values_in_rect_from(finger, lo, hi),
                    (brute(false), brute(true)),
                    "case {case}: {lo:?}..={hi:?} from a finger"
                );
                for value in [false, true] {
                    assert_eq!(
                        tree.any_cell_in_rect(lo, hi, value),
                        brute(value),
                        "case {case}: {lo:?}..={hi:?} {value}"
                    );
                }
                // Both answers from one descent.
                assert_eq!(
                    tree.values_in_rect(lo, hi),
                    (brute(false), brute(true)),
                    "case {case}: {lo:?}..={hi:?}"
                );
            }
        }
    }
}

/// A view's rows are filled block by block (`fill_new_rows_reporting`). Rows that complete
/// whole squares (merged into one leaf while the call goes on), clear cells (splitting
/// leaves, reusing freed nodes) and revisit blocks of a square merged earlier in the same
/// call leave exactly the cells a brute-force grid holds, report exactly those that
/// switched, and keep the tree well formed (odd cases keep content hashes, worked out again
/// every few calls, which each fill must forget where it changes cells).
#[test]
fn rows_filled_block_by_block_match_a_grid() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x9A7B);
    let grid = Grid::new(DVec2::ZERO, 1.0, 96, 80).unwrap();
    let side = grid.side_cells();
    for case in 0..40 {
        let mut tree = RegionQuadtree::uniform(grid, false);
        let mut brute = vec![false; (side * side) as usize];
        for call in 0..60 {
            if case % 2 == 1 && call % 3 == 0 {
                tree.complete_hashes();
                // And a whole aligned square set by its own descent, now and then.
                let level = rng.random_range(3..=5u8);
                let (x, y) = (
                    rng.random_range(0..side) >> level << level,
                    rng.random_range(0..side) >> level << level,
                );
                let value = rng.random_bool(0.5);
                tree.fill_square_reporting(Square { x, y, level }, value, |_| {});
                tree.assert_well_formed();
                for (cy, cx) in (y..y + (1 << level)).flat_map(|cy| (x..x + (1 << level)).map(move |cx| (cy, cx))) {
                    brute[(cy * side + cx) as usize] = value;
                }
            }
            let value = rng.random_bool(0.75);
            let mut rows = crate::spatial::geometry::CellRows::empty();
            // Half the time at a block's edge, as a view over whole blocks.
            let align = if rng.random_bool(0.5) { !7 } else { !0 };
            rows.x0 = rng.random_range(0..side - 8) & align;
            rows.y0 = rng.random_range(0..side - 8);
            rows.len = rng.random_range(1..=64).min((side - rows.y0) as usize);
            let width = (side - rows.x0).min(64);
            let full = if width == 64 { u64::MAX } else { (1u64 << width) - 1 };
            // Dense rows complete squares; a run of full rows completes them in one call.
            let dense = rng.random_bool(0.5);
            for row in &mut rows.rows[..rows.len] {
                *row = if dense { full } else { rng.random::<u64>() & full };
            }
            let mut switched = BTreeSet::new();
            let ok = tree.fill_new_rows_reporting(&rows, value, |set| {
                set.for_each_cell(|x, y| assert!(switched.insert((x, y)), "case {case}.{call}: ({x}, {y}) twice"));
            });
            assert!(ok, "a packed tree fills rows");
            tree.assert_well_formed();
            let mut expected = BTreeSet::new();
            for (j, &row) in rows.rows[..rows.len].iter().enumerate() {
                let y = rows.y0 + j as u32;
                for i in 0..64 {
                    let x = rows.x0 + i;
                    if row >> i & 1 == 1 && brute[(y * side + x) as usize] != value {
                        brute[(y * side + x) as usize] = value;
                        expected.insert((x, y));
                    }
                }
            }
            assert_eq!(switched, expected, "case {case}.{call}: switched cells");
            for y in 0..side {
                for x in 0..side {
                    assert_eq!(
                        tree.cell_value(x, y),
                        brute[(y * side + x) as usize],
                        "case {case}.{call}: ({x}, {y})"
                    );
                }
            }
        }
    }
}

/// Descents that start from a finger (moved by each query to the ancestor at its level)
/// answer as descents from the root, on a tree deep enough for the finger to move: runs of
/// queries close together, then far apart.
#[test]
fn values_in_rect_from_a_finger_match_the_root_descent() {
    let mut rng = ChaCha8Rng::seed_from_u64(1212);
    let grid = Grid::new(DVec2::ZERO, 1.0, 300, 200).unwrap();
    let cells: Vec<bool> = (0..300 * 200).map(|_| rng.random_bool(0.2)).collect();
    let tree = RegionQuadtree::from_fn(grid, false, |x, y| cells[((y / 3) * 300 + x / 2) as usize]);
    let mut finger = super::Finger::new(&tree);
    let side = grid.side_cells();
    let (mut near, mut moved) = ((0, 0), 0);
    for k in 0..4000 {
        if k % 40 == 0 {
            near = (rng.random_range(0..side), rng.random_range(0..side));
        }
        let lo = (
            (near.0 + rng.random_range(0..40)).min(side - 1),
            (near.1 + rng.random_range(0..40)).min(side - 1),
        );
        let hi = (
            (lo.0 + rng.random_range(0..6)).min(side - 1),
            (lo.1 + rng.random_range(0..6)).min(side - 1),
        );
        let before = finger.square();
        assert_eq!(
            tree.values_in_rect_from(&mut finger, lo, hi),
            tree.values_in_rect(lo, hi),
            "{lo:?}..={hi:?}"
        );
        moved += usize::from(finger.square() != before);
    }
    assert!(moved > 50, "the finger moved {moved} times");
}

/// `shape`'s classification, never "contains", as a nearest-point search's shape: every
/// square is then tested on the way down.
fn never_contains(shape: &dyn Shape, b: &Aabb) -> crate::spatial::geometry::Overlap {
    match shape.classify(b) {
        crate::spatial::geometry::Overlap::Disjoint => crate::spatial::geometry::Overlap::Disjoint,
        _ => crate::spatial::geometry::Overlap::Partial,
    }
}

/// A shape walked square by square (no cell masks).
struct SquareBySquare<'a>(&'a dyn Shape);

impl Shape for SquareBySquare<'_> {
    fn classify(&self, b: &Aabb) -> crate::spatial::geometry::Overlap {
        never_contains(self.0, b)
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
}

/// The same shape answering a block's cells at once (from `intersects`, cell by cell), its
/// blocks to be walked in the walk's own order.
struct CellsInWalkOrder<'a>(&'a dyn Shape);

impl Shape for CellsInWalkOrder<'_> {
    fn classify(&self, b: &Aabb) -> crate::spatial::geometry::Overlap {
        never_contains(self.0, b)
    }
    fn intersects_cells(&self, cells: &crate::spatial::geometry::BlockCells) -> Option<u64> {
        let mut hits = 0;
        for j in 0..8 {
            for i in 0..8 {
                let b = Aabb {
                    min: DVec2::new(cells.xs[i], cells.ys[j]),
                    max: DVec2::new(cells.xs[i + 1], cells.ys[j + 1]),
                };
                hits |= u64::from(self.0.intersects(&b)) << (8 * j + i);
            }
        }
        Some(hits)
    }
    fn cells_in_z_order(&self) -> bool {
        false
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
}

/// A shape that answers a block's cells at once but keeps the walk's order is visited leaf
/// for leaf in the order of the square-by-square walk (a nearest-point search breaks ties
/// by that order), on random trees and shapes of every kind.
#[test]
fn cells_in_walk_order_visit_the_leaves_of_the_square_by_square_walk() {
    let mut rng = ChaCha8Rng::seed_from_u64(1207);
    let mut blocks_seen = 0;
    for case in 0..300 {
        let grid = Grid::new(DVec2::new(-3.0, 5.0), rng.random_range(0.3..2.0), 70, 45).unwrap();
        let tree = random_tree(&mut rng, grid);
        let shape = random_shape(&mut rng, &grid);
        for value in [false, true] {
            let walk = |s: &dyn Shape| {
                let mut seen = Vec::new();
                let _ = tree.visit_leaves_in(&s, value, |sq, b| {
                    seen.push((sq, b));
                    ControlFlow::Continue(())
                });
                seen
            };
            let (plain, by_cells) = (walk(&SquareBySquare(&*shape)), walk(&CellsInWalkOrder(&*shape)));
            assert_eq!(plain, by_cells, "case {case}, value {value}");
            blocks_seen += plain.iter().filter(|(sq, _)| sq.level < 3).count();
        }
    }
    assert!(blocks_seen > 1000, "only {blocks_seen} leaves inside blocks");
}
