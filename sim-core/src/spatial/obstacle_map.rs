//! The kernel's obstacle map: a region quadtree of blocked cells (paper §4.1).
//!
//! Everything outside the map's extent is blocked: padding cells of the covering square are
//! stored as blocked leaves (they merge into a few big squares), and the freeness tests also
//! refuse shapes that leave the extent on its lower and left sides, where the tree ends.

use std::ops::ControlFlow;

use glam::DVec2;

use crate::Result;
use crate::spatial::geometry::{Aabb, Capsule, Disc, Shape, clip_line, segment_box_distance_squared};
use crate::spatial::grid::Grid;
use crate::spatial::quadtree::RegionQuadtree;
use crate::spatial::quadtree::Square;
use crate::spatial::quadtree::{BitGrid, Directory, Region};

/// Blocks of the tree (8 × 8 cells) within reach of a long leg that the swept-disc test
/// reads the cells of; past that, the tree walk decides.
pub(crate) const MAX_LEG_BLOCKS: u32 = 64;

/// The static obstacles of a map.
#[derive(Clone, Debug)]
pub struct ObstacleMap {
    tree: RegionQuadtree,
    /// The tree's nodes at one level, for descents to its blocks. Valid because the tree
    /// never changes; checked by [`validate`](Self::validate).
    directory: Option<Directory>,
}

impl ObstacleMap {
    /// A map without obstacles.
    pub fn empty(grid: Grid) -> Self {
        Self::from_regions(grid, |_| Region::Empty)
    }

    /// Build from "is cell `(x, y)` blocked" (cell (0, 0) at the lower-left corner).
    pub fn from_fn(grid: Grid, blocked: impl FnMut(u32, u32) -> bool) -> Self {
        Self::wrap(RegionQuadtree::from_fn(grid, true, blocked))
    }

    /// Build from a raster of blocked cells the size of the map (row 0 at the bottom).
    pub fn from_bitgrid(grid: Grid, blocked: &BitGrid) -> Result<Self> {
        Ok(Self::wrap(RegionQuadtree::from_bitgrid(grid, blocked, true)?))
    }

    /// Build top-down from a classifier of squares (see [`RegionQuadtree::from_regions`]):
    /// `Full` = blocked.
    pub fn from_regions(grid: Grid, classify: impl FnMut(Square) -> Region) -> Self {
        Self::wrap(RegionQuadtree::from_regions(grid, true, classify))
    }

    /// Wrap a tree whose `FULL` leaves are obstacles. Its padding must be blocked.
    pub fn from_tree(tree: RegionQuadtree) -> crate::Result<Self> {
        let map = Self::wrap(tree);
        map.validate()?;
        Ok(map)
    }

    /// The map of `tree`, with its directory.
    fn wrap(tree: RegionQuadtree) -> Self {
        let directory = Directory::new(&tree);
        Self { tree, directory }
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        self.tree.grid()
    }

    /// The underlying quadtree (`FULL` = blocked).
    pub fn tree(&self) -> &RegionQuadtree {
        &self.tree
    }

    /// Visit every blocked leaf overlapping `shape`; the visitor may stop early.
    #[inline]
    pub fn visit_blocked<S: Shape>(
        &self,
        shape: &S,
        visit: impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        self.tree.visit_leaves_in(shape, true, visit)
    }

    /// Call `visit` with the world box of every blocked leaf overlapping the open disc.
    #[inline]
    pub fn for_each_blocked_in_disc(&self, center: DVec2, radius_m: f64, mut visit: impl FnMut(Aabb)) {
        let _ = self.visit_blocked(
            &Disc {
                center,
                radius: radius_m,
            },
            |_, b| {
                visit(b);
                ControlFlow::Continue(())
            },
        );
    }

    /// Call `visit` with the world box of every blocked leaf overlapping the box's interior.
    pub fn for_each_blocked_in_box(&self, area: Aabb, mut visit: impl FnMut(Aabb)) {
        let _ = self.visit_blocked(&area, |_, b| {
            visit(b);
            ControlFlow::Continue(())
        });
    }

    /// Whether world point `p` lies in a free cell of the map.
    pub fn is_point_free(&self, p: DVec2) -> bool {
        self.grid().extent().contains_box(&Aabb { min: p, max: p }) && self.tree.value_at(p) == Some(false)
    }

    /// Whether a disc (a robot) overlaps no obstacle and stays inside the map.
    pub fn is_disc_free(&self, center: DVec2, radius_m: f64) -> bool {
        self.shape_free(&Disc {
            center,
            radius: radius_m,
        })
    }

    /// Whether the segment `a → b` stays inside the map and never enters an obstacle's
    /// interior (running along a wall is allowed).
    pub fn is_segment_free(&self, a: DVec2, b: DVec2) -> bool {
        self.shape_free(&Capsule { a, b, radius: 0.0 })
    }

    /// Whether a disc of `radius_m` can move in a straight line from `a` to `b` without
    /// overlapping an obstacle or leaving the map (the test behind every robot move).
    pub fn is_swept_disc_free(&self, a: DVec2, b: DVec2, radius_m: f64) -> bool {
        let capsule = Capsule { a, b, radius: radius_m };
        if !self.inside_map(&capsule) {
            return false;
        }
        match self.capsule_free_by_cells(&capsule) {
            Some(free) => free,
            None => !self.tree.any_leaf_in(&capsule, true),
        }
    }

