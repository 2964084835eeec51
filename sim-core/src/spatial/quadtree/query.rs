//! Read-only queries: shape visitors, point look-ups, ray casts and areas. None allocates.

use std::ops::ControlFlow;

use glam::DVec2;

use super::{FULL, NodeRef, RegionQuadtree, Square, Stack, is_leaf, leaf, tag, tag_square, untag};
use crate::spatial::geometry::{Aabb, Overlap, Shape, clip_line};

impl RegionQuadtree {
    /// Visit every leaf of the given value whose square overlaps `shape` (in world
    /// coordinates), with its square and world box. The visitor may stop the walk early.
    /// Returns `ControlFlow::Break` if it did.
    #[inline]
    pub fn visit_leaves_in<S: Shape>(
        &self,
        shape: &S,
        value: bool,
        mut visit: impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let want = leaf(value);
        let root = self.root_square();
        let Some(inside) = self.classify_node(shape, self.root, want, root) else {
            return ControlFlow::Continue(());
        };
        // Stack entries carry "wholly inside the shape" in the level's top bit: below such a
        // node every wanted leaf is reported without further tests.
        let mut stack = Stack::new(self.root, tag(root.level, inside));
        while let Some((n, tagged)) = stack.pop() {
            let (sq, inside) = untag(tagged);
            if is_leaf(n) {
                visit(sq, self.grid.square(sq.x, sq.y, sq.level))?;
                continue;
            }
            let kids = self.groups[n as usize];
            // Leaf children are visited at once (no stack round trip); internal ones are
            // pushed in reverse so they pop in SW, SE, NW, NE order.
            for i in (0..4).rev() {
                let (k, csq) = (kids[i], sq.child(i));
                if is_leaf(k) {
                    if k == want {
                        let b = self.grid.square(csq.x, csq.y, csq.level);
                        // A leaf needs only the cheap half of the test.
                        if inside || shape.intersects(&b) {
                            visit(csq, b)?;
                        }
                    }
                } else if inside {
                    stack.push(k, tag_square(csq, true));
                } else {
                    match shape.classify(&self.grid.square(csq.x, csq.y, csq.level)) {
                        Overlap::Disjoint => {}
                        Overlap::Partial => stack.push(k, tag_square(csq, false)),
                        Overlap::Contains => stack.push(k, tag_square(csq, true)),
                    }
                }
            }
        }
        ControlFlow::Continue(())
    }

    /// `None` if the node cannot hold a wanted leaf overlapping the shape, else whether it
    /// lies wholly inside the shape.
    #[inline]
    fn classify_node<S: Shape>(&self, shape: &S, n: NodeRef, want: NodeRef, sq: Square) -> Option<bool> {
        if is_leaf(n) && n != want {
            return None;
        }
        match shape.classify(&self.grid.square(sq.x, sq.y, sq.level)) {
            Overlap::Disjoint => None,
            Overlap::Partial => Some(false),
            Overlap::Contains => Some(true),
        }
    }

    /// Whether any leaf of the given value overlaps `shape`.
    pub fn any_leaf_in<S: Shape>(&self, shape: &S, value: bool) -> bool {
        self.visit_leaves_in(shape, value, |_, _| ControlFlow::Break(()))
            .is_break()
    }

    /// Whether every cell overlapping `shape` has the given value (true for shapes that
    /// overlap no cell of the covering square).
    pub fn all_in<S: Shape>(&self, shape: &S, value: bool) -> bool {
        !self.any_leaf_in(shape, !value)
    }

    /// The value of cell `(x, y)` of the covering square.
    pub fn cell_value(&self, x: u32, y: u32) -> bool {
        let mut n = self.root;
        let mut level = self.grid.depth();
        while !is_leaf(n) {
            level -= 1;
            let i = ((x >> level) & 1) | (((y >> level) & 1) << 1);
            n = self.groups[n as usize][i as usize];
        }
        n == FULL
    }

    /// The value at world point `p`, or `None` outside the covering square.
    pub fn value_at(&self, p: DVec2) -> Option<bool> {
        self.grid.cell_of(p).map(|(x, y)| self.cell_value(x, y))
    }

