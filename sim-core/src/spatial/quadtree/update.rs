//! In-place updates. Groups freed by an update are reused by the next, so a tree's memory
//! follows the size of the region it describes, not the number of updates made to it.

use super::block::{self, BLOCK_LEVEL, Node};
use super::{CellSet, FULL, NodeRef, RegionQuadtree, Square, is_block, is_leaf, leaf};
use crate::spatial::geometry::{Aabb, CellRows, Overlap, Shape};
use crate::spatial::grid::MAX_DEPTH;

/// What [`RegionQuadtree::fill`] does with a cell the shape covers only in part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartialCells {
    /// Set it (over-approximate the shape: "a cell touching a shape is blocked").
    Include,
    /// Leave it (under-approximate: "known only where fully seen").
    Exclude,
}

/// A block's cells `bits` once its cells `cover` are set to `value` (Z-order bits).
#[inline]
fn filled_bits(bits: u64, cover: u64, value: bool) -> u64 {
    if value { bits | cover } else { bits & !cover }
}

impl RegionQuadtree {
    /// Set every cell covered by `shape` (world coordinates) to `value`; cells it covers in
    /// part follow `partial`. Returns whether anything changed.
    pub fn fill<S: Shape>(&mut self, shape: &S, value: bool, partial: PartialCells) -> bool {
        let mut changed = false;
        self.fill_reporting(shape, value, partial, |_| changed = true);
        changed
    }

    /// [`fill`](Self::fill), calling `changed` with every square whose cells all switched to
    /// `value` (together they are exactly the cells that changed).
    pub fn fill_reporting<S: Shape>(
        &mut self,
        shape: &S,
        value: bool,
        partial: PartialCells,
        mut changed: impl FnMut(Square),
    ) {
        let root = self.root_square();
        let before = self.root;
        self.root = self.fill_node(before, root, shape, leaf(value), partial, &mut changed);
    }

    /// Set every cell of grid square `sq` to `value`, calling `changed` with squares whose
    /// cells all switched (together exactly the cells that changed): what
    /// [`fill_reporting`](Self::fill_reporting) does with the square's own box, by one
    /// descent along its coordinates instead of box tests at every node. O(depth) plus the
    /// nodes replaced. Checked by `filling_a_square_is_filling_its_box`.
    pub fn fill_square_reporting(&mut self, sq: Square, value: bool, mut changed: impl FnMut(Square)) {
        let root = self.root_square();
        let before = self.root;
        self.root = self.fill_square_node(before, root, sq, leaf(value), &mut changed);
    }

    /// Set the cells of `set` to `value`, calling `changed` with the cells that switched (a
    /// whole square's as whole squares, a block's as one set), by one descent along the
    /// square's coordinates (see [`fill_square_reporting`](Self::fill_square_reporting)).
    /// Returns the block's cells after (Z order) for a set of some of a block's cells.
    pub fn fill_cells_reporting(&mut self, set: CellSet, value: bool, mut changed: impl FnMut(CellSet)) -> Option<u64> {
        if !set.is_whole() {
            // A block's cells: there are blocks only in packed trees.
            return Some(self.fill_block_cells(set.square(), set.bits, value, &mut changed));
        }
        self.fill_square_reporting(set.square(), value, |sq| changed(CellSet::whole(sq)));
        None
    }

