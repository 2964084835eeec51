//! A directory of a tree's nodes at one level, so that a descent to a block starts there
//! instead of at the root: for trees that no longer change (the obstacle map), whose move
//! tests read the one to four blocks around each move.
//!
//! Invariant: a descent from a directory entry reaches the node a descent from the root
//! reaches, as long as the tree is unchanged since the directory was built. Checked by
//! [`RegionQuadtree::check_directory`] (run by `ObstacleMap::validate`) and
//! `descents_from_the_directory_are_the_root_descents`.

use super::block::{BLOCK_LEVEL, Node};
use super::{NodeRef, RegionQuadtree, Square, is_block, is_leaf};

/// Entries a directory holds at most (4 bytes each): it stays within the processor's
/// second-level cache.
const MAX_ENTRIES: usize = 1 << 16;

/// The nodes of one level of a tree, row-major: the node whose square holds each square of
/// that level (the leaf above it where the tree has one). It describes the tree it was
/// built from as it was then: whoever keeps one must not change the tree.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Directory {
    /// The level of the squares it holds (at least the block level).
    level: u8,
    /// Squares a side.
    per_side: u32,
    nodes: Vec<NodeRef>,
}

impl Directory {
    /// The directory of `tree`, at the lowest level with at most [`MAX_ENTRIES`] squares and
    /// no lower than its blocks; `None` for trees without blocks.
    pub(crate) fn new(tree: &RegionQuadtree) -> Option<Self> {
        Self::with_max_entries(tree, MAX_ENTRIES)
    }

    /// [`new`](Self::new) with at most `max_entries` (a power of 4) squares.
    fn with_max_entries(tree: &RegionQuadtree, max_entries: usize) -> Option<Self> {
        let depth = tree.grid().depth();
        if !tree.packs(BLOCK_LEVEL) || depth <= BLOCK_LEVEL {
            return None;
        }
        // 4^(depth - level) entries.
        let lowest = depth.saturating_sub((max_entries.ilog2() / 2) as u8);
        let level = lowest.max(BLOCK_LEVEL);
        let per_side = 1u32 << (depth - level);
        let mut dir = Self {
            level,
            per_side,
            nodes: vec![0; (per_side * per_side) as usize],
        };
        dir.fill(tree, tree.root(), tree.root_square());
        Some(dir)
    }

    /// Set the entries under node `n` of square `sq`.
    fn fill(&mut self, tree: &RegionQuadtree, n: NodeRef, sq: Square) {
        if sq.level == self.level || is_leaf(n) {
            // A leaf's square holds every directory square under it (`sq` is never below
            // the directory's level).
            let (x0, y0) = (sq.x >> self.level, sq.y >> self.level);
            let side = sq.side_cells() >> self.level;
            for y in y0..y0 + side {
                let row = (y * self.per_side) as usize;
                self.nodes[row + x0 as usize..row + (x0 + side) as usize].fill(n);
            }
            return;
        }
        debug_assert!(!is_block(n), "blocks lie at or below the directory's level");
        let kids = *tree.children(n);
        for (i, kid) in kids.into_iter().enumerate() {
            self.fill(tree, kid, sq.child(i));
        }
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.nodes.capacity() * std::mem::size_of::<NodeRef>()
    }
}

impl RegionQuadtree {
    /// The node of square `sq` (at most the directory's level), or the leaf above it: what
    /// a descent from the root finds, from `dir`'s entry down when it is given (it must be
    /// this tree's).
    #[inline]
    pub(crate) fn descend_via(&self, dir: Option<&Directory>, sq: Square) -> Node {
        match dir {
            Some(dir) if sq.level <= dir.level => {
                let at = (sq.y >> dir.level) * dir.per_side + (sq.x >> dir.level);
                let n = self.node(dir.nodes[at as usize]);
                self.descend_from(n, dir.level, sq, |_, _| {})
            }
            _ => self.descend_to(sq),
        }
    }

    /// Whether `dir` is this tree's directory as it stands (what [`Directory::new`] builds).
    pub(crate) fn check_directory(&self, dir: &Directory) -> Result<(), String> {
        match Directory::new(self) {
            Some(fresh) if fresh == *dir => Ok(()),
            _ => Err("the directory does not describe the tree".to_owned()),
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec2;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::Directory;
    use crate::spatial::grid::Grid;
    use crate::spatial::quadtree::{RegionQuadtree, Square};

    /// A descent from a directory entry finds what the descent from the root finds, for
    /// every square at or below the directory's level, whatever the level.
    #[test]
    fn descents_from_the_directory_are_the_root_descents() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for case in 0..24 {
            let (w, h) = (rng.random_range(9..300), rng.random_range(9..300));
            let grid = Grid::new(DVec2::ZERO, 1.0, w, h).unwrap();
            let (density, clumpy) = (rng.random_range(0.0..0.6), rng.random_bool(0.5));
            let tree = RegionQuadtree::from_fn(grid, true, |x, y| {
                if clumpy {
                    (x / 11 + y / 7) % 4 == 0
                } else {
                    rng.random_bool(density)
                }
            });
            for max_entries in [1, 4, 16, 256, 1 << 16] {
                let dir = Directory::with_max_entries(&tree, max_entries).expect("trees of 9 cells a side pack");
                tree.check_directory(&Directory::new(&tree).unwrap()).unwrap();
                for level in 0..=dir.level {
                    let side = grid.side_cells() >> level;
                    for _ in 0..200 {
                        let sq = Square {
                            x: rng.random_range(0..side) << level,
                            y: rng.random_range(0..side) << level,
                            level,
                        };
                        assert_eq!(
                            tree.descend_via(Some(&dir), sq),
                            tree.descend_to(sq),
                            "case {case}, {sq:?}"
                        );
                    }
                }
            }
        }
    }
}
