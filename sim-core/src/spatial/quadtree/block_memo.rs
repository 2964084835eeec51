//! Cells a growing tree is known to hold, block by block, for skipping fills that would
//! change nothing.

use crate::spatial::quadtree::block::BLOCK_LEVEL;
use crate::spatial::quadtree::{CellSet, Square};

/// A slot's key when it holds no block.
const NO_BLOCK: u64 = u64::MAX;

/// The key of the block whose south-west cell is `(x, y)`: `bx << 32 | by` in block
/// coordinates.
#[inline]
fn block_key(x: u32, y: u32) -> u64 {
    (u64::from(x >> BLOCK_LEVEL) << 32) | u64::from(y >> BLOCK_LEVEL)
}

/// The blocks that slots of `keys` (and `bits` beside them) hold, with their bits.
#[cfg(test)]
fn held_blocks<'a>(keys: &'a [u64], bits: &'a [u64]) -> impl Iterator<Item = (Square, u64)> + 'a {
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

/// Blocks a side of the window of blocks the memo maps one to one (64 × 64 blocks: 512 ×
/// 512 cells).
const SIDE_BITS: u32 = 6;

/// Some of the cells set in a tree whose cells are only ever set (a collective explored
/// map), for 4,096 of its blocks: each slot holds the block at its block coordinates
/// modulo 64 (so a 512 × 512-cell window of blocks has no two in one slot) and a subset of
/// the block's set cells (Z order, as the tree stores a block).
///
/// A set of cells that a slot already holds would change nothing: the caller skips its
/// descent (most blocks a walker's map gains were explored by another walker before).
/// Invariant: a slot holds a subset of its block's set cells; a subset stays one however
/// the tree grows, so the memo is never stale. Checked by [`check`](Self::check) and
/// `marking_through_the_memo_is_marking_every_set`.
///
/// It holds nothing, and allocates nothing, until the first [`put`](Self::put).
#[derive(Clone, Debug, Default)]
pub(crate) struct BlockMemo {
    /// Block `(bx, by)` as `bx << 32 | by`, or [`NO_BLOCK`] (no slots yet: empty).
    keys: Vec<u64>,
    bits: Vec<u64>,
}

impl BlockMemo {
    /// The slot and key of the block whose south-west cell is `(x, y)`.
    #[inline]
    fn slot(sq: Square) -> (usize, u64) {
        let (bx, by) = (sq.x >> BLOCK_LEVEL, sq.y >> BLOCK_LEVEL);
        let mask = (1 << SIDE_BITS) - 1;
        (
            ((bx & mask) | ((by & mask) << SIDE_BITS)) as usize,
            block_key(sq.x, sq.y),
        )
    }

    /// Whether the memo holds every cell of `set` as set (a set of one block; `false` for
    /// larger squares).
    #[inline]
    pub fn holds(&self, set: CellSet) -> bool {
        let sq = set.square();
        if sq.level != BLOCK_LEVEL {
            return false;
        }
        let (slot, key) = Self::slot(sq);
        self.keys.get(slot) == Some(&key) && set.bits() & !self.bits[slot] == 0
    }

    /// Note that the block at `sq` holds at least the cells `bits` (Z order).
    #[inline]
    pub fn put(&mut self, sq: Square, bits: u64) {
        debug_assert_eq!(sq.level, BLOCK_LEVEL);
        if self.keys.is_empty() {
            let slots = 1 << (2 * SIDE_BITS);
            self.keys = vec![NO_BLOCK; slots];
            self.bits = vec![0; slots];
        }
        let (slot, key) = Self::slot(sq);
        (self.keys[slot], self.bits[slot]) = (key, bits);
    }

    /// Whether every cell held is set in `tree` (a description of the first block where
    /// one is not, otherwise).
    #[cfg(test)]
    pub fn check(&self, tree: &super::RegionQuadtree) -> Result<(), String> {
        for (sq, bits) in held_blocks(&self.keys, &self.bits) {
            let actual = tree.block_bits_at(sq);
            if bits & !actual != 0 {
                return Err(format!(
                    "memo of the block at cell ({}, {}) holds {bits:#x}, the tree only {actual:#x}",
                    sq.x, sq.y
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec2;
    use rand::{Rng, SeedableRng};

    use super::BlockMemo;
    use crate::spatial::quadtree::block::BLOCK_LEVEL;
    use crate::spatial::quadtree::{CellSet, Square};
    use crate::spatial::{Grid, KnownMap};

    /// Marking sets of cells through the memo (skipping those it holds, noting each
    /// block's cells after a fill) grows the same map, reporting the same new cells, as
    /// marking every set; and the memo stays a subset of the map. Sets of random blocks
    /// near a few spots (so blocks repeat and share slots) and some whole squares.
    #[test]
    fn marking_through_the_memo_is_marking_every_set() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 1500, 1500).unwrap();
        let (mut plain, mut memoed) = (KnownMap::new(grid), KnownMap::new(grid));
        let mut memo = BlockMemo::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut skipped, mut reported) = (0, 0);
        for round in 0..3000 {
            // Blocks near spots 64 blocks apart share slots.
            let spot = [(1, 1), (65, 1), (1, 65), (100, 120)][rng.random_range(0..4)];
            let (bx, by) = (spot.0 + rng.random_range(0..8), spot.1 + rng.random_range(0..8));
            let set = if rng.random_range(0..20) == 0 {
                let level = rng.random_range(BLOCK_LEVEL..BLOCK_LEVEL + 3);
                let side = 1 << level;
                CellSet::whole(Square {
                    x: (bx << BLOCK_LEVEL) / side * side,
                    y: (by << BLOCK_LEVEL) / side * side,
                    level,
                })
            } else {
                // A few cells (four on average).
                let bits = rng.random::<u64>() & rng.random::<u64>() & rng.random::<u64>() & rng.random::<u64>();
                let sq = Square {
                    x: bx << BLOCK_LEVEL,
                    y: by << BLOCK_LEVEL,
                    level: BLOCK_LEVEL,
                };
                if bits == 0 || bits == u64::MAX {
                    continue;
                }
                CellSet::of_block(sq, bits)
            };
            let (mut want, mut got) = (Vec::new(), Vec::new());
            plain.mark_cells_reporting(set, |s| want.push(s));
            if memo.holds(set) {
                skipped += 1;
            } else if let Some(after) = memoed.mark_cells_reporting(set, |s| got.push(s)) {
                memo.put(set.square(), after);
            }
            reported += usize::from(!want.is_empty());
            assert_eq!(got, want, "set {round}: {set:?}");
            memo.check(memoed.tree()).unwrap();
        }
        assert_eq!(memoed.known_cells(), plain.known_cells());
        assert_eq!(memoed.tree().leaf_count(), plain.tree().leaf_count());
        assert!(
            skipped > 500 && reported > 500,
            "{skipped} skipped, {reported} reported"
        );
    }
}
