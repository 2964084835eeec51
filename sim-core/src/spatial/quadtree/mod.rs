//! The binary region quadtree behind the obstacle map and the robots' known maps.
//!
//! A node is a `u32`: one of two leaf codes (`EMPTY`, `FULL`) or the index of a group of
//! four children in `groups` (order: SW, SE, NW, NE — bit 0 of the child index is the x half,
//! bit 1 the y half). A node's square is derived on descent from the grid, so nodes carry no
//! coordinates, uniform space costs nothing below its leaf, and a query prunes a subtree with
//! one box test. Uniform siblings are always merged (see [`RegionQuadtree::validate`]).
//!
//! Split by operation: `build` (from rasters, predicates and region classifiers), `query`
//! (shape visitors, ray casting, areas), `update` (fill, union), `validate`, `codec` (the
//! map file's bit string) and `components` (connected free space). Node references are
//! internal to sim-core; users see squares, values and shapes.

mod build;
mod codec;
mod components;
mod query;
mod update;
mod validate;

pub use build::{BitGrid, Region};
pub use components::Components;
pub use update::PartialCells;

use crate::spatial::grid::{Grid, MAX_DEPTH};

/// A node reference: a leaf code or a group index.
pub(crate) type NodeRef = u32;
/// Leaf code of a uniformly empty square (free space / unknown space).
pub(crate) const EMPTY: NodeRef = u32::MAX;
/// Leaf code of a uniformly full square (obstacle / known space).
pub(crate) const FULL: NodeRef = u32::MAX - 1;
/// Largest usable group index.
const MAX_GROUPS: usize = (u32::MAX - 2) as usize;

/// Whether a node reference is a leaf.
#[inline]
pub(crate) fn is_leaf(n: NodeRef) -> bool {
    n >= FULL
}

/// The leaf code for a value.
#[inline]
pub(crate) fn leaf(value: bool) -> NodeRef {
    if value { FULL } else { EMPTY }
}

/// A region quadtree of boolean cells over a [`Grid`].
#[derive(Clone, Debug)]
pub struct RegionQuadtree {
    grid: Grid,
    root: NodeRef,
    groups: Vec<[NodeRef; 4]>,
    /// Groups released by updates, reused before `groups` grows.
    free_groups: Vec<u32>,
}

/// A square of the tree: lower-left cell and level (`2^level` cells a side).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Square {
    /// Lower-left cell column.
    pub x: u32,
    /// Lower-left cell row.
    pub y: u32,
    /// Level: the square is `2^level` cells a side.
    pub level: u8,
}

impl Square {
    /// Side in cells.
    pub fn side_cells(&self) -> u32 {
        1 << self.level
    }
    /// Number of cells.
    pub fn cells(&self) -> u64 {
        1u64 << (2 * u32::from(self.level))
    }
    /// The child square in quadrant `i` (bit 0: east half, bit 1: north half).
    #[inline]
    #[must_use]
    pub fn child(&self, i: usize) -> Square {
        let half = 1u32 << (self.level - 1);
        Square {
            x: self.x + if i & 1 != 0 { half } else { 0 },
            y: self.y + if i & 2 != 0 { half } else { 0 },
            level: self.level - 1,
        }
    }
}

const FLAG: u8 = 0x80;

/// A level with a flag in its top bit (levels never exceed [`MAX_DEPTH`] < 128).
#[inline]
pub(crate) fn tag(level: u8, flag: bool) -> u8 {
    if flag { level | FLAG } else { level }
}

/// A square whose level carries a flag.
#[inline]
pub(crate) fn tag_square(sq: Square, flag: bool) -> Square {
    Square {
        level: tag(sq.level, flag),
        ..sq
    }
}

/// Split a tagged square into the square and its flag.
#[inline]
pub(crate) fn untag(sq: Square) -> (Square, bool) {
    (
        Square {
            level: sq.level & !FLAG,
            ..sq
        },
        sq.level & FLAG != 0,
    )
}

/// Fixed-capacity traversal stack: a depth-first walk never holds more than three pending
/// siblings per level plus the current node, so no query allocates.
pub(crate) struct Stack {
    items: [(NodeRef, Square); 4 * MAX_DEPTH as usize + 4],
    len: usize,
}