    /// Set the cells `cover` (Z order) of the block at `sq` to `value`: a loop down the
    /// block's coordinates that remembers its way, then back up only as far as something
    /// changed, writing back and merging there alone. A leaf of the other value on the way
    /// is split along the path, as the recursive descent would, so the tree stays the same
    /// canonical tree. Packed trees only. Returns the block's cells after (Z order).
    /// Checked by `rows_filled_block_by_block_match_a_grid`.
    fn fill_block_cells(&mut self, sq: Square, cover: u64, value: bool, changed: &mut impl FnMut(CellSet)) -> u64 {
        debug_assert!(self.packed && sq.level == BLOCK_LEVEL);
        let want = leaf(value);
        let mut path = [(0u32, 0usize); MAX_DEPTH as usize];
        let mut depth = 0;
        let mut n = self.root;
        let mut level = self.grid.depth();
        while level > BLOCK_LEVEL && !is_leaf(n) {
            level -= 1;
            let i = (((sq.x >> level) & 1) | (((sq.y >> level) & 1) << 1)) as usize;
            path[depth] = (n, i);
            depth += 1;
            n = self.groups[n as usize][i];
        }
        if n == want {
            return self.bits_of(n, BLOCK_LEVEL);
        }
        // `n` is the block, or a leaf of the other value at `level` (≥ the block's): the
        // block's cells either way.
        let bits = self.bits_of(n, BLOCK_LEVEL);
        let filled = filled_bits(bits, cover, value);
        if filled == bits {
            return bits;
        }
        changed(CellSet::of_block(sq, filled ^ bits));
        // Every group on the way down holds the changed cells.
        for &(g, _) in &path[..depth] {
            self.forget_hash(g);
        }
        let mut new = self.store_bits(n, filled);
        // Split a leaf above the block: a group per level, the rest of each still that leaf.
        for l in BLOCK_LEVEL + 1..=level {
            let i = (((sq.x >> (l - 1)) & 1) | (((sq.y >> (l - 1)) & 1) << 1)) as usize;
            let mut kids = [n; 4];
            kids[i] = new;
            new = self.make_node(kids);
        }
        // Back up: write the changed child, and merge groups that became one leaf.
        let mut old = n;
        while new != old {
            let Some(d) = depth.checked_sub(1) else {
                self.root = new;
                break;
            };
            depth = d;
            let (g, i) = path[d];
            self.groups[g as usize][i] = new;
            old = g;
            new = if is_leaf(new) { self.merge_if_uniform(g) } else { g };
        }
        filled
    }

    /// One step of setting the whole grid square `target` to leaf `want` by a descent along
    /// its coordinates, from node `n` of square `at` (which holds `target`).
    fn fill_square_node(
        &mut self,
        n: NodeRef,
        at: Square,
        target: Square,
        want: NodeRef,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        if n == want {
            return n;
        }
        if at.level == target.level {
            return self.replace_with_leaf(n, at, want, changed);
        }
        if self.packs(at.level) {
            let bits = self.bits_of(n, BLOCK_LEVEL);
            // An aligned square's cells are consecutive in Z order.
            let cover = block::low_bits(target.level) << block::cell_index(target.x - at.x, target.y - at.y);
            let filled = if want == FULL { bits | cover } else { bits & !cover };
            report_bits(filled ^ bits, at, changed);
            return self.store_bits(n, filled);
        }
        let half = at.level - 1;
        let i = (((target.x >> half) & 1) | (((target.y >> half) & 1) << 1)) as usize;
        if is_leaf(n) {
            let mut kids = [n; 4];
            kids[i] = self.fill_square_node(n, at.child(i), target, want, changed);
            self.make_node(kids)
        } else {
            let k = self.groups[n as usize][i];
            let k2 = self.fill_square_node(k, at.child(i), target, want, changed);
            self.groups[n as usize][i] = k2;
            self.forget_hash(n);
            self.merge_if_uniform(n)
        }
    }

    /// Set the cells of `cells` to `value`, calling `changed` with each block's cells that
    /// switched: the rows cut into 8 × 8 block masks in one pass, then one descent along
    /// coordinates per block with cells to set (integer steps, no shapes), stopping at
    /// squares that hold `value` already. Trees with blocks only (`false`, nothing done,
    /// otherwise).
    ///
    /// For a robot's view: its cells come from
    /// [`Disc::contained_rows`](crate::spatial::geometry::Disc::contained_rows), so marking
    /// is a few descents, not a shape walk along the rim. Checked by
    /// `rows_filled_block_by_block_match_a_grid` and `views_marked_by_blocks_are_the_walks_cells`.
    pub fn fill_new_rows_reporting(&mut self, cells: &CellRows, value: bool, mut changed: impl FnMut(CellSet)) -> bool {
        if !self.packed {
            return false;
        }
        if cells.len == 0 {
            return true;
        }
        // Bit `i` of a row is column `x0 + i`; shifted by `lead`, bit `8 b + k` is column
        // `k` of block column `b` from `base_x` (64 + 7 bits: nine blocks at most).
        let base_x = cells.x0 & !7;
        let lead = cells.x0 - base_x;
        let (y0, y_end) = (cells.y0, cells.y0 + cells.len as u32);
        for by in (y0 >> BLOCK_LEVEL)..=((y_end - 1) >> BLOCK_LEVEL) {
            let mut masks = [0u64; 9];
            let mut any = 0u128;
            for y in (by << BLOCK_LEVEL).max(y0)..((by + 1) << BLOCK_LEVEL).min(y_end) {
                let row = cells.rows[(y - y0) as usize];
                if row == 0 {
                    continue;
                }
                let wide = u128::from(row) << lead;
                any |= wide;
                let at = 8 * (y & 7);
                for b in (wide.trailing_zeros() / 8)..=(wide.ilog2() / 8) {
                    masks[b as usize] |= ((wide >> (8 * b)) as u64 & 0xFF) << at;
                }
            }
            if any == 0 {
                continue;
            }
            for b in (any.trailing_zeros() / 8)..=(any.ilog2() / 8) {
                let mask = masks[b as usize];
                if mask != 0 {
                    let sq = Square {
                        x: base_x + 8 * b,
                        y: by << BLOCK_LEVEL,
                        level: BLOCK_LEVEL,
                    };
                    let _ = self.fill_block_cells(sq, block::z_order(mask), value, &mut changed);
                }
            }
        }
        true
    }

