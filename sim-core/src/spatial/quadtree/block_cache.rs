//! The cells of the few blocks around a robot's view, as its known map last saw them.

use crate::cache::prefetch;
use crate::spatial::quadtree::block::BLOCK_LEVEL;
use crate::spatial::quadtree::{RegionQuadtree, Square};

/// Blocks held: a 4 × 4 neighbourhood of blocks, by block coordinates modulo 4, so that a
/// view spanning up to four blocks a side never evicts its own.
const SLOTS: usize = 16;

/// A slot that holds no block.
pub(super) const NO_BLOCK: u64 = u64::MAX;

/// The key of the block whose south-west cell is `(x, y)`: `bx << 32 | by` in block
/// coordinates.
#[inline]
pub(super) fn block_key(x: u32, y: u32) -> u64 {
    (u64::from(x >> BLOCK_LEVEL) << 32) | u64::from(y >> BLOCK_LEVEL)
}

/// The blocks that slots of `keys` (and `bits` beside them) hold, with their bits.
pub(super) fn held_blocks<'a>(keys: &'a [u64], bits: &'a [u64]) -> impl Iterator<Item = (Square, u64)> + 'a {
    keys.iter()
        .zip(bits)
        .filter(|(key, _)| **key != NO_BLOCK)
        .map(|(&key, &bits)| {
            let sq = Square {
                x: ((key >> 32) as u32) << BLOCK_LEVEL,
                y: (key as u32) << BLOCK_LEVEL,
                level: BLOCK_LEVEL,
            };
            (sq, bits)
        })
}

/// The cells (Z-order bits, as the tree stores a block) of up to 16 blocks of a tree,
/// exactly as the tree holds them: [`RegionQuadtree::fill_new_rows_cached`] keeps it up
/// to date and skips the blocks in which it would change nothing without descending the
/// tree. A walker's view mostly touches the same few blocks round after round.
///
/// Invariant: every block held equals the tree's cells there. Whoever changes the tree
/// otherwise must [`clear`](Self::clear) it. Checked by
/// [`check`](Self::check) (run by `KnownMap::validate`) and
/// `views_marked_by_blocks_are_the_walks_cells`.
#[derive(Clone, Debug, PartialEq, Eq)]
#[repr(align(64))] // four whole cache lines, fetched together
pub struct BlockCache {
    /// Block `(bx, by)` as `bx << 32 | by`, or [`NO_BLOCK`].
    keys: [u64; SLOTS],
    bits: [u64; SLOTS],
}

impl Default for BlockCache {
    fn default() -> Self {
        Self {
            keys: [NO_BLOCK; SLOTS],
            bits: [0; SLOTS],
        }
    }
}

impl BlockCache {
    /// The slot and key of the block whose south-west cell is `(x, y)`.
    #[inline]
    fn slot(x: u32, y: u32) -> (usize, u64) {
        let (bx, by) = (x >> BLOCK_LEVEL, y >> BLOCK_LEVEL);
        (((bx & 3) | ((by & 3) << 2)) as usize, block_key(x, y))
    }

    /// The cells of the block at `sq` (a square at [`BLOCK_LEVEL`]), if held.
    #[inline]
    pub(crate) fn get(&self, sq: Square) -> Option<u64> {
        let (slot, key) = Self::slot(sq.x, sq.y);
        (self.keys[slot] == key).then_some(self.bits[slot])
    }

    /// Hold `bits` as the cells of the block at `sq`.
    #[inline]
    pub(crate) fn put(&mut self, sq: Square, bits: u64) {
        let (slot, key) = Self::slot(sq.x, sq.y);
        (self.keys[slot], self.bits[slot]) = (key, bits);
    }

    /// Start loading the cache's lines (see [`prefetch`]).
    #[inline]
    pub(crate) fn prefetch(&self) {
        prefetch(&self.keys[0]);
        prefetch(&self.keys[8]);
        prefetch(&self.bits[0]);
        prefetch(&self.bits[8]);
    }

    /// Hold nothing.
    pub fn clear(&mut self) {
        self.keys = [NO_BLOCK; SLOTS];
    }

    /// Whether every block held has the cells `tree` has there (a description of the first
    /// that does not, otherwise).
    pub fn check(&self, tree: &RegionQuadtree) -> Result<(), String> {
        for (sq, bits) in held_blocks(&self.keys, &self.bits) {
            let actual = tree.block_bits_at(sq);
            if actual != bits {
                return Err(format!(
                    "cached block at cell ({}, {}) holds {bits:#x}, the tree {actual:#x}",
                    sq.x, sq.y
                ));
            }
        }
        Ok(())
    }
}