    /// The swept-disc test from the blocked cells near the move
    /// ([`RegionQuadtree::capsule_meets_cells`]; `None`: the tree walk decides). The
    /// capsule must lie inside the map.
    fn capsule_free_by_cells(&self, capsule: &Capsule) -> Option<bool> {
        self.tree
            .capsule_meets_cells_via(self.directory.as_ref(), capsule, true, MAX_LEG_BLOCKS)
            .map(|hit| !hit)
    }

    /// Visit the world box of every blocked cell that `area` (inside the map), widened by
    /// its rounding margin, touches, if they lie within 2 × 2 blocks of the tree (`None`
    /// otherwise, visiting nothing; see [`RegionQuadtree::visit_cells_in_rect`]).
    fn visit_blocked_cells_near(
        &self,
        area: &Aabb,
        mut visit: impl FnMut(Aabb) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        let grid = self.grid();
        let (lo, hi) = grid.cells_near(area)?;
        self.tree
            .visit_cells_in_rect_via(self.directory.as_ref(), lo, hi, true, |x, y| {
                visit(grid.square(x, y, 0))
            })
    }

    /// How far along move `d` from `from` a disc of `radius_m` gets before an obstacle or the
    /// map's edge, as a fraction of `d`: the value a 24-step bisection on
    /// [`is_swept_disc_free`](Self::is_swept_disc_free) finds (the largest fraction it proved
    /// free), for a move that is not free as a whole.
    ///
    /// The result is exactly that bisection's, with fewer tree walks: the blocked leaves near
    /// the whole move are gathered once, each step is decided against them, and a step whose
    /// nearest leaf is too close to call either way is decided by the exact test. Checked by
    /// `swept_disc_free_fraction_is_the_bisections`.
    pub fn swept_disc_free_fraction(&self, from: DVec2, d: DVec2, radius_m: f64) -> f64 {
        let exact = |t: f64| self.is_swept_disc_free(from, from + d * t, radius_m);
        // Segments (radius 0) are tested differently by the exact test: they take it always.
        let quick = radius_m > 0.0;
        let near = if quick {
            self.blocked_near_move(from, d, radius_m)
        } else {
            Vec::new()
        };
        let r2 = radius_m * radius_m;
        // Distances this far from the radius decide a step whatever rounding the exact test's
        // own box and distance arithmetic does.
        let (clearly_hit, clearly_clear) = (r2 * (1.0 - 1e-7), r2 * (1.0 + 1e-7));
        let free = |t: f64| {
            if !quick {
                return exact(t);
            }
            let b = from + d * t;
            let capsule = Capsule {
                a: from,
                b,
                radius: radius_m,
            };
            if !self.inside_map(&capsule) {
                return false;
            }
            let mut nearest = f64::INFINITY;
            for bx in &near {
                nearest = nearest.min(segment_box_distance_squared(from, b, bx));
                if nearest < clearly_hit {
                    return false;
                }
            }
            nearest > clearly_clear || exact(t)
        };
        if quick && !near.is_empty() {
            let touch = near
                .iter()
                .map(|b| first_touch(from, d, radius_m, b))
                .fold(1.0, f64::min);
            if let Some(t) = bisection_end_near(touch, &free) {
                return t;
            }
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if free(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The blocked cells (near a short move) or leaves that a disc of `radius_m` moving by
    /// `d` from `from` could meet: a step meets a leaf exactly when it meets one of its cells.
    fn blocked_near_move(&self, from: DVec2, d: DVec2, radius_m: f64) -> Vec<Aabb> {
        let mut near = Vec::new();
        // Slightly wider than any step's capsule, so no leaf a step could meet is missed (a
        // step's capsule lies inside the whole move's).
        let reach = Capsule {
            a: from,
            b: from + d,
            radius: radius_m * (1.0 + 1e-6) + 1e-9,
        };
        let by_cells = self
            .inside_map(&reach)
            .then(|| {
                self.visit_blocked_cells_near(&reach.bounds(), |b| {
                    near.push(b);
                    ControlFlow::Continue(())
                })
            })
            .flatten();
        if by_cells.is_none() {
            let _ = self.tree.visit_leaves_in(&reach, true, |_, b| {
                near.push(b);
                ControlFlow::Continue(())
            });
        }
        near
    }

    fn shape_free<S: Shape>(&self, shape: &S) -> bool {
        self.inside_map(shape) && !self.tree.any_leaf_in(shape, true)
    }

    /// Whether `shape` stays inside the map's extent (the tree ends at its lower and left
    /// edges, so this is tested apart from the blocked padding).
    fn inside_map<S: Shape>(&self, shape: &S) -> bool {
        self.grid().extent().contains_box(&shape.bounds())
    }

    /// Distance along the ray `origin + t·dir` (`dir` need not be normalised; distances are
    /// in metres along it) to the first obstacle or the map's edge, if within `max_dist_m`.
    pub fn first_hit(&self, origin: DVec2, dir: DVec2, max_dist_m: f64) -> Option<f64> {
        let len = dir.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let dir = dir / len;
        let edge = match clip_line(origin, dir, 0.0, f64::INFINITY, &self.grid().extent()) {
            Some((t0, t1)) if t0 <= 0.0 => t1,
            _ => 0.0, // starts outside the map: already blocked
        };
        let hit = self
            .tree
            .first_hit(origin, dir, max_dist_m, true)
            .map_or(edge, |t| t.min(edge));
        (hit <= max_dist_m).then_some(hit)
    }

    /// Total blocked area inside the map, m².
    pub fn blocked_area_m2(&self) -> f64 {
        let g = self.grid();
        let map_cells = u64::from(g.width_cells()) * u64::from(g.height_cells());
        (map_cells - self.tree.count_cells(false)) as f64 * g.cell_area_m2()
    }

    /// Total free area, m².
    pub fn free_area_m2(&self) -> f64 {
        self.tree.count_cells(false) as f64 * self.grid().cell_area_m2()
    }

    /// Number of quadtree leaves (padding included).
    pub fn leaf_count(&self) -> usize {
        self.tree.leaf_count()
    }

    /// Number of blocked leaves (padding included).
    pub fn blocked_leaf_count(&self) -> usize {
        self.tree.count_leaves(true)
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes() + self.directory.as_ref().map_or(0, Directory::memory_bytes)
    }

    /// Tree invariants plus: every padding cell is blocked.
    pub fn validate(&self) -> crate::Result<()> {
        self.problems().map_err(crate::Error::Malformed)
    }

    fn problems(&self) -> Result<(), String> {
        self.tree.problems()?;
        if let Some(directory) = &self.directory {
            self.tree.check_directory(directory)?;
        }
        let g = *self.grid();
        let (w, h) = (u64::from(g.width_cells()), u64::from(g.height_cells()));
        let mut bad = None;
        self.tree.for_each_leaf(|sq, blocked| {
            let side = u64::from(sq.side_cells());
            if !blocked && (u64::from(sq.x) + side > w || u64::from(sq.y) + side > h) {
                bad.get_or_insert(sq);
            }
        });
        match bad {
            Some(sq) => Err(format!(
                "free leaf at cell ({}, {}), {} cells wide, reaches outside the map (padding must be blocked)",
                sq.x,
                sq.y,
                sq.side_cells()
            )),
            None => Ok(()),
        }
    }
}

/// Where a disc of `radius` whose centre moves from `from` by `d` first comes within the
/// radius of box `b`, as a fraction of `d` (0 if it starts there, infinite if never): the
/// entry of the ray into the box grown by the radius (two slabs and four corner discs). An
/// estimate for [`ObstacleMap::swept_disc_free_fraction`], which checks it.
fn first_touch(from: DVec2, d: DVec2, radius: f64, b: &Aabb) -> f64 {
    if b.distance_squared_to(from) < radius * radius {
        return 0.0;
    }
    let (rx, ry) = (DVec2::new(radius, 0.0), DVec2::new(0.0, radius));
    let slabs = [
        Aabb {
            min: b.min - rx,
            max: b.max + rx,
        },
        Aabb {
            min: b.min - ry,
            max: b.max + ry,
        },
    ];
    let mut t = f64::INFINITY;
    for slab in &slabs {
        if let Some((t0, _)) = clip_line(from, d, 0.0, f64::INFINITY, slab) {
            t = t.min(t0);
        }
    }
    let a = d.length_squared();
    if a > 0.0 {
        for c in b.corners() {
            let f = from - c;
            let half_b = d.dot(f);
            let disc = half_b * half_b - a * (f.length_squared() - radius * radius);
            if disc >= 0.0 {
                let t1 = (-half_b - disc.sqrt()) / a;
                if t1 >= 0.0 {
                    t = t.min(t1);
                }
            }
        }
    }
    t
}

/// Where the 24-step bisection on `free` ends, found from `touch`, the fraction of the move
/// at which the disc first comes within its radius of a near box: the bisection ends at the
/// largest k / 2²⁴ (0 < k < 2²⁴) that `free` accepts, or 0, as a longer step sweeps a
/// superset of a shorter one, so the steps around `touch` are tested. `None` if that takes
/// more than a few tests (then bisect).
fn bisection_end_near(touch: f64, free: &impl Fn(f64) -> bool) -> Option<f64> {
    const STEPS: f64 = (1u32 << 24) as f64;
    const LAST: i64 = (1 << 24) - 1;
    let at = |k: i64| k as f64 / STEPS;
    let mut k = ((touch * STEPS) as i64).clamp(0, LAST);
    let mut tests = 0;
    if k >= 1 && free(at(k)) {
        while k < LAST && tests < 4 && free(at(k + 1)) {
            k += 1;
            tests += 1;
        }
        (k == LAST || tests < 4).then(|| at(k))
    } else {
        while k >= 1 && tests < 4 && !free(at(k)) {
            k -= 1;
            tests += 1;
        }
        (k == 0 || tests < 4).then(|| at(k))
    }
}