    /// Set one cell of the covering square.
    pub fn set_cell(&mut self, x: u32, y: u32, value: bool) -> bool {
        let b = self.grid.square(x, y, 0);
        // Shrunk so no neighbour's closed box overlaps it.
        let inner = Aabb {
            min: b.min + (b.max - b.min) * 0.25,
            max: b.max - (b.max - b.min) * 0.25,
        };
        self.fill(&inner, value, PartialCells::Include)
    }

    /// One node of a fill: the quick cases here, inlined into the parent's loop, so that
    /// the children a shape misses (most of them on the way down) cost no call.
    #[allow(clippy::inline_always)] // the hot path of marking views: no call per missed child
    #[inline(always)]
    fn fill_node<S: Shape>(
        &mut self,
        n: NodeRef,
        sq: Square,
        shape: &S,
        want: NodeRef,
        partial: PartialCells,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        if n == want {
            return n;
        }
        match shape.classify(&self.grid.square(sq.x, sq.y, sq.level)) {
            Overlap::Disjoint => n,
            overlap if self.packs(sq.level) => self.fill_block(n, sq, overlap, shape, want == FULL, partial, changed),
            overlap => self.fill_overlapping(n, sq, overlap, shape, want, partial, changed),
        }
    }

    /// [`fill_node`](Self::fill_node) on a node the shape overlaps (`overlap` is not
    /// disjoint).
    #[allow(clippy::too_many_arguments)] // one recursive step: the walk's state, not options
    fn fill_overlapping<S: Shape>(
        &mut self,
        n: NodeRef,
        sq: Square,
        overlap: Overlap,
        shape: &S,
        want: NodeRef,
        partial: PartialCells,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        match overlap {
            Overlap::Disjoint => n,
            Overlap::Partial if sq.level == 0 => {
                if partial == PartialCells::Include {
                    changed(sq);
                    want
                } else {
                    n
                }
            }
            Overlap::Contains => self.replace_with_leaf(n, sq, want, changed),
            Overlap::Partial => {
                if is_leaf(n) {
                    let kids = [0, 1, 2, 3].map(|i| self.fill_node(n, sq.child(i), shape, want, partial, changed));
                    self.make_node(kids)
                } else {
                    for i in 0..4 {
                        let k = self.groups[n as usize][i];
                        let k2 = self.fill_node(k, sq.child(i), shape, want, partial, changed);
                        self.groups[n as usize][i] = k2;
                    }
                    self.forget_hash(n);
                    self.merge_if_uniform(n)
                }
            }
        }
    }

    /// [`fill_node`](Self::fill_node) on node `n` at [`BLOCK_LEVEL`] (a leaf or a block)
    /// that the shape overlaps as `overlap`: one word operation when the shape classifies
    /// the 64 cells at once.
    #[allow(clippy::too_many_arguments)] // one recursive step: the walk's state, not options
    fn fill_block<S: Shape>(
        &mut self,
        n: NodeRef,
        sq: Square,
        overlap: Overlap,
        shape: &S,
        value: bool,
        partial: PartialCells,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        let bits = self.bits_of(n, BLOCK_LEVEL);
        let filled = match overlap {
            Overlap::Disjoint => return n,
            Overlap::Contains => {
                self.report_node(self.node(n), sq, value, changed);
                if value { u64::MAX } else { 0 }
            }
            Overlap::Partial => match shape.classify_cells(&self.block_cells(sq)) {
                Some(m) => {
                    let cover = block::z_order(match partial {
                        PartialCells::Include => m.intersects,
                        PartialCells::Exclude => m.contains,
                    });
                    let filled = if value { bits | cover } else { bits & !cover };
                    report_bits(filled ^ bits, sq, changed);
                    filled
                }
                None => self.fill_bits(bits, sq, shape, value, partial, changed),
            },
        };
        self.store_bits(n, filled)
    }

