//! Known cells of a map around a robot's view, 64 × 64 cells as row masks, so that marking
//! the view leaves out what is known with a word operation per row.
//!
//! Most views add no cell to a walker's map. With the known cells at hand as rows, the
//! view's rows leave them out as they are made (the known cells on its rim need no exact
//! test) and only blocks with cells to set are visited. Invariant: every cell of a loaded
//! block is known in the tree (known maps only grow); checked by [`KnownWindow::check`]
//! (run by `KnownMap::validate`) and `views_through_the_known_window_are_the_walks_cells`.

use crate::cache::prefetch;
use crate::spatial::quadtree::RegionQuadtree;
use crate::spatial::quadtree::Square;
use crate::spatial::quadtree::block::{BLOCK_LEVEL, row_major};
use crate::spatial::view_stencil::KnownRows;

/// Cells a side: a row is a word.
pub(crate) const SIDE: u32 = 64;

/// The widest box of view cells (a side, in cells) a window takes: a view can then move
/// about a quarter of the window each way before the window is loaded again.
pub(crate) const MAX_VIEW_CELLS: u32 = 32;

/// Known cells of a 64 × 64 square of a tree at least 64 cells a side, aligned to its
/// blocks, each of its 8 × 8 blocks loaded from the tree when a view first needs it.
///
/// It holds a part of the tree's known cells: all of them when loaded, and every cell
/// [`add_rows`](Self::add_rows) gives it, but not those the tree learns otherwise (merged
/// maps). As known maps only grow, what it holds stays known, which is all a view needs
/// (what it leaves out of a view is known); a view that finds cells it does not hold, known
/// already, sets them again, which changes nothing in the tree, and adds them here. So a
/// merge need not reload the window: crowds merge maps nearly every round.
#[derive(Clone, Debug)]
pub(crate) struct KnownWindow {
    /// Column and row of the window's south-west cell (multiples of 8).
    x0: u32,
    y0: u32,
    /// Bit `8 by + bx`: the window's block `(bx, by)` has been loaded.
    loaded: u64,
    /// Bit `i` of `rows[j]`: cell `(x0 + i, y0 + j)` is known (in loaded blocks).
    rows: [u64; SIDE as usize],
}

impl Default for KnownWindow {
    fn default() -> Self {
        Self {
            x0: 0,
            y0: 0,
            loaded: 0,
            rows: [0; SIDE as usize],
        }
    }
}

impl KnownWindow {
    /// Start loading the whole window (see [`prefetch`]): its nine lines at once, rather
    /// than the rows around a view, which would wait for the window's place to arrive
    /// first. A hint only: it changes no result.
    #[inline]
    pub(crate) fn prefetch(&self) {
        prefetch(&self.loaded);
        for row in self.rows.iter().step_by(8) {
            prefetch(row);
        }
    }

    /// Whether the window takes views on `tree`: at least 64 cells a side.
    #[inline]
    pub(crate) fn fits(tree: &RegionQuadtree) -> bool {
        tree.grid().side_cells() >= SIDE
    }

    /// Make the window hold the cells `lo ..= hi` (at most [`MAX_VIEW_CELLS`] a side, inside
    /// `tree`, which [`fits`](Self::fits)): moved to be centred on them if they do not lie
    /// in it, then their blocks loaded from `tree` where they are not.
    pub(crate) fn cover(&mut self, tree: &RegionQuadtree, lo: (u32, u32), hi: (u32, u32)) {
        debug_assert!(hi.0 - lo.0 < MAX_VIEW_CELLS && hi.1 - lo.1 < MAX_VIEW_CELLS);
        if lo.0 < self.x0 || lo.1 < self.y0 || hi.0 >= self.x0 + SIDE || hi.1 >= self.y0 + SIDE {
            // On the blocks' grid, inside the tree: the box, at most 32 cells a side, then
            // lies in the window.
            let side = tree.grid().side_cells();
            let start = |a: u32, b: u32| (a.midpoint(b).saturating_sub(SIDE / 2) & !7).min(side - SIDE);
            (self.x0, self.y0) = (start(lo.0, hi.0), start(lo.1, hi.1));
            self.loaded = 0;
        }
        let (bx0, bx1) = ((lo.0 - self.x0) / 8, (hi.0 - self.x0) / 8);
        let (by0, by1) = ((lo.1 - self.y0) / 8, (hi.1 - self.y0) / 8);
        let columns = (u64::MAX >> (63 - bx1)) & (u64::MAX << bx0) & 0xFF;
        for by in by0..=by1 {
            let mut missing = (columns << (8 * by)) & !self.loaded;
            while missing != 0 {
                let b = missing.trailing_zeros();
                missing &= missing - 1;
                self.load_block(tree, b % 8, b / 8);
            }
        }
    }

    /// Load the window's block `(bx, by)` from `tree` (one descent).
    fn load_block(&mut self, tree: &RegionQuadtree, bx: u32, by: u32) {
        let square = Square {
            x: self.x0 + 8 * bx,
            y: self.y0 + 8 * by,
            level: BLOCK_LEVEL,
        };
        let bits = row_major(tree.block_bits_at(square));
        for k in 0..8 {
            let row = &mut self.rows[(8 * by + k) as usize];
            *row = (*row & !(0xFF << (8 * bx))) | (((bits >> (8 * k)) & 0xFF) << (8 * bx));
        }
        self.loaded |= 1 << (8 * by + bx);
    }

    /// The cells it holds, for leaving them out of a view's rows (only those of loaded
    /// blocks, hence of the box last given to [`cover`](Self::cover), are meaningful).
    #[inline]
    pub(crate) fn known_rows(&self) -> KnownRows<'_> {
        KnownRows {
            x0: self.x0,
            y0: self.y0,
            rows: &self.rows,
        }
    }

    /// Note as known the cells of `rows` (bit `i` of `rows[j]`: cell `(x0 + i, y0 + j)`),
    /// which the tree has just been given; they must lie in the window.
    #[inline]
    pub(crate) fn add_rows(&mut self, x0: u32, y0: u32, rows: &[u64]) {
        let shift = x0 - self.x0;
        for (j, &row) in rows.iter().enumerate() {
            self.rows[(y0 - self.y0) as usize + j] |= row << shift;
        }
    }

    /// Whether every cell the window's loaded blocks hold is known in `tree` (a description
    /// of the first block where one is not, otherwise).
    pub(crate) fn check(&self, tree: &RegionQuadtree) -> Result<(), String> {
        let mut fresh = self.clone();
        let mut loaded = self.loaded;
        while loaded != 0 {
            let b = loaded.trailing_zeros();
            loaded &= loaded - 1;
            let (bx, by) = (b % 8, b / 8);
            fresh.load_block(tree, bx, by);
            let rows = (8 * by as usize)..(8 * by as usize + 8);
            let block = |rows: &[u64]| rows.iter().map(|row| (row >> (8 * bx)) & 0xFF).collect::<Vec<_>>();
            let (held, known) = (block(&self.rows[rows.clone()]), block(&fresh.rows[rows]));
            if held.iter().zip(&known).any(|(h, k)| h & !k != 0) {
                return Err(format!(
                    "known window's block at cell ({}, {}) holds rows {held:x?}, the tree knows {known:x?}",
                    self.x0 + 8 * bx,
                    self.y0 + 8 * by
                ));
            }
        }
        Ok(())
    }
}
