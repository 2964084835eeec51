//! Building region quadtrees bottom-up, merging uniform siblings as they are made.

use super::block::{self, BLOCK_LEVEL};
use super::{EMPTY, FULL, NodeRef, RegionQuadtree, Square, leaf};
use crate::spatial::grid::Grid;
use crate::{Error, Result};

/// What a generator knows about a square of cells, for [`RegionQuadtree::from_regions`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Every cell is empty.
    Empty,
    /// Every cell is full.
    Full,
    /// Don't know or mixed: split the square (a single mixed cell counts as full).
    Mixed,
}

/// A packed raster of bits, row 0 at the bottom (y up), as the quadtrees use it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BitGrid {
    width: u32,
    height: u32,
    words: Vec<u64>,
}

impl BitGrid {
    /// An all-zero raster of `width × height` bits.
    pub fn new(width: u32, height: u32) -> Self {
        let bits = u64::from(width) * u64::from(height);
        Self {
            width,
            height,
            words: vec![0; bits.div_ceil(64) as usize],
        }
    }
    /// Width in cells.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in cells.
    pub fn height(&self) -> u32 {
        self.height
    }
    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "cell ({x}, {y}) outside {}×{}",
            self.width,
            self.height
        );
        (u64::from(y) * u64::from(self.width) + u64::from(x)) as usize
    }
    /// The bit of cell `(x, y)`.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> bool {
        let i = self.index(x, y);
        self.words[i / 64] >> (i % 64) & 1 != 0
    }
    /// Set the bit of cell `(x, y)`.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, value: bool) {
        let i = self.index(x, y);
        if value {
            self.words[i / 64] |= 1 << (i % 64);
        } else {
            self.words[i / 64] &= !(1 << (i % 64));
        }
    }
    /// Number of set bits.
    pub fn count_ones(&self) -> u64 {
        self.words.iter().map(|w| u64::from(w.count_ones())).sum()
    }
}

impl RegionQuadtree {
    /// Build from a per-cell predicate over the map's cells; padding cells get `padding`.
    pub fn from_fn(grid: Grid, padding: bool, mut cell: impl FnMut(u32, u32) -> bool) -> Self {
        Self::from_regions(grid, padding, |sq| {
            if sq.level == 0 {
                if cell(sq.x, sq.y) { Region::Full } else { Region::Empty }
            } else {
                Region::Mixed
            }
        })
    }

    /// Build from a raster the size of the grid's map (row 0 at the bottom).
    pub fn from_bitgrid(grid: Grid, bits: &BitGrid, padding: bool) -> Result<Self> {
        if bits.width() != grid.width_cells() || bits.height() != grid.height_cells() {
            return Err(Error::InvalidParameter(format!(
                "raster is {}×{} cells but the map is {}×{}",
                bits.width(),
                bits.height(),
                grid.width_cells(),
                grid.height_cells()
            )));
        }
        Ok(Self::from_fn(grid, padding, |x, y| bits.get(x, y)))
    }

    /// Build top-down from a classifier of squares, so generators that know a region is
    /// uniform (a shape's interior, open terrain) never visit its cells: this is how maps of
    /// 10¹⁰ cells are made without a full raster. `classify` is only asked about squares
    /// that lie wholly inside the map; padding cells get `padding`.
    pub fn from_regions(grid: Grid, padding: bool, mut classify: impl FnMut(Square) -> Region) -> Self {
        let mut tree = Self::uniform(grid, padding);
        let root = tree.root_square();
        tree.root = tree.build_square(root, padding, &mut classify);
        tree
    }

    fn build_square(&mut self, sq: Square, padding: bool, classify: &mut impl FnMut(Square) -> Region) -> NodeRef {
        if self.packs(sq.level) {
            let bits = self.build_bits(sq, padding, classify);
            return self.store_bits(EMPTY, bits);
        }
        let (w, h) = (u64::from(self.grid.width_cells()), u64::from(self.grid.height_cells()));
        let (x0, y0, side) = (u64::from(sq.x), u64::from(sq.y), u64::from(sq.side_cells()));
        if x0 >= w || y0 >= h {
            return leaf(padding);
        }
        if x0 + side <= w && y0 + side <= h {
            match classify(sq) {
                Region::Empty => return EMPTY,
                Region::Full => return FULL,
                Region::Mixed if sq.level == 0 => return FULL,
                Region::Mixed => {}
            }
        }
        let kids = [0, 1, 2, 3].map(|i| self.build_square(sq.child(i), padding, classify));
        self.make_node(kids)
    }

    /// [`build_square`](Self::build_square) for a square at or below [`BLOCK_LEVEL`], as
    /// bits: the same questions to `classify`, in the same order.
    fn build_bits(&self, sq: Square, padding: bool, classify: &mut impl FnMut(Square) -> Region) -> u64 {
        debug_assert!(sq.level <= BLOCK_LEVEL);
        let all = block::low_bits(sq.level);
        let (w, h) = (u64::from(self.grid.width_cells()), u64::from(self.grid.height_cells()));
        let (x0, y0, side) = (u64::from(sq.x), u64::from(sq.y), u64::from(sq.side_cells()));
        if x0 >= w || y0 >= h {
            return if padding { all } else { 0 };
        }
        if x0 + side <= w && y0 + side <= h {
            match classify(sq) {
                Region::Empty => return 0,
                Region::Full => return all,
                Region::Mixed if sq.level == 0 => return all,
                Region::Mixed => {}
            }
        }
        block::join_kids(sq.level, |i| self.build_bits(sq.child(i), padding, classify))
    }
}