    /// [`fill_node`](Self::fill_node) on the cells `bits` of a square at or below
    /// [`BLOCK_LEVEL`]: the same tests in the same order, on a word instead of nodes.
    fn fill_bits<S: Shape>(
        &self,
        bits: u64,
        sq: Square,
        shape: &S,
        value: bool,
        partial: PartialCells,
        changed: &mut impl FnMut(Square),
    ) -> u64 {
        let target = if value { block::low_bits(sq.level) } else { 0 };
        if bits == target {
            return bits;
        }
        match shape.classify(&self.grid.square(sq.x, sq.y, sq.level)) {
            Overlap::Disjoint => bits,
            Overlap::Partial if sq.level == 0 => {
                if partial == PartialCells::Include {
                    changed(sq);
                    target
                } else {
                    bits
                }
            }
            Overlap::Contains => {
                self.report_node(Node::from_bits(bits, sq.level), sq, value, changed);
                target
            }
            Overlap::Partial => block::join_kids(sq.level, |i| {
                let kid = block::child_bits(bits, sq.level, i);
                self.fill_bits(kid, sq.child(i), shape, value, partial, changed)
            }),
        }
    }

    /// Replace node `n` of square `sq` by leaf `want`, reporting the leaves that change.
    fn replace_with_leaf(
        &mut self,
        n: NodeRef,
        sq: Square,
        want: NodeRef,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        self.report_leaves(n, sq, want, changed);
        self.release(n);
        want
    }

    /// Report the leaves below `n` that differ from `want`.
    #[inline]
    fn report_leaves(&self, n: NodeRef, sq: Square, want: NodeRef, changed: &mut impl FnMut(Square)) {
        self.report_node(self.node(n), sq, want == FULL, changed);
    }

    fn report_node(&self, n: Node, sq: Square, want: bool, changed: &mut impl FnMut(Square)) {
        if let Node::Leaf(v) = n {
            if v != want {
                changed(sq);
            }
            return;
        }
        for (i, k) in self.kids(n).into_iter().enumerate() {
            self.report_node(k, sq.child(i), want, changed);
        }
    }