impl Stack {
    #[inline]
    pub(crate) fn new(root: NodeRef, depth: u8) -> Self {
        let zero = (EMPTY, Square { x: 0, y: 0, level: 0 });
        let mut s = Self {
            items: [zero; 4 * MAX_DEPTH as usize + 4],
            len: 0,
        };
        s.push(
            root,
            Square {
                x: 0,
                y: 0,
                level: depth,
            },
        );
        s
    }
    #[inline]
    pub(crate) fn push(&mut self, n: NodeRef, sq: Square) {
        self.items[self.len] = (n, sq);
        self.len += 1;
    }
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<(NodeRef, Square)> {
        if self.len == 0 {
            None
        } else {
            self.len -= 1;
            Some(self.items[self.len])
        }
    }
}

impl RegionQuadtree {
    /// A tree that is uniformly `value` over the whole covering square.
    pub fn uniform(grid: Grid, value: bool) -> Self {
        Self {
            grid,
            root: leaf(value),
            groups: Vec::new(),
            free_groups: Vec::new(),
        }
    }

    /// A tree from decoded parts; callers must [`validate`](Self::validate) it.
    pub(crate) fn from_parts(grid: Grid, root: NodeRef, groups: Vec<[NodeRef; 4]>) -> Self {
        Self {
            grid,
            root,
            groups,
            free_groups: Vec::new(),
        }
    }

    /// The grid the tree covers.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The root node.
    pub(crate) fn root(&self) -> NodeRef {
        self.root
    }

    /// The root square.
    pub fn root_square(&self) -> Square {
        Square {
            x: 0,
            y: 0,
            level: self.grid.depth(),
        }
    }

    /// The children of an internal node.
    #[inline]
    pub(crate) fn children(&self, n: NodeRef) -> &[NodeRef; 4] {
        &self.groups[n as usize]
    }

    /// Number of internal nodes in use.
    pub fn internal_nodes(&self) -> usize {
        self.groups.len() - self.free_groups.len()
    }

    /// Number of leaves (`3 × internal + 1`, as every internal node has four children).
    pub fn leaf_count(&self) -> usize {
        3 * self.internal_nodes() + 1
    }

    /// Heap and inline bytes held by the tree (capacity, not just length: what it costs).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.groups.capacity() * std::mem::size_of::<[NodeRef; 4]>()
            + self.free_groups.capacity() * std::mem::size_of::<u32>()
    }

    /// Give memory that updates released back to the allocator by compacting the tree.
    pub fn compact(&mut self) {
        if self.free_groups.is_empty() {
            return;
        }
        let mut out = Vec::with_capacity(self.internal_nodes());
        self.root = self.copy_into(self.root, &mut out);
        self.groups = out;
        self.free_groups = Vec::new();
    }

    fn copy_into(&self, n: NodeRef, out: &mut Vec<[NodeRef; 4]>) -> NodeRef {
        if is_leaf(n) {
            return n;
        }
        let c = self.groups[n as usize];
        let kids = [
            self.copy_into(c[0], out),
            self.copy_into(c[1], out),
            self.copy_into(c[2], out),
            self.copy_into(c[3], out),
        ];
        out.push(kids);
        (out.len() - 1) as NodeRef
    }

    /// Store a group of children, merging it into a leaf when all four are the same leaf.
    pub(crate) fn make_node(&mut self, kids: [NodeRef; 4]) -> NodeRef {
        if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
            return kids[0];
        }
        if let Some(i) = self.free_groups.pop() {
            self.groups[i as usize] = kids;
            i
        } else {
            assert!(self.groups.len() < MAX_GROUPS, "quadtree exceeds 2^32 nodes");
            self.groups.push(kids);
            (self.groups.len() - 1) as NodeRef
        }
    }

    /// Release a subtree's groups for reuse.
    pub(crate) fn release(&mut self, n: NodeRef) {
        if is_leaf(n) {
            return;
        }
        let kids = self.groups[n as usize];
        for k in kids {
            self.release(k);
        }
        self.free_groups.push(n);
    }
}
