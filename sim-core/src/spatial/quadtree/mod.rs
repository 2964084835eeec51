//! The binary region quadtree behind the obstacle map and the robots' known maps.
//!
//! A node is a `u32`: one of two leaf codes (`EMPTY`, `FULL`), the index of a group of
//! four children in `groups` (order: SW, SE, NW, NE — bit 0 of the child index is the x half,
//! bit 1 the y half), or the index of a *block* in `blocks`. A node's square is derived on
//! descent from the grid, so nodes carry no coordinates, uniform space costs nothing below
//! its leaf, and a query prunes a subtree with one box test. Uniform siblings are always
//! merged (see [`RegionQuadtree::validate`]).
//!
//! **Bit-packed bottom**: in a tree at least 8 cells a side, every mixed square of 8 × 8
//! cells is a block, one `u64` with a bit per cell in Z order (see [`block`]), instead of
//! up to 21 groups of four references (a group is 16 bytes, a block 8). The quadtree below
//! a block is implicit in the bits: a 4 × 4 or 2 × 2 run of equal bits is a leaf. Queries
//! see it through [`Node`], so they walk one tree whatever its storage; updates and unions
//! act on a block with a few word operations. Invariant: a packed tree is the same
//! canonical tree, with the same leaves, counts and map-file bytes, as its unpacked twin;
//! only the order in which a query reports a block's leaves may differ (see
//! [`RegionQuadtree::visit_leaves_in`]). Checked by `packed_trees_are_the_unpacked_tree`
//! and [`RegionQuadtree::validate`].
//!
//! Split by operation: `build` (from rasters, predicates and region classifiers), `query`
//! (shape visitors, ray casting, areas), `update` (fill, union), `validate`, `codec` (the
//! map file's bit string), `block` (the packed bottom), `components` (connected free
//! space), `hash` (content hashes for unions), `state` (the checkpoint form), and
//! `directory` and `block_memo` (shortcuts to blocks). Node references are
//! internal to sim-core; users see squares, values and shapes.

pub(crate) mod block;
mod block_memo;
mod build;
mod codec;
mod components;
mod directory;
mod hash;
mod query;
mod state;
#[cfg(test)]
mod tests;
mod update;
mod validate;

pub(crate) use block_memo::BlockMemo;
pub use build::{BitGrid, Region};
pub use components::Components;
pub(crate) use directory::Directory;
pub(crate) use query::Finger;
pub use update::PartialCells;

use crate::spatial::geometry::{Aabb, BlockCells};
use crate::spatial::grid::{Grid, MAX_DEPTH};
use block::{BLOCK_LEVEL, Node, internal_nodes_in};

/// A node reference: a leaf code, a group index, or a block index tagged with `BLOCK_TAG`.
pub(crate) type NodeRef = u32;
/// Leaf code of a uniformly empty square (free space / unknown space).
pub(crate) const EMPTY: NodeRef = u32::MAX;
/// Leaf code of a uniformly full square (obstacle / known space).
pub(crate) const FULL: NodeRef = u32::MAX - 1;
/// Set in a block reference; the other bits index `blocks`.
const BLOCK_TAG: u32 = 1 << 31;
/// Largest usable group index.
const MAX_GROUPS: usize = (BLOCK_TAG - 1) as usize;
/// Largest usable block index.
const MAX_BLOCKS: usize = (FULL - BLOCK_TAG - 1) as usize;

/// Whether a node reference is a leaf.
#[inline]
pub(crate) fn is_leaf(n: NodeRef) -> bool {
    n >= FULL
}

/// Whether a node reference is a block (an 8 × 8 square stored as bits).
#[inline]
pub(crate) fn is_block(n: NodeRef) -> bool {
    (BLOCK_TAG..FULL).contains(&n)
}

/// The leaf code for a value.
#[inline]
pub(crate) fn leaf(value: bool) -> NodeRef {
    if value { FULL } else { EMPTY }
}