    /// Distance along the ray `origin + t·dir` (`dir` of unit length) at which it first enters
    /// the interior of a leaf of the given value, within `max_dist`. A ray that starts inside
    /// such a leaf hits at 0.
    pub fn first_hit(&self, origin: DVec2, dir: DVec2, max_dist: f64, value: bool) -> Option<f64> {
        let want = leaf(value);
        let mut best = f64::INFINITY;
        let mut stack = Stack::new(self.root, self.grid.depth());
        while let Some((n, sq)) = stack.pop() {
            if is_leaf(n) && n != want {
                continue;
            }
            let b = self.grid.square(sq.x, sq.y, sq.level);
            let Some((t0, t1)) = clip_line(origin, dir, 0.0, max_dist.min(best), &b) else {
                continue;
            };
            if is_leaf(n) {
                // Grazing an edge or a corner is no hit: the chord must reach the interior.
                if b.contains_strictly(origin + dir * (0.5 * (t0 + t1))) && t0 < best {
                    best = t0;
                }
            } else {
                let kids = self.groups[n as usize];
                // Near children last, so they pop first and tighten `best` early.
                let near = usize::from(dir.x < 0.0) | (usize::from(dir.y < 0.0) << 1);
                for i in [near ^ 3, near ^ 2, near ^ 1, near] {
                    stack.push(kids[i], sq.child(i));
                }
            }
        }
        best.is_finite().then_some(best)
    }

    /// Visit every leaf with its square and value.
    pub fn for_each_leaf(&self, mut visit: impl FnMut(Square, bool)) {
        let mut stack = Stack::new(self.root, self.grid.depth());
        while let Some((n, sq)) = stack.pop() {
            if is_leaf(n) {
                visit(sq, n == FULL);
            } else {
                let kids = self.groups[n as usize];
                for i in (0..4).rev() {
                    stack.push(kids[i], sq.child(i));
                }
            }
        }
    }

    /// Number of leaves holding `value`.
    pub fn count_leaves(&self, value: bool) -> usize {
        let mut count = 0;
        self.for_each_leaf(|_, v| count += usize::from(v == value));
        count
    }

    /// Number of cells (of the covering square, padding included) holding `value`.
    pub fn count_cells(&self, value: bool) -> u64 {
        let mut count = 0;
        self.for_each_leaf(|sq, v| {
            if v == value {
                count += sq.cells();
            }
        });
        count
    }

    /// The value of every cell of `sq` if they all agree, `None` if they differ. One descent
    /// from the root: the cheap test for squares of the grid (navigation nodes are such).
    #[inline]
    pub fn square_value(&self, sq: Square) -> Option<bool> {
        let mut n = self.root;
        let mut level = self.grid.depth();
        while level > sq.level {
            if is_leaf(n) {
                break;
            }
            level -= 1;
            let i = ((sq.x >> level) & 1) | (((sq.y >> level) & 1) << 1);
            n = self.groups[n as usize][i as usize];
        }
        // A leaf on the way covers the square; an internal node at its level is mixed.
        if is_leaf(n) { Some(n == FULL) } else { None }
    }

    /// Number of cells of `sq` holding `value`.
    pub fn count_cells_in(&self, sq: Square, value: bool) -> u64 {
        let mut n = self.root;
        let mut level = self.grid.depth();
        while level > sq.level {
            if is_leaf(n) {
                return if n == leaf(value) { sq.cells() } else { 0 };
            }
            level -= 1;
            let i = ((sq.x >> level) & 1) | (((sq.y >> level) & 1) << 1);
            n = self.groups[n as usize][i as usize];
        }
        self.subtree_cells(n, leaf(value), sq)
    }

    /// Number of cells where `self` holds `a` and `other` holds `b`. Both trees must cover
    /// the same grid depth (they are walked in lockstep).
    pub fn count_cells_where(&self, a: bool, other: &RegionQuadtree, b: bool) -> u64 {
        assert_eq!(self.grid.depth(), other.grid.depth(), "trees over different grids");
        let root = self.root_square();
        self.lockstep(self.root, leaf(a), other, other.root, leaf(b), root)
    }

    fn lockstep(&self, n: NodeRef, a: NodeRef, other: &RegionQuadtree, m: NodeRef, b: NodeRef, sq: Square) -> u64 {
        match (is_leaf(n), is_leaf(m)) {
            (true, _) if n != a => 0,
            (_, true) if m != b => 0,
            (true, true) => sq.cells(),
            (true, false) => other.subtree_cells(m, b, sq),
            (false, true) => self.subtree_cells(n, a, sq),
            (false, false) => {
                let (kn, km) = (self.groups[n as usize], other.groups[m as usize]);
                (0..4)
                    .map(|i| self.lockstep(kn[i], a, other, km[i], b, sq.child(i)))
                    .sum()
            }
        }
    }

    fn subtree_cells(&self, n: NodeRef, want: NodeRef, sq: Square) -> u64 {
        if is_leaf(n) {
            return if n == want { sq.cells() } else { 0 };
        }
        let kids = self.groups[n as usize];
        (0..4).map(|i| self.subtree_cells(kids[i], want, sq.child(i))).sum()
    }
}
