//! Read-only queries: shape visitors, point look-ups, ray casts and areas. None allocates.

use std::ops::ControlFlow;

use glam::DVec2;

use super::block::{self, BLOCK_LEVEL, Node};
use super::directory::Directory;
use super::{CellSet, NodeRef, Reach, RegionQuadtree, Square, Stack, is_block, is_leaf, tag_square, untag};
use crate::spatial::geometry::{Aabb, Capsule, Overlap, Shape, clip_line, segment_box_distance_squared};
use crate::spatial::grid::Grid;

/// How many cells within rounding of a capsule's rim [`RegionQuadtree::capsule_meets_cells`]
/// decides by the walk's own tests; with more it gives up (`None`).
const MAX_TIES: usize = 8;

impl RegionQuadtree {
    /// Visit every leaf of the given value whose square overlaps `shape` (in world
    /// coordinates), with its square and world box. The visitor may stop the walk early.
    /// Returns `ControlFlow::Break` if it did.
    ///
    /// The order is fixed (the same tree and shape give the same sequence) but not
    /// spatial: a node's leaf children come before its other descendants, except inside an
    /// 8 × 8 block of a shape that [classifies cells at once](Shape::classify_cells),
    /// whose leaves come in Z order.
    #[inline]
    pub fn visit_leaves_in<S: Shape>(
        &self,
        shape: &S,
        value: bool,
        mut visit: impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let (start, root) = self.start_node(&shape.bounds());
        let Some(inside) = self.classify_node(shape, self.node(start), value, root) else {
            return ControlFlow::Continue(());
        };
        // Stack entries carry "wholly inside the shape" in the level's top bit: below such a
        // node every wanted leaf is reported without further tests.
        let mut stack = Stack::starting_at(super::EMPTY, start, tag_square(root, inside));
        while let Some((n, tagged)) = stack.pop() {
            let (sq, inside) = untag(tagged);
            if is_leaf(n) {
                visit(sq, self.grid.square(sq.x, sq.y, sq.level))?;
                continue;
            }
            if is_block(n) {
                self.visit_bits(shape, self.bits_of(n, BLOCK_LEVEL), sq, value, inside, &mut visit)?;
                continue;
            }
            let kids = *self.children(n);
            // Leaf or not is in the reference: no block is loaded before it is descended into.
            let leaves = kids.map(|k| is_leaf(k).then_some(k == super::FULL));
            let descend = self.visit_step(shape, leaves, sq, value, inside, &mut visit)?;
            // Pushed in reverse so they pop in SW, SE, NW, NE order.
            for i in (0..4).rev() {
                if let Some(inside) = descend[i] {
                    stack.push(kids[i], tag_square(sq.child(i), inside));
                }
            }
        }
        ControlFlow::Continue(())
    }