/// A region quadtree of boolean cells over a [`Grid`].
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(try_from = "state::TreeState")]
pub struct RegionQuadtree {
    grid: Grid,
    root: NodeRef,
    groups: Vec<[NodeRef; 4]>,
    /// Groups released by updates, reused before `groups` grows.
    free_groups: Vec<u32>,
    /// Mixed 8 × 8 squares, a bit per cell in Z order.
    blocks: Vec<u64>,
    /// Blocks released by updates, reused before `blocks` grows.
    free_blocks: Vec<u32>,
    /// Internal nodes implicit in the live blocks (so the leaf count stays O(1)).
    block_internal: usize,
    /// Whether mixed squares of [`BLOCK_LEVEL`] are blocks (false only in trees under
    /// 8 cells a side, and in the unpacked copies that [`Components`] walks).
    packed: bool,
    /// Content hash of each group (`hash::NO_HASH` until worked out), once the tree keeps
    /// them (empty before): unions skip subtrees equal to the other tree's (see `hash`).
    hashes: Vec<u64>,
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

/// Some cells of one square of a tree: all of them, or those of a bit mask inside an 8 × 8
/// block. What a block-wise fill reports, and what the collective explored map takes from
/// the robots' own maps: a view's gain in one block is one set, settled by one descent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellSet {
    square: Square,
    /// `u64::MAX`: every cell of `square`; otherwise `square` is a block and these are its
    /// cells in Z order (see [`block`]).
    bits: u64,
}

impl CellSet {
    /// Every cell of `square`.
    pub fn whole(square: Square) -> Self {
        Self { square, bits: u64::MAX }
    }

    /// The cells `bits` (Z order, not all set) of the block at `square`.
    pub(crate) fn of_block(square: Square, bits: u64) -> Self {
        debug_assert_eq!(square.level, block::BLOCK_LEVEL);
        Self { square, bits }
    }

    /// The square the cells lie in.
    pub fn square(&self) -> Square {
        self.square
    }

    /// The set's cells in its block (Z order; all of them for a whole square).
    pub(crate) fn bits(&self) -> u64 {
        self.bits
    }

    /// Whether the set is its whole square.
    pub fn is_whole(&self) -> bool {
        self.bits == u64::MAX
    }

    /// Number of cells in the set.
    pub fn cells(&self) -> u64 {
        if self.is_whole() {
            self.square.cells()
        } else {
            u64::from(self.bits.count_ones())
        }
    }

