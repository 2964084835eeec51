//! In-place updates. Groups freed by an update are reused by the next, so a tree's memory
//! follows the size of the region it describes, not the number of updates made to it.

use super::{FULL, NodeRef, RegionQuadtree, Square, is_leaf, leaf};
use crate::geometry::{Aabb, Overlap, Shape};

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
        let root = self.root_square();
        let before = self.root;
        let mut changed = false;
        self.root = self.fill_node(before, root, shape, leaf(value), partial, &mut changed);
        changed
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
        changed: &mut bool,
    ) -> NodeRef {
        if n == want {
            return n;
        }
        match shape.classify(&self.grid.square(sq.x, sq.y, sq.level)) {
            Overlap::Disjoint => n,
            Overlap::Partial if sq.level == 0 => {
                if partial == PartialCells::Include {
                    *changed = true;
                    want
                } else {
                    n
                }
            }
            Overlap::Contains => {
                *changed = true;
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
        assert_eq!(self.grid.depth(), other.grid.depth(), "trees over different grids");
        let mut changed = false;
        self.root = self.union_node(self.root, other, other.root, &mut changed);
        changed
    }

    fn union_node(&mut self, n: NodeRef, other: &RegionQuadtree, m: NodeRef, changed: &mut bool) -> NodeRef {
        if n == FULL || m == super::EMPTY {
            return n;
        }
        if m == FULL {
            *changed = true;
            self.release(n);
            return FULL;
        }
        if n == super::EMPTY {
            *changed = true;
            return self.copy_from(other, m);
        }
        for i in 0..4 {
            let k = self.groups[n as usize][i];
            let k2 = self.union_node(k, other, other.groups[m as usize][i], changed);
            self.groups[n as usize][i] = k2;
        }
        self.merge_if_uniform(n)
    }

    fn copy_from(&mut self, other: &RegionQuadtree, m: NodeRef) -> NodeRef {
        if is_leaf(m) {
            return m;
        }
        let kids = other.groups[m as usize].map(|k| self.copy_from(other, k));
        self.make_node(kids)
    }
}
