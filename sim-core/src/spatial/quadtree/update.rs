//! In-place updates. Groups freed by an update are reused by the next, so a tree's memory
//! follows the size of the region it describes, not the number of updates made to it.

use super::{FULL, NodeRef, RegionQuadtree, Square, is_leaf, leaf};
use crate::spatial::geometry::{Aabb, Overlap, Shape};

/// What [`RegionQuadtree::fill`] does with a cell the shape covers only in part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartialCells {
    /// Set it (over-approximate the shape: "a cell touching a shape is blocked").
    Include,
    /// Leave it (under-approximate: "known only where fully seen").
    Exclude,
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
            Overlap::Partial if sq.level == 0 => {
                if partial == PartialCells::Include {
                    changed(sq);
                    want
                } else {
                    n
                }
            }
            Overlap::Contains => {
                self.report_leaves(n, sq, want, changed);
                self.release(n);
                want
            }
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
                    self.merge_if_uniform(n)
                }
            }
        }
    }

    /// Report the leaves below `n` that differ from `want`.
    fn report_leaves(&self, n: NodeRef, sq: Square, want: NodeRef, changed: &mut impl FnMut(Square)) {
        if is_leaf(n) {
            if n != want {
                changed(sq);
            }
            return;
        }
        let kids = self.groups[n as usize];
        for (i, k) in kids.into_iter().enumerate() {
            self.report_leaves(k, sq.child(i), want, changed);
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
    /// keeps its count up to date without a traversal of the whole tree (issue 11: the
    /// recount after every merge was a twentieth of a crowded round).
    pub fn union_counting(&mut self, other: &RegionQuadtree) -> u64 {
        assert_eq!(self.grid.depth(), other.grid.depth(), "trees over different grids");
        let mut added = 0;
        self.root = self.union_node(self.root, self.grid.depth(), other, other.root, &mut added);
        added
    }

    fn union_node(&mut self, n: NodeRef, level: u8, other: &RegionQuadtree, m: NodeRef, added: &mut u64) -> NodeRef {
        if n == FULL || m == super::EMPTY {
            return n;
        }
        if m == FULL {
            *added += (1u64 << (2 * u32::from(level))) - self.full_cells(n, level);
            self.release(n);
            return FULL;
        }
        if n == super::EMPTY {
            *added += other.full_cells(m, level);
            return self.copy_from(other, m);
        }
        // Maps that were exchanged before are mostly alike: settle equal leaves here rather
        // than in a call, and write back (and try to merge) only children that changed.
        let (kids, theirs) = (self.groups[n as usize], other.groups[m as usize]);
        let mut changed = false;
        for i in 0..4 {
            let (k, mk) = (kids[i], theirs[i]);
            if k == FULL || mk == super::EMPTY {
                continue;
            }
            let k2 = self.union_node(k, level - 1, other, mk, added);
            if k2 != k {
                self.groups[n as usize][i] = k2;
                changed = true;
            }
        }
        // Only a child that became a leaf can make the group uniform.
        if changed { self.merge_if_uniform(n) } else { n }
    }

    /// Cells of value `1` under node `n` of a square at `level`.
    fn full_cells(&self, n: NodeRef, level: u8) -> u64 {
        match n {
            FULL => 1u64 << (2 * u32::from(level)),
            super::EMPTY => 0,
            g => self.groups[g as usize]
                .iter()
                .map(|&k| self.full_cells(k, level - 1))
                .sum(),
        }
    }

    fn copy_from(&mut self, other: &RegionQuadtree, m: NodeRef) -> NodeRef {
        if is_leaf(m) {
            return m;
        }
        let kids = other.groups[m as usize].map(|k| self.copy_from(other, k));
        self.make_node(kids)
    }
}