    /// Call `visit` with every cell `(x, y)` of the set (in Z order within the square).
    pub fn for_each_cell(&self, mut visit: impl FnMut(u32, u32)) {
        let sq = self.square;
        if self.is_whole() {
            for y in sq.y..sq.y + sq.side_cells() {
                for x in sq.x..sq.x + sq.side_cells() {
                    visit(x, y);
                }
            }
            return;
        }
        let mut bits = self.bits;
        while bits != 0 {
            let (dx, dy) = block::cell_at(bits.trailing_zeros());
            visit(sq.x + dx, sq.y + dy);
            bits &= bits - 1;
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

/// A shape's bounds, for skipping the squares a shape cannot meet: a child square holding
/// the bounds with room to spare is the only child the shape can overlap, its siblings being
/// disjoint from it whatever the rounding of the shapes' box tests.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reach {
    bounds: Aabb,
    /// The room to spare: far more than any rounding at these coordinates (infinite bounds
    /// give NaN, and no square holds them).
    eps: f64,
}

impl Reach {
    pub(crate) fn new(bounds: Aabb) -> Self {
        Self {
            bounds,
            eps: bounds.rounding_margin(),
        }
    }

    /// The child of `sq` that holds the bounds with room to spare, if one does.
    #[inline]
    pub(crate) fn child_holding(&self, grid: &Grid, sq: Square) -> Option<usize> {
        if sq.level == 0 {
            return None;
        }
        let (b, e) = (&self.bounds, self.eps);
        let box_of = grid.square(sq.x, sq.y, sq.level);
        let mid = (box_of.min + box_of.max) * 0.5;
        // The child on the bounds' side of the middle, if they lie wholly on one side.
        let east = if b.min.x > mid.x {
            1
        } else if b.max.x < mid.x {
            0
        } else {
            return None;
        };
        let north = if b.min.y > mid.y {
            2
        } else if b.max.y < mid.y {
            0
        } else {
            return None;
        };
        let i = east | north;
        let c = sq.child(i);
        let cb = grid.square(c.x, c.y, c.level);
        let holds =
            cb.min.x + e < b.min.x && b.max.x < cb.max.x - e && cb.min.y + e < b.min.y && b.max.y < cb.max.y - e;
        holds.then_some(i)
    }
}

/// Fixed-capacity traversal stack: a depth-first walk never holds more than three pending
/// siblings per level plus the current node, so no query allocates. Entries are node
/// references in the hot walks (16 bytes an entry: the stack is zeroed on every query).
pub(crate) struct Stack<T> {
    items: [(T, Square); 4 * MAX_DEPTH as usize + 4],
    len: usize,
}

impl<T: Copy> Stack<T> {
    /// A stack holding `root` at the root square of a tree of `depth`; `zero` fills the
    /// unused slots.
    #[inline]
    pub(crate) fn new(zero: T, root: T, depth: u8) -> Self {
        Self::starting_at(
            zero,
            root,
            Square {
                x: 0,
                y: 0,
                level: depth,
            },
        )
    }

    /// A stack holding node `n` of square `sq` (a walk that starts below the root).
    #[inline]
    pub(crate) fn starting_at(zero: T, n: T, sq: Square) -> Self {
        let mut s = Self {
            items: [(zero, Square { x: 0, y: 0, level: 0 }); 4 * MAX_DEPTH as usize + 4],
            len: 0,
        };
        s.push(n, sq);
        s
    }
    #[inline]
    pub(crate) fn push(&mut self, n: T, sq: Square) {
        self.items[self.len] = (n, sq);
        self.len += 1;
    }
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<(T, Square)> {
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
            blocks: Vec::new(),
            free_blocks: Vec::new(),
            block_internal: 0,
            packed: grid.depth() >= BLOCK_LEVEL,
            hashes: Vec::new(),
        }
    }

    /// A tree from decoded parts; callers must [`validate`](Self::validate) it.
    pub(crate) fn from_parts(grid: Grid, root: NodeRef, groups: Vec<[NodeRef; 4]>, blocks: Vec<u64>) -> Self {
        let block_internal = blocks.iter().map(|&b| internal_nodes_in(b)).sum();
        Self {
            root,
            groups,
            blocks,
            block_internal,
            ..Self::uniform(grid, false)
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

    /// The children of a group.
    #[inline]
    pub(crate) fn children(&self, n: NodeRef) -> &[NodeRef; 4] {
        &self.groups[n as usize]
    }

    /// Whether a square at `level` is stored as a block when mixed.
    #[inline]
    pub(crate) fn packs(&self, level: u8) -> bool {
        self.packed && level == BLOCK_LEVEL
    }

    /// Number of internal nodes in use (those implicit in blocks included).
    pub fn internal_nodes(&self) -> usize {
        self.groups.len() - self.free_groups.len() + self.block_internal
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
            + self.blocks.capacity() * std::mem::size_of::<u64>()
            + self.free_blocks.capacity() * std::mem::size_of::<u32>()
            + self.hashes.capacity() * std::mem::size_of::<u64>()
    }

    /// Give memory that updates released back to the allocator by compacting the tree.
    pub fn compact(&mut self) {
        if self.free_groups.is_empty() && self.free_blocks.is_empty() {
            return;
        }
        let mut groups = Vec::with_capacity(self.groups.len() - self.free_groups.len());
        let mut blocks = Vec::with_capacity(self.blocks.len() - self.free_blocks.len());
        self.root = self.copy_into(self.root, &mut groups, &mut blocks);
        // Groups are numbered anew: hashes are worked out again when asked.
        self.hashes = Vec::new();
        self.groups = groups;
        self.blocks = blocks;
        self.free_groups = Vec::new();
        self.free_blocks = Vec::new();
    }

    fn copy_into(&self, n: NodeRef, groups: &mut Vec<[NodeRef; 4]>, blocks: &mut Vec<u64>) -> NodeRef {
        if is_leaf(n) {
            return n;
        }
        if is_block(n) {
            blocks.push(self.block_bits(n));
            return BLOCK_TAG + (blocks.len() - 1) as NodeRef;
        }
        let c = self.groups[n as usize];
        let kids = c.map(|k| self.copy_into(k, groups, blocks));
        groups.push(kids);
        (groups.len() - 1) as NodeRef
    }

    /// Store a group of children, merging it into a leaf when all four are the same leaf.
    pub(crate) fn make_node(&mut self, kids: [NodeRef; 4]) -> NodeRef {
        if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
            return kids[0];
        }
        if let Some(i) = self.free_groups.pop() {
            self.groups[i as usize] = kids;
            self.forget_hash(i);
            i
        } else {
            assert!(self.groups.len() < MAX_GROUPS, "quadtree exceeds 2^31 groups");
            if self.keeps_hashes() {
                self.hashes.push(hash::NO_HASH);
            }
            self.groups.push(kids);
            (self.groups.len() - 1) as NodeRef
        }
    }

    /// The cells of block `n`.
    #[inline]
    fn block_bits(&self, n: NodeRef) -> u64 {
        self.blocks[(n - BLOCK_TAG) as usize]
    }

    /// The cells of a node at [`BLOCK_LEVEL`] or below as bits (see [`block`]), whatever
    /// its storage: a leaf, a block, or (in unpacked trees) groups.
    pub(crate) fn bits_of(&self, n: NodeRef, level: u8) -> u64 {
        debug_assert!(level <= BLOCK_LEVEL);
        match n {
            EMPTY => 0,
            FULL => block::low_bits(level),
            b if is_block(b) => self.block_bits(b),
            g => {
                let kids = self.groups[g as usize];
                block::join_kids(level, |i| self.bits_of(kids[i], level - 1))
            }
        }
    }

    /// Replace node `n` at [`BLOCK_LEVEL`] (a leaf or a block) by the square whose cells
    /// are `bits`: a leaf if they agree, else a block (`n`'s own if it was one).
    pub(crate) fn store_bits(&mut self, n: NodeRef, bits: u64) -> NodeRef {
        if bits == 0 || bits == u64::MAX {
            self.release(n);
            return leaf(bits != 0);
        }
        if is_block(n) {
            let slot = &mut self.blocks[(n - BLOCK_TAG) as usize];
            if *slot != bits {
                self.block_internal = self.block_internal - internal_nodes_in(*slot) + internal_nodes_in(bits);
                *slot = bits;
            }
            return n;
        }
        self.block_internal += internal_nodes_in(bits);
        if let Some(i) = self.free_blocks.pop() {
            self.blocks[i as usize] = bits;
            BLOCK_TAG + i
        } else {
            assert!(self.blocks.len() < MAX_BLOCKS, "quadtree exceeds 2^31 blocks");
            self.blocks.push(bits);
            BLOCK_TAG + (self.blocks.len() - 1) as NodeRef
        }
    }

    /// The cell edges of the block at square `sq`, for [`Shape::classify_cells`].
    #[inline]
    pub(crate) fn block_cells(&self, sq: Square) -> BlockCells {
        let mut cells = BlockCells {
            xs: [0.0; 9],
            ys: [0.0; 9],
        };
        for i in 0..9 {
            // `Grid::corner`, the same arithmetic as the boxes `classify` sees.
            let c = self.grid.corner(sq.x + i, sq.y + i);
            cells.xs[i as usize] = c.x;
            cells.ys[i as usize] = c.y;
        }
        cells
    }

    /// The view of node `n` that walks see (blocks as their bits).
    #[inline]
    pub(crate) fn node(&self, n: NodeRef) -> Node {
        match n {
            EMPTY => Node::Leaf(false),
            FULL => Node::Leaf(true),
            b if is_block(b) => Node::Bits {
                bits: self.block_bits(b),
                level: BLOCK_LEVEL,
            },
            g => Node::Group(g),
        }
    }

    /// The four children of an internal node.
    #[inline]
    pub(crate) fn kids(&self, node: Node) -> [Node; 4] {
        match node {
            Node::Group(g) => self.groups[g as usize].map(|k| self.node(k)),
            Node::Bits { bits, level } => block::kids(bits, level),
            Node::Leaf(_) => unreachable!("a leaf has no children"),
        }
    }

    /// Child `i` of an internal node.
    #[inline]
    pub(crate) fn kid(&self, node: Node, i: usize) -> Node {
        match node {
            Node::Group(g) => self.node(self.groups[g as usize][i]),
            Node::Bits { bits, level } => block::kid(bits, level, i),
            Node::Leaf(_) => unreachable!("a leaf has no children"),
        }
    }

    /// Release a subtree's groups and blocks for reuse.
    pub(crate) fn release(&mut self, n: NodeRef) {
        if is_leaf(n) {
            return;
        }
        if is_block(n) {
            self.block_internal -= internal_nodes_in(self.block_bits(n));
            self.free_blocks.push(n - BLOCK_TAG);
            return;
        }
        let kids = self.groups[n as usize];
        for k in kids {
            self.release(k);
        }
        self.free_groups.push(n);
    }

    /// The same tree with groups down to single cells and no blocks, for walks that need a
    /// reference to every internal node ([`Components`]).
    pub(crate) fn unpacked(&self) -> RegionQuadtree {
        let mut out = Self {
            packed: false,
            ..Self::uniform(self.grid, false)
        };
        out.root = out.unpack_from(self, self.node(self.root));
        out
    }

    fn unpack_from(&mut self, other: &RegionQuadtree, node: Node) -> NodeRef {
        if let Node::Leaf(v) = node {
            return leaf(v);
        }
        let kids = other.kids(node).map(|k| self.unpack_from(other, k));
        self.make_node(kids)
    }
}