    /// One node of [`visit_leaves_in`](Self::visit_leaves_in)'s walk, given the value of
    /// each child that is a leaf: visit its leaf children of the wanted value that overlap
    /// the shape (at once, in reverse order, no stack round trip), then classify the
    /// others, all before any is descended into: `Some(inside)` for each child to descend
    /// into.
    #[inline]
    fn visit_step<S: Shape>(
        &self,
        shape: &S,
        leaves: [Option<bool>; 4],
        sq: Square,
        value: bool,
        inside: bool,
        visit: &mut impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<(), [Option<bool>; 4]> {
        let mut descend = [None; 4];
        for i in (0..4).rev() {
            let csq = sq.child(i);
            if let Some(v) = leaves[i] {
                if v == value {
                    let b = self.grid.square(csq.x, csq.y, csq.level);
                    // A leaf needs only the cheap half of the test.
                    if inside || shape.intersects(&b) {
                        visit(csq, b)?;
                    }
                }
            } else if inside {
                descend[i] = Some(true);
            } else {
                descend[i] = match shape.classify(&self.grid.square(csq.x, csq.y, csq.level)) {
                    Overlap::Disjoint => None,
                    Overlap::Partial => Some(false),
                    Overlap::Contains => Some(true),
                };
            }
        }
        ControlFlow::Continue(descend)
    }

    /// [`visit_leaves_in`](Self::visit_leaves_in) below a mixed square `bits` at `sq`
    /// (≤ [`BLOCK_LEVEL`]). A whole block, with a shape that classifies its cells at once:
    /// the leaves come from word operations, in Z order. Otherwise the walk above the
    /// block goes on over its bits, in the same order (recursion visits subtrees in the
    /// order the stack pops them).
    fn visit_bits<S: Shape>(
        &self,
        shape: &S,
        bits: u64,
        sq: Square,
        value: bool,
        inside: bool,
        visit: &mut impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        if sq.level == BLOCK_LEVEL {
            let hits = if inside {
                Some(u64::MAX)
            } else {
                shape.intersects_cells(&self.block_cells(sq)).map(block::z_order)
            };
            if let Some(hits) = hits {
                let wanted = if value { bits } else { !bits };
                if inside || shape.cells_in_z_order() {
                    return self.visit_block(wanted, sq, hits, visit);
                }
                return self.visit_cells_in_walk_order(wanted, sq, hits, visit);
            }
        }
        let kids = block::kids(bits, sq.level);
        let leaves = kids.map(|k| if let Node::Leaf(v) = k { Some(v) } else { None });
        let descend = self.visit_step(shape, leaves, sq, value, inside, visit)?;
        for i in 0..4 {
            if let (Some(inside), Node::Bits { bits, .. }) = (descend[i], kids[i]) {
                self.visit_bits(shape, bits, sq.child(i), value, inside, visit)?;
            }
        }
        ControlFlow::Continue(())
    }

    /// The leaves of the mixed square at `sq` (≤ [`BLOCK_LEVEL`]) whose cells are all in
    /// `wanted` and that share a cell with `hits` (both Z-order masks of the square's
    /// cells), in the order [`visit_bits`](Self::visit_bits) walks them: at each square its
    /// leaf children last to first, then its mixed children first to last.
    ///
    /// Invariant: a leaf shares a cell with `hits` exactly when its box meets the shape, so
    /// these are the leaves the square-by-square walk visits, with one shape test per
    /// block. Checked by `cells_in_walk_order_visit_the_leaves_of_the_square_by_square_walk`.
    fn visit_cells_in_walk_order(
        &self,
        wanted: u64,
        sq: Square,
        hits: u64,
        visit: &mut impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let part = |w: u64, i: usize| block::child_bits(w, sq.level, i);
        let full = block::low_bits(sq.level - 1);
        for i in (0..4).rev() {
            if part(wanted, i) == full && part(hits, i) != 0 {
                let c = sq.child(i);
                visit(c, self.grid.square(c.x, c.y, c.level))?;
            }
        }
        for i in 0..4 {
            let w = part(wanted, i);
            if w != 0 && w != full && part(hits, i) != 0 {
                self.visit_cells_in_walk_order(w, sq.child(i), part(hits, i), visit)?;
            }
        }
        ControlFlow::Continue(())
    }

    /// Visit the leaves of a block at `sq` whose cells are all in `wanted` and that share
    /// a cell with `hits` (Z order), in Z order.
    fn visit_block(
        &self,
        wanted: u64,
        sq: Square,
        hits: u64,
        visit: &mut impl FnMut(Square, Aabb) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let (mut leaves, quarters, squares) = block::leaves_hit(wanted, hits);
        while leaves != 0 {
            let i = leaves.trailing_zeros();
            leaves &= leaves - 1;
            let (dx, dy) = block::cell_at(i);
            let level = if quarters >> i & 1 != 0 {
                2
            } else {
                u8::from(squares >> i & 1 != 0)
            };
            let leaf = Square {
                x: sq.x + dx,
                y: sq.y + dy,
                level,
            };
            visit(leaf, self.grid.square(leaf.x, leaf.y, level))?;
        }
        ControlFlow::Continue(())
    }

    /// The deepest node (and its square) whose square holds `bounds` with room to spare (see
    /// [`Reach`]), stopping at leaves and blocks. A walk for the shape may start there: every
    /// other branch would be found disjoint, so it visits the same leaves in the same order
    /// as a walk from the root without classifying the levels above. O(depth).
    #[inline]
    fn start_node(&self, bounds: &Aabb) -> (NodeRef, Square) {
        let (mut n, mut sq) = (self.root, self.root_square());
        let reach = Reach::new(*bounds);
        while !is_leaf(n) && !is_block(n) {
            let Some(i) = reach.child_holding(&self.grid, sq) else {
                break;
            };
            n = self.children(n)[i];
            sq = sq.child(i);
        }
        (n, sq)
    }

    /// `None` if the node cannot hold a wanted leaf overlapping the shape, else whether it
    /// lies wholly inside the shape.
    #[inline]
    fn classify_node<S: Shape>(&self, shape: &S, n: Node, want: bool, sq: Square) -> Option<bool> {
        if matches!(n, Node::Leaf(v) if v != want) {
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
            if is_block(n) {
                return self.bits_of(n, BLOCK_LEVEL) >> block::cell_index(x, y) & 1 != 0;
            }
            level -= 1;
            let i = ((x >> level) & 1) | (((y >> level) & 1) << 1);
            n = self.children(n)[i as usize];
        }
        n == super::FULL
    }

    /// Visit the cells `(x, y)` holding `value` in the cell rectangle `x0..=x1` × `y0..=y1`
    /// (inside the covering square), block by block, or return `None` (visiting nothing) if
    /// the rectangle meets more than 2 × 2 blocks or the tree has none. One integer descent
    /// per block and a mask, no shape tests: for the few cells around a robot's move.
    /// Checked by `cells_in_small_rectangles_match_the_raster`.
    pub fn visit_cells_in_rect(
        &self,
        lo: (u32, u32),
        hi: (u32, u32),
        value: bool,
        visit: impl FnMut(u32, u32) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        self.visit_cells_in_rect_via(None, lo, hi, value, visit)
    }

    /// [`visit_cells_in_rect`](Self::visit_cells_in_rect), each block found from its entry
    /// in `dir` (this tree's) when given.
    pub(crate) fn visit_cells_in_rect_via(
        &self,
        dir: Option<&Directory>,
        lo: (u32, u32),
        hi: (u32, u32),
        value: bool,
        visit: impl FnMut(u32, u32) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        if (hi.0 >> BLOCK_LEVEL) - (lo.0 >> BLOCK_LEVEL) > 1 || (hi.1 >> BLOCK_LEVEL) - (lo.1 >> BLOCK_LEVEL) > 1 {
            return None;
        }
        self.visit_cells_in_blocks_via(dir, lo, hi, value, |_| true, visit)
    }

    /// [`visit_cells_in_rect`](Self::visit_cells_in_rect) over any number of blocks, but
    /// only in the blocks (squares of the tree's block level) that `near` accepts: for a
    /// long shape, the blocks along it. `None` if the tree has no blocks.
    pub fn visit_cells_in_blocks(
        &self,
        lo: (u32, u32),
        hi: (u32, u32),
        value: bool,
        near: impl FnMut(Square) -> bool,
        visit: impl FnMut(u32, u32) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        self.visit_cells_in_blocks_via(None, lo, hi, value, near, visit)
    }

    /// [`visit_cells_in_blocks`](Self::visit_cells_in_blocks), each block found from its
    /// entry in `dir` (this tree's) when given.
    pub(crate) fn visit_cells_in_blocks_via(
        &self,
        dir: Option<&Directory>,
        (x0, y0): (u32, u32),
        (x1, y1): (u32, u32),
        value: bool,
        mut near: impl FnMut(Square) -> bool,
        mut visit: impl FnMut(u32, u32) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        debug_assert!(x0 <= x1 && y0 <= y1 && x1 < self.grid.side_cells() && y1 < self.grid.side_cells());
        if !self.packed {
            return None;
        }
        for by in (y0 >> BLOCK_LEVEL)..=(y1 >> BLOCK_LEVEL) {
            for bx in (x0 >> BLOCK_LEVEL)..=(x1 >> BLOCK_LEVEL) {
                let (ox, oy) = (bx << BLOCK_LEVEL, by << BLOCK_LEVEL);
                let sq = Square {
                    x: ox,
                    y: oy,
                    level: BLOCK_LEVEL,
                };
                if !near(sq) {
                    continue;
                }
                let cells = match self.descend_via(dir, sq) {
                    Node::Leaf(v) => {
                        if v == value {
                            u64::MAX
                        } else {
                            continue;
                        }
                    }
                    Node::Bits { bits, .. } => {
                        if value {
                            bits
                        } else {
                            !bits
                        }
                    }
                    Node::Group(_) => unreachable!("packed trees have blocks at their block level"),
                };
                // The rectangle's part of this block, row-major, then in the block's Z order.
                let (cx0, cx1) = (x0.max(ox) - ox, x1.min(ox + 7) - ox);
                let (cy0, cy1) = (y0.max(oy) - oy, y1.min(oy + 7) - oy);
                let row = (0xFFu64 >> (7 - (cx1 - cx0))) << cx0;
                let rows = (u64::MAX >> (8 * (7 - (cy1 - cy0)))) << (8 * cy0);
                let mut hits = cells & block::z_order(rows & (row * 0x0101_0101_0101_0101));
                while hits != 0 {
                    let (dx, dy) = block::cell_at(hits.trailing_zeros());
                    hits &= hits - 1;
                    if visit(ox + dx, oy + dy).is_break() {
                        return Some(ControlFlow::Break(()));
                    }
                }
            }
        }
        Some(ControlFlow::Continue(()))
    }

    /// Whether a capsule of positive radius meets a cell holding `value`, told from the
    /// cells near it instead of by a walk, or `None` when that cannot tell: a radius of 0, a
    /// tree without blocks, more than `max_blocks` blocks to read near a long capsule, or
    /// more than eight cells within a part in 10⁷ of the radius. A capsule within 2 × 2
    /// blocks reads their cells; a longer one, row of blocks by row of blocks, only the
    /// blocks within its reach.
    ///
    /// Invariant: an answer is that of [`any_leaf_in`](Self::any_leaf_in). A capsule meets a
    /// leaf exactly when it meets one of the leaf's cells; a distance more than a part in
    /// 10⁷ off the radius decides the same whatever the rounding, and a cell nearer the rim
    /// than that (a leg pulled round a corner to its clearance) is decided by the walk's own
    /// tests on the way down to it (the private `walk_meets_cell`). Checked by
    /// `capsule_meets_cells_is_the_walks`.
    pub fn capsule_meets_cells(&self, capsule: &Capsule, value: bool, max_blocks: u32) -> Option<bool> {
        self.capsule_meets_cells_via(None, capsule, value, max_blocks)
    }

    /// [`capsule_meets_cells`](Self::capsule_meets_cells), each block found from its entry
    /// in `dir` (this tree's) when given.
    pub(crate) fn capsule_meets_cells_via(
        &self,
        dir: Option<&Directory>,
        capsule: &Capsule,
        value: bool,
        max_blocks: u32,
    ) -> Option<bool> {
        if capsule.radius <= 0.0 {
            return None;
        }
        let (a, b) = (capsule.a, capsule.b);
        let r2 = capsule.radius * capsule.radius;
        let (clearly_hit, clearly_clear) = (r2 * (1.0 - 1e-7), r2 * (1.0 + 1e-7));
        let grid = self.grid;
        let bounds = capsule.bounds();
        // A cell whose centre lies farther from the axis's line than the radius, half the
        // cell's diagonal and room for rounding is clear by more than a part in 10⁷ and
        // cannot decide anything: one cross product skips it. An axis of a cell or two (a
        // robot's step) reads only the few cells near it, unsifted.
        let axis = b - a;
        let (per_m, beyond) = if axis.length_squared() > 4.0 * grid.cell_m() * grid.cell_m() {
            let margin = capsule.radius * 1e-6 + bounds.rounding_margin();
            (
                1.0 / axis.length(),
                capsule.radius + std::f64::consts::FRAC_1_SQRT_2 * grid.cell_m() + margin,
            )
        } else {
            (0.0, f64::INFINITY)
        };
        let (mut ties, mut tied) = ([(0, 0); MAX_TIES], 0);
        let mut visit = |x: u32, y: u32| {
            if per_m > 0.0 && axis.perp_dot(grid.cell_center(x, y) - a).abs() * per_m > beyond {
                return ControlFlow::Continue(());
            }
            let d = segment_box_distance_squared(a, b, &grid.square(x, y, 0));
            if d < clearly_hit {
                return ControlFlow::Break(());
            }
            if d <= clearly_clear {
                if tied < MAX_TIES {
                    ties[tied] = (x, y);
                }
                tied += 1;
            }
            ControlFlow::Continue(())
        };
        let (lo, hi) = grid.cells_near(&bounds)?;
        let flow = if (hi.0 >> BLOCK_LEVEL) - (lo.0 >> BLOCK_LEVEL) <= 1
            && (hi.1 >> BLOCK_LEVEL) - (lo.1 >> BLOCK_LEVEL) <= 1
        {
            self.visit_cells_in_blocks_via(dir, lo, hi, value, |_| true, &mut visit)?
        } else {
            self.visit_capsule_rows(dir, capsule, (lo, hi), value, max_blocks, &mut visit)?
        };
        if flow.is_break() {
            Some(true)
        } else if tied > MAX_TIES {
            None
        } else {
            Some(
                ties[..tied]
                    .iter()
                    .any(|&cell| self.walk_meets_cell(capsule, value, cell)),
            )
        }
    }

    /// The cells holding `value` of a long capsule's blocks, row of blocks by row of blocks,
    /// only the blocks within its reach, for [`capsule_meets_cells_via`](Self::capsule_meets_cells_via):
    /// `None` once more than `max_blocks` blocks would be read (no hit so far).
    #[inline]
    fn visit_capsule_rows(
        &self,
        dir: Option<&Directory>,
        capsule: &Capsule,
        (lo, hi): ((u32, u32), (u32, u32)),
        value: bool,
        max_blocks: u32,
        visit: &mut impl FnMut(u32, u32) -> ControlFlow<()>,
    ) -> Option<ControlFlow<()>> {
        let (a, b, grid) = (capsule.a, capsule.b, self.grid);
        // A block farther than the radius by a part in a million holds no cell within a part
        // in 10⁷ of it, whatever the rounding, so skipping it changes no answer; a row's
        // blocks beyond the segment's reach there by a cell more are farther still.
        let reach2 = capsule.radius * capsule.radius * (1.0 + 1e-6);
        let near = |sq: Square| segment_box_distance_squared(a, b, &grid.square(sq.x, sq.y, sq.level)) <= reach2;
        let reach = capsule.radius * (1.0 + 1e-6) + grid.cell_m() + capsule.bounds().rounding_margin();
        let mut budget = max_blocks;
        for by in (lo.1 >> BLOCK_LEVEL)..=(hi.1 >> BLOCK_LEVEL) {
            let (y0, y1) = ((by << BLOCK_LEVEL).max(lo.1), ((by << BLOCK_LEVEL) + 7).min(hi.1));
            let Some((x0, x1)) = capsule_row_span(&grid, a, b, reach, (y0, y1), (lo.0, hi.0)) else {
                continue;
            };
            let blocks = (x1 >> BLOCK_LEVEL) - (x0 >> BLOCK_LEVEL) + 1;
            if blocks > budget {
                return None;
            }
            budget -= blocks;
            let flow = self.visit_cells_in_blocks_via(dir, (x0, y0), (x1, y1), value, near, &mut *visit)?;
            if flow.is_break() {
                return Some(flow);
            }
        }
        Some(ControlFlow::Continue(()))
    }

    /// Whether the walk of [`any_leaf_in`](Self::any_leaf_in)`(shape, value)` reports a
    /// leaf for cell `(x, y)`: the cell holds `value`, every square on the way down from
    /// the walk's start meets the shape (or one lies inside it, and then everything below
    /// it counts), and so does the cell's leaf (in a block, the cell itself). The walk's own
    /// tests on one path: the answer for a cell too near the shape's edge to tell by a
    /// distance with room for rounding.
    fn walk_meets_cell<S: Shape>(&self, shape: &S, value: bool, (x, y): (u32, u32)) -> bool {
        let (mut n, mut sq) = self.start_node(&shape.bounds());
        if x >> sq.level != sq.x >> sq.level || y >> sq.level != sq.y >> sq.level {
            return false;
        }
        let Some(mut inside) = self.classify_node(shape, self.node(n), value, sq) else {
            return false;
        };
        loop {
            if is_leaf(n) {
                // `classify_node` found it of the value and meeting the shape.
                return true;
            }
            if is_block(n) {
                let held = self.bits_of(n, BLOCK_LEVEL) >> block::cell_index(x, y) & 1 != 0;
                return held == value && (inside || shape.intersects(&self.grid.square(x, y, 0)));
            }
            let below = sq.level - 1;
            let i = ((x >> below) & 1) | (((y >> below) & 1) << 1);
            let (kid, ksq) = (self.children(n)[i as usize], sq.child(i as usize));
            let b = self.grid.square(ksq.x, ksq.y, ksq.level);
            if is_leaf(kid) {
                return (kid == super::FULL) == value && (inside || shape.intersects(&b));
            }
            if !inside {
                match shape.classify(&b) {
                    Overlap::Disjoint => return false,
                    Overlap::Partial => {}
                    Overlap::Contains => inside = true,
                }
            }
            (n, sq) = (kid, ksq);
        }
    }

    /// Whether some cell of the cell rectangle `lo ..= hi` (inclusive corners, inside the
    /// covering square) holds `value`. A descent into the nodes the rectangle meets that
    /// stops at the first node inside it that is mixed (it holds both values): the test
    /// for navigation pieces, which are rectangles of cells.
    pub fn any_cell_in_rect(&self, lo: (u32, u32), hi: (u32, u32), value: bool) -> bool {
        self.values_in_rect_until(&mut Finger::new(self), lo, hi, value_bit(value)) & value_bit(value) != 0
    }

    /// Which values the cells of the rectangle `lo ..= hi` (as for
    /// [`any_cell_in_rect`](Self::any_cell_in_rect)) hold: `(some cell holds false, some
    /// cell holds true)`. Both answers of `any_cell_in_rect` from one descent.
    pub fn values_in_rect(&self, lo: (u32, u32), hi: (u32, u32)) -> (bool, bool) {
        self.values_in_rect_from(&mut Finger::new(self), lo, hi)
    }

    /// [`values_in_rect`](Self::values_in_rect) descending from where `finger` points if
    /// that holds the rectangle (it then points at the rectangle's ancestor at
    /// level 6): a run of queries about nearby rectangles skips the levels above.
    /// `finger` must be of this tree. Same answer as from the root; checked by
    /// `values_in_rect_from_a_finger_match_the_root_descent`.
    pub fn values_in_rect_from(&self, finger: &mut Finger, lo: (u32, u32), hi: (u32, u32)) -> (bool, bool) {
        debug_assert!(std::ptr::eq(finger.tree, self), "a finger of another tree");
        let held = self.values_in_rect_until(finger, lo, hi, BOTH_VALUES);
        (held & value_bit(false) != 0, held & value_bit(true) != 0)
    }

    /// The values (bits of [`value_bit`]) the rectangle's cells hold, the descent stopped
    /// once all of `wanted` are found (the answer then holds at least those).
    fn values_in_rect_until(&self, finger: &mut Finger, lo: (u32, u32), hi: (u32, u32), wanted: u8) -> u8 {
        debug_assert!(lo.0 <= hi.0 && lo.1 <= hi.1 && hi.0 < self.grid.side_cells() && hi.1 < self.grid.side_cells());
        // Straight down to the smallest square that holds the rectangle, found from the
        // bits of its corners' coordinates, with no box tests.
        let differ = (lo.0 ^ hi.0) | (lo.1 ^ hi.1);
        let level = (u32::BITS - differ.leading_zeros()).min(u32::from(self.grid.depth()));
        let keep = u32::MAX.checked_shl(level).unwrap_or(0);
        let sq = Square {
            x: lo.0 & keep,
            y: lo.1 & keep,
            level: level as u8,
        };
        match self.descend_by(finger, sq) {
            // A leaf at or above the square: the whole rectangle holds its value.
            Node::Leaf(v) => value_bit(v),
            n => self.values_in_rect_below(n, sq, lo, hi, wanted),
        }
    }

    /// [`descend_to`](Self::descend_to) from `finger`'s node if its square holds `sq`,
    /// else from the root; `finger` then points at `sq`'s ancestor at [`FINGER_LEVEL`] if
    /// the descent passed one.
    fn descend_by(&self, finger: &mut Finger, sq: Square) -> Node {
        let shift = u32::from(finger.square.level);
        let (n, level) = if finger.square.level >= sq.level
            && sq.x >> shift == finger.square.x >> shift
            && sq.y >> shift == finger.square.y >> shift
        {
            (finger.node, finger.square.level)
        } else {
            (self.node(self.root), self.grid.depth())
        };
        self.descend_from(n, level, sq, |level, n| {
            if level == FINGER_LEVEL {
                let keep = u32::MAX << level;
                finger.square = Square {
                    x: sq.x & keep,
                    y: sq.y & keep,
                    level,
                };
                finger.node = n;
            }
        })
    }

    /// From node `n` at `level` down toward `sq` (inside `n`'s square) to `sq`'s node or
    /// the leaf above it, showing `passed` each node met below `n` with its level.
    #[inline]
    pub(super) fn descend_from(
        &self,
        mut n: Node,
        mut level: u8,
        sq: Square,
        mut passed: impl FnMut(u8, Node),
    ) -> Node {
        while level > sq.level {
            if let Node::Leaf(_) = n {
                break;
            }
            level -= 1;
            let i = ((sq.x >> level) & 1) | (((sq.y >> level) & 1) << 1);
            n = self.kid(n, i as usize);
            passed(level, n);
        }
        n
    }

    /// `values_in_rect_until` below node `n` of square `sq`, which the rectangle meets.
    fn values_in_rect_below(&self, n: Node, sq: Square, lo: (u32, u32), hi: (u32, u32), wanted: u8) -> u8 {
        let last = sq.side_cells() - 1;
        match n {
            Node::Leaf(v) => value_bit(v),
            // An internal node is never uniform: inside the rectangle it holds both values.
            _ if lo.0 <= sq.x && lo.1 <= sq.y && sq.x + last <= hi.0 && sq.y + last <= hi.1 => BOTH_VALUES,
            Node::Bits { bits, level } if level == BLOCK_LEVEL => {
                // The rectangle's part of the block as a mask, row-major, then in Z order.
                let (cx0, cx1) = (lo.0.max(sq.x) - sq.x, hi.0.min(sq.x + 7) - sq.x);
                let (cy0, cy1) = (lo.1.max(sq.y) - sq.y, hi.1.min(sq.y + 7) - sq.y);
                let row = (0xFFu64 >> (7 - (cx1 - cx0))) << cx0;
                let rows = (u64::MAX >> (8 * (7 - (cy1 - cy0)))) << (8 * cy0);
                let mask = block::z_order(rows & (row * 0x0101_0101_0101_0101));
                (u8::from(!bits & mask != 0) * value_bit(false)) | (u8::from(bits & mask != 0) * value_bit(true))
            }
            _ => {
                let half = sq.side_cells() / 2;
                let mut held = 0;
                for i in 0..4 {
                    let c = sq.child(i);
                    if c.x <= hi.0 && c.y <= hi.1 && c.x + half > lo.0 && c.y + half > lo.1 {
                        held |= self.values_in_rect_below(self.kid(n, i), c, lo, hi, wanted);
                        if held & wanted == wanted {
                            break;
                        }
                    }
                }
                held
            }
        }
    }

    /// The value at world point `p`, or `None` outside the covering square.
    pub fn value_at(&self, p: DVec2) -> Option<bool> {
        self.grid.cell_of(p).map(|(x, y)| self.cell_value(x, y))
    }

    /// Distance along the ray `origin + t·dir` (`dir` of unit length) at which it first enters
    /// the interior of a leaf of the given value, within `max_dist`. A ray that starts inside
    /// such a leaf hits at 0.
    pub fn first_hit(&self, origin: DVec2, dir: DVec2, max_dist: f64, value: bool) -> Option<f64> {
        let mut best = f64::INFINITY;
        let mut stack = Stack::new(Node::Leaf(false), self.node(self.root), self.grid.depth());
        while let Some((n, sq)) = stack.pop() {
            if matches!(n, Node::Leaf(v) if v != value) {
                continue;
            }
            let b = self.grid.square(sq.x, sq.y, sq.level);
            let Some((t0, t1)) = clip_line(origin, dir, 0.0, max_dist.min(best), &b) else {
                continue;
            };
            if let Node::Leaf(_) = n {
                // Grazing an edge or a corner is no hit: the chord must reach the interior.
                if b.contains_strictly(origin + dir * (0.5 * (t0 + t1))) && t0 < best {
                    best = t0;
                }
            } else {
                let kids = self.kids(n);
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
        let mut stack = Stack::new(Node::Leaf(false), self.node(self.root), self.grid.depth());
        while let Some((n, sq)) = stack.pop() {
            if let Node::Leaf(v) = n {
                visit(sq, v);
            } else {
                let kids = self.kids(n);
                for i in (0..4).rev() {
                    stack.push(kids[i], sq.child(i));
                }
            }
        }
    }

    /// Visit the squares holding any cell of `value`, looking no finer than `min_level`:
    /// leaves of that value above `min_level`, and each square at `min_level` that holds it at
    /// least once. Disjoint squares, in Z order; the cost is the nodes above `min_level`, so
    /// a coarse view of a fine tree (a viewer's overview of a known map) skips its detail.
    pub fn for_each_square_holding(&self, value: bool, min_level: u8, mut visit: impl FnMut(Square)) {
        let mut stack = Stack::new(Node::Leaf(false), self.node(self.root), self.grid.depth());
        while let Some((n, sq)) = stack.pop() {
            match n {
                Node::Leaf(v) => {
                    if v == value {
                        visit(sq);
                    }
                }
                // An internal node is mixed: it holds both values.
                _ if sq.level <= min_level => visit(sq),
                _ => {
                    let kids = self.kids(n);
                    for i in (0..4).rev() {
                        stack.push(kids[i], sq.child(i));
                    }
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
        match self.descend_to(sq) {
            // A leaf on the way covers the square; an internal node at its level is mixed.
            Node::Leaf(v) => Some(v),
            _ => None,
        }
    }

    /// The node of square `sq`, or the leaf above it that covers it.
    #[inline]
    pub(super) fn descend_to(&self, sq: Square) -> Node {
        self.descend_from(self.node(self.root), self.grid.depth(), sq, |_, _| {})
    }

    /// Number of cells of `sq` holding `value`.
    pub fn count_cells_in(&self, sq: Square, value: bool) -> u64 {
        self.subtree_cells(self.descend_to(sq), value, sq)
    }

    /// Number of cells of `set` holding `value` (one descent).
    pub fn count_cells_in_set(&self, set: CellSet, value: bool) -> u64 {
        if set.is_whole() {
            return self.count_cells_in(set.square(), value);
        }
        let bits = self.block_bits_at(set.square());
        let held = if value { bits } else { !bits };
        u64::from((held & set.bits).count_ones())
    }

    /// The cells (Z-order bits) of the square at [`BLOCK_LEVEL`] `sq`, by one descent.
    pub(crate) fn block_bits_at(&self, sq: Square) -> u64 {
        match self.descend_to(sq) {
            Node::Leaf(v) => {
                if v {
                    u64::MAX
                } else {
                    0
                }
            }
            Node::Bits { bits, .. } => bits,
            Node::Group(g) => self.bits_of(g, BLOCK_LEVEL),
        }
    }

    /// Number of cells where `self` holds `a` and `other` holds `b`. Both trees must cover
    /// the same grid depth (they are walked in lockstep).
    pub fn count_cells_where(&self, a: bool, other: &RegionQuadtree, b: bool) -> u64 {
        assert_eq!(self.grid.depth(), other.grid.depth(), "trees over different grids");
        let root = self.root_square();
        self.lockstep(self.node(self.root), a, other, other.node(other.root), b, root)
    }

    fn lockstep(&self, n: Node, a: bool, other: &RegionQuadtree, m: Node, b: bool, sq: Square) -> u64 {
        match (n, m) {
            (Node::Leaf(v), _) if v != a => 0,
            (_, Node::Leaf(v)) if v != b => 0,
            (Node::Leaf(_), Node::Leaf(_)) => sq.cells(),
            (Node::Leaf(_), _) => other.subtree_cells(m, b, sq),
            (_, Node::Leaf(_)) => self.subtree_cells(n, a, sq),
            // Both packed at the same level: the cells where both hold their value.
            (Node::Bits { bits: x, level }, Node::Bits { bits: y, .. }) => {
                let all = block::low_bits(level);
                let (x, y) = (if a { x } else { !x & all }, if b { y } else { !y & all });
                u64::from((x & y).count_ones())
            }
            _ => {
                let (kn, km) = (self.kids(n), other.kids(m));
                (0..4)
                    .map(|i| self.lockstep(kn[i], a, other, km[i], b, sq.child(i)))
                    .sum()
            }
        }
    }

    fn subtree_cells(&self, n: Node, want: bool, sq: Square) -> u64 {
        match n {
            Node::Leaf(v) => {
                if v == want {
                    sq.cells()
                } else {
                    0
                }
            }
            Node::Bits { bits, .. } => {
                let ones = u64::from(bits.count_ones());
                if want { ones } else { sq.cells() - ones }
            }
            Node::Group(_) => {
                let kids = self.kids(n);
                (0..4).map(|i| self.subtree_cells(kids[i], want, sq.child(i))).sum()
            }
        }
    }
}

/// A value as a bit of the masks of [`RegionQuadtree::values_in_rect`]'s descent.
#[inline]
fn value_bit(v: bool) -> u8 {
    1 << u8::from(v)
}

/// Both values' bits.
const BOTH_VALUES: u8 = 3;

/// The level of the squares a [`Finger`] points at: 64 cells a side, about the ground one
/// frontier search covers.
const FINGER_LEVEL: u8 = 6;

/// Where descents of one tree toward nearby squares may start: a node an earlier descent
/// passed, and its square. It borrows the tree, so the tree cannot change while it points
/// into it, and a descent from it reaches the node a descent from the root reaches.
#[derive(Clone, Copy)]
pub struct Finger<'a> {
    tree: &'a RegionQuadtree,
    square: Square,
    node: Node,
}

impl<'a> Finger<'a> {
    /// A finger at the root of `tree`.
    pub fn new(tree: &'a RegionQuadtree) -> Self {
        Self {
            tree,
            square: Square {
                x: 0,
                y: 0,
                level: tree.grid.depth(),
            },
            node: tree.node(tree.root),
        }
    }

    /// The square the finger points at.
    pub fn square(&self) -> Square {
        self.square
    }
}

/// The cell columns `x0..=x1` (within `cols`) of the cell rows `y0..=y1` that the segment
/// `a`–`b` comes within `reach` of: its part level with the rows, give or take the reach.
/// `None` when it comes nowhere near them.
#[inline]
fn capsule_row_span(
    grid: &Grid,
    a: DVec2,
    b: DVec2,
    reach: f64,
    (y0, y1): (u32, u32),
    cols: (u32, u32),
) -> Option<(u32, u32)> {
    let (ylo, yhi) = (grid.corner(0, y0).y - reach, grid.corner(0, y1 + 1).y + reach);
    let (t0, t1) = if (b.y - a.y).abs() <= 1e-3 * (b.x - a.x).abs() {
        // Nearly level (the division would magnify rounding): the whole axis, if it comes
        // within reach of the rows.
        if a.y.max(b.y) < ylo || a.y.min(b.y) > yhi {
            return None;
        }
        (0.0, 1.0)
    } else {
        let (ta, tb) = ((ylo - a.y) / (b.y - a.y), (yhi - a.y) / (b.y - a.y));
        (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
    };
    if t0 > t1 {
        return None;
    }
    let (xa, xb) = (a.x + (b.x - a.x) * t0, a.x + (b.x - a.x) * t1);
    let span = Aabb {
        min: DVec2::new(xa.min(xb) - reach, grid.corner(0, y0).y),
        max: DVec2::new(xa.max(xb) + reach, grid.corner(0, y1 + 1).y),
    };
    let ((x0, _), (x1, _)) = grid.cells_touching(&span)?;
    let (x0, x1) = (x0.max(cols.0), x1.min(cols.1));
    (x0 <= x1).then_some((x0, x1))
}