    /// Turn a group whose children became one leaf value into that leaf.
    fn merge_if_uniform(&mut self, n: NodeRef) -> NodeRef {
        let kids = self.groups[n as usize];
        if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
            self.free_groups.push(n);
            kids[0]
        } else {
            n
        }
    }

    /// Make `self` the cell-wise union (OR) of itself and `other`. Both must cover the same
    /// grid depth. Returns whether anything changed.
    pub fn union_with(&mut self, other: &RegionQuadtree) -> bool {
        self.union_counting(other) > 0
    }

    /// [`union_with`](Self::union_with), returning how many cells became `1`: a known map
    /// keeps its count up to date without a traversal of the whole tree.
    pub fn union_counting(&mut self, other: &RegionQuadtree) -> u64 {
        self.union_reporting(other, |_| {})
    }

    /// [`union_counting`](Self::union_counting), calling `changed` with squares that hold
    /// every cell that became `1` (a square may hold cells that were `1` already): what a
    /// known map's frontier needs to look at again after a merge.
    pub fn union_reporting(&mut self, other: &RegionQuadtree, mut changed: impl FnMut(Square)) -> u64 {
        assert_eq!(self.grid.depth(), other.grid.depth(), "trees over different grids");
        let mut added = 0;
        let root = self.root_square();
        self.root = self.union_node(self.root, root, other, other.root, &mut added, &mut changed);
        added
    }

    fn union_node(
        &mut self,
        n: NodeRef,
        sq: Square,
        other: &RegionQuadtree,
        m: NodeRef,
        added: &mut u64,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        let level = sq.level;
        if n == FULL || m == super::EMPTY {
            return n;
        }
        if m == FULL {
            *added += (1u64 << (2 * u32::from(level))) - self.full_cells(n, level);
            self.release(n);
            changed(sq);
            return FULL;
        }
        if n == super::EMPTY {
            *added += other.full_cells(m, level);
            changed(sq);
            return self.copy_from(other, m, level);
        }
        // Groups both: equal hashes mean equal contents, which add nothing (the other
        // tree's hashes are kept when it was shared for merging; see `hash`). Not above
        // `HASHED_LEVELS`: maps that differ anywhere differ there, and each view marked
        // would make this tree work out those groups' hashes again.
        if level <= super::hash::HASHED_LEVELS
            && !is_block(n)
            && !is_block(m)
            && let Some(theirs) = other.known_hash(m)
            && self.hash_of(n) == theirs
        {
            return n;
        }
        if self.packs(level) {
            // Both mixed: one OR settles the 64 cells.
            let (mine, theirs) = (self.bits_of(n, level), other.bits_of(m, level));
            let union = mine | theirs;
            if union == mine {
                return n;
            }
            *added += u64::from(union.count_ones() - mine.count_ones());
            changed(sq);
            return self.store_bits(n, union);
        }
        // Maps that were exchanged before are mostly alike: settle equal leaves here rather
        // than in a call, and write back (and try to merge) only children that changed.
        let (kids, theirs) = (self.groups[n as usize], other.groups[m as usize]);
        if self.packs(level - 1) && other.packs(level - 1) {
            return self.union_blocks(n, sq, kids, other, theirs, added, changed);
        }
        let (mut any, before) = (false, *added);
        for i in 0..4 {
            let (k, mk) = (kids[i], theirs[i]);
            if k == FULL || mk == super::EMPTY {
                continue;
            }
            let k2 = self.union_node(k, sq.child(i), other, mk, added, changed);
            if k2 != k {
                self.groups[n as usize][i] = k2;
                any = true;
            }
        }
        // A union changes a subtree only by adding cells to it.
        if *added != before {
            self.forget_hash(n);
        }
        // Only a child that became a leaf can make the group uniform.
        if any { self.merge_if_uniform(n) } else { n }
    }

    /// [`union_node`](Self::union_node) for a group `n` whose children are blocks or
    /// leaves (as are those of `other`'s group, `theirs`): the eight children's cells are
    /// read at once and settled without a call each, since merges of maps exchanged before
    /// are mostly no-ops. The same cells, counts, reports and slots as one call per child;
    /// checked by `packed_trees_are_the_unpacked_tree`.
    #[allow(clippy::too_many_arguments)] // `union_node`'s own, with the children it read
    fn union_blocks(
        &mut self,
        n: NodeRef,
        sq: Square,
        kids: [NodeRef; 4],
        other: &RegionQuadtree,
        theirs: [NodeRef; 4],
        added: &mut u64,
        changed: &mut impl FnMut(Square),
    ) -> NodeRef {
        // `bits_of` at the block level, for packed trees only (children here are leaves or
        // blocks), without its general cases.
        let cells = |t: &RegionQuadtree, k: NodeRef| match k {
            FULL => u64::MAX,
            super::EMPTY => 0,
            b => t.block_bits(b),
        };
        let mut any = false;
        for i in 0..4 {
            let (k, mk) = (kids[i], theirs[i]);
            if k == FULL || mk == super::EMPTY {
                continue;
            }
            let mine = cells(self, k);
            let union = mine | cells(other, mk);
            if union == mine {
                continue;
            }
            *added += u64::from(union.count_ones() - mine.count_ones());
            changed(sq.child(i));
            self.forget_hash(n);
            let k2 = self.store_bits(k, union);
            if k2 != k {
                self.groups[n as usize][i] = k2;
                any = true;
            }
        }
        if any { self.merge_if_uniform(n) } else { n }
    }

    /// Cells of value `1` under node `n` of a square at `level`.
    fn full_cells(&self, n: NodeRef, level: u8) -> u64 {
        match n {
            FULL => 1u64 << (2 * u32::from(level)),
            super::EMPTY => 0,
            b if is_block(b) => u64::from(self.bits_of(b, level).count_ones()),
            g => self.groups[g as usize]
                .iter()
                .map(|&k| self.full_cells(k, level - 1))
                .sum(),
        }
    }

    /// A copy of `other`'s subtree `m` at `level`, stored in `self`.
    fn copy_from(&mut self, other: &RegionQuadtree, m: NodeRef, level: u8) -> NodeRef {
        if is_leaf(m) {
            return m;
        }
        if self.packs(level) {
            let bits = other.bits_of(m, level);
            return self.store_bits(super::EMPTY, bits);
        }
        if is_block(m) {
            return self.unpack_from(other, other.node(m));
        }
        let kids = other.children(m).map(|k| self.copy_from(other, k, level - 1));
        self.make_node(kids)
    }
}

/// Report the set cells of `bits`, a square at `sq` (≤ [`BLOCK_LEVEL`]), as the fewest
/// squares of the implicit quadtree.
fn report_bits(bits: u64, sq: Square, changed: &mut impl FnMut(Square)) {
    if bits == 0 {
        return;
    }
    if bits == block::low_bits(sq.level) {
        changed(sq);
        return;
    }
    for i in 0..4 {
        report_bits(block::child_bits(bits, sq.level, i), sq.child(i), changed);
    }
}
