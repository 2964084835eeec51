//! Structural invariants, checked by tests after every mutation and by the map loader.

use super::block::{BLOCK_LEVEL, internal_nodes_in};
use super::{BLOCK_TAG, NodeRef, RegionQuadtree, is_block, is_leaf};

impl RegionQuadtree {
    /// Check the invariants: every group and block is reachable exactly once or on its free
    /// list (never both), no internal node sits below the finest level, no group has four
    /// equal leaves as children (uniform siblings are merged, so the tree is canonical: one
    /// region, one tree), and in a packed tree every mixed 8 × 8 square is a block of mixed
    /// bits, with no group at or below that level; and every content hash kept is that of
    /// its group's contents.
    pub fn validate(&self) -> crate::Result<()> {
        self.problems().map_err(crate::Error::Malformed)
    }

    pub(crate) fn problems(&self) -> Result<(), String> {
        let n = self.groups.len();
        let nb = self.blocks.len();
        let mut seen = vec![false; n];
        let mut seen_block = vec![false; nb];
        for (list, seen, what) in [
            (&self.free_groups, &mut seen, "group"),
            (&self.free_blocks, &mut seen_block, "block"),
        ] {
            for &f in list {
                let f = f as usize;
                if f >= seen.len() {
                    return Err(format!("free {what} {f} out of range ({} {what}s)", seen.len()));
                }
                if seen[f] {
                    return Err(format!("{what} {f} is on the free list twice"));
                }
                seen[f] = true;
            }
        }
        let mut stack: Vec<(NodeRef, u8)> = vec![(self.root, self.grid.depth())];
        let (mut reached, mut reached_blocks, mut block_internal) = (0usize, 0usize, 0usize);
        while let Some((node, level)) = stack.pop() {
            if is_leaf(node) {
                continue;
            }
            if is_block(node) {
                let b = (node - BLOCK_TAG) as usize;
                if b >= nb {
                    return Err(format!("node refers to block {b}, but there are {nb}"));
                }
                if !self.packs(level) {
                    return Err(format!(
                        "block {b} sits at level {level}, not at the packed level {BLOCK_LEVEL}"
                    ));
                }
                if seen_block[b] {
                    return Err(format!("block {b} is reached twice or is also on the free list"));
                }
                seen_block[b] = true;
                reached_blocks += 1;
                let bits = self.blocks[b];
                if bits == 0 || bits == u64::MAX {
                    return Err(format!("block {b} is uniform and should have been a leaf"));
                }
                block_internal += internal_nodes_in(bits);
                continue;
            }
            let i = node as usize;
            if i >= n {
                return Err(format!("node refers to group {i}, but there are {n}"));
            }
            if level == 0 {
                return Err(format!("group {i} is an internal node below the finest level"));
            }
            if self.packed && level <= BLOCK_LEVEL {
                return Err(format!("group {i} at level {level} should be packed in a block"));
            }
            if seen[i] {
                return Err(format!("group {i} is reached twice or is also on the free list"));
            }
            seen[i] = true;
            reached += 1;
            let kids = self.groups[i];
            if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
                return Err(format!("group {i} has four equal leaves and should have been merged"));
            }
            stack.extend(kids.iter().map(|&k| (k, level - 1)));
        }
        if reached + self.free_groups.len() != n {
            return Err(format!(
                "{} groups are neither reachable nor free ({reached} reachable, {} free, {n} in all)",
                n - reached - self.free_groups.len(),
                self.free_groups.len()
            ));
        }
        if reached_blocks + self.free_blocks.len() != nb {
            return Err(format!(
                "{} blocks are neither reachable nor free ({reached_blocks} reachable, {} free, {nb} in all)",
                nb - reached_blocks - self.free_blocks.len(),
                self.free_blocks.len()
            ));
        }
        if self.keeps_hashes() {
            if self.hashes.len() != n {
                return Err(format!("{} content hashes kept for {n} groups", self.hashes.len()));
            }
            self.hash_problems(self.root)?;
        }
        if block_internal != self.block_internal {
            return Err(format!(
                "blocks hold {block_internal} internal nodes but the tree counts {}",
                self.block_internal
            ));
        }
        Ok(())
    }

    /// Panic with the broken invariant, for tests.
    #[track_caller]
    pub fn assert_well_formed(&self) {
        if let Err(e) = self.validate() {
            panic!("malformed region quadtree: {e}");
        }
    }
}
