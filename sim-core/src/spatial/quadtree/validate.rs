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

    /// The first broken invariant (see [`validate`](Self::validate)), if any.
    pub(crate) fn problems(&self) -> Result<(), String> {
        let mut census = self.free_list_census()?;
        self.mark_reached(&mut census)?;
        self.count_problems(&census)?;
        let n = self.groups.len();
        if self.keeps_hashes() {
            if self.hashes.len() != n {
                return Err(format!("{} content hashes kept for {n} groups", self.hashes.len()));
            }
            self.hash_problems(self.root)?;
        }
        let block_internal = census.block_internal;
        if block_internal != self.block_internal {
            return Err(format!(
                "blocks hold {block_internal} internal nodes but the tree counts {}",
                self.block_internal
            ));
        }
        Ok(())
    }

    /// A census with the groups and blocks on the free lists marked, refusing an entry out
    /// of range or listed twice.
    fn free_list_census(&self) -> Result<Census, String> {
        let mut census = Census {
            seen: vec![false; self.groups.len()],
            seen_block: vec![false; self.blocks.len()],
            reached: 0,
            reached_blocks: 0,
            block_internal: 0,
        };
        for (list, seen, what) in [
            (&self.free_groups, &mut census.seen, "group"),
            (&self.free_blocks, &mut census.seen_block, "block"),
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
        Ok(census)
    }

    /// Walk the tree from the root, marking in `census` every group and block reached.
    fn mark_reached(&self, census: &mut Census) -> Result<(), String> {
        let mut stack: Vec<(NodeRef, u8)> = vec![(self.root, self.grid.depth())];
        while let Some((node, level)) = stack.pop() {
            if is_leaf(node) {
                continue;
            }
            if is_block(node) {
                self.reach_block(node, level, census)?;
                continue;
            }
            let kids = self.reach_group(node, level, census)?;
            stack.extend(kids.iter().map(|&k| (k, level - 1)));
        }
        Ok(())
    }

    /// Mark the block that `node` refers to as reached at `level`, checking that it sits at
    /// the packed level, is reached once and holds mixed bits.
    fn reach_block(&self, node: NodeRef, level: u8, census: &mut Census) -> Result<(), String> {
        let nb = self.blocks.len();
        let b = (node - BLOCK_TAG) as usize;
        if b >= nb {
            return Err(format!("node refers to block {b}, but there are {nb}"));
        }
        if !self.packs(level) {
            return Err(format!(
                "block {b} sits at level {level}, not at the packed level {BLOCK_LEVEL}"
            ));
        }
        if census.seen_block[b] {
            return Err(format!("block {b} is reached twice or is also on the free list"));
        }
        census.seen_block[b] = true;
        census.reached_blocks += 1;
        let bits = self.blocks[b];
        if bits == 0 || bits == u64::MAX {
            return Err(format!("block {b} is uniform and should have been a leaf"));
        }
        census.block_internal += internal_nodes_in(bits);
        Ok(())
    }

    /// Mark the group that `node` refers to as reached at `level`, checking where it sits,
    /// that it is reached once and is not four equal leaves; returns its children.
    fn reach_group(&self, node: NodeRef, level: u8, census: &mut Census) -> Result<[NodeRef; 4], String> {
        let n = self.groups.len();
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
        if census.seen[i] {
            return Err(format!("group {i} is reached twice or is also on the free list"));
        }
        census.seen[i] = true;
        census.reached += 1;
        let kids = self.groups[i];
        if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
            return Err(format!("group {i} has four equal leaves and should have been merged"));
        }
        Ok(kids)
    }

    /// Check that every group and every block is either reached or free.
    fn count_problems(&self, census: &Census) -> Result<(), String> {
        let (n, nb) = (self.groups.len(), self.blocks.len());
        let (reached, reached_blocks) = (census.reached, census.reached_blocks);
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

/// What validation has met so far: the groups and blocks on a free list or reached from the
/// root, how many of each were reached, and the internal nodes the reached blocks hold.
struct Census {
    seen: Vec<bool>,
    seen_block: Vec<bool>,
    reached: usize,
    reached_blocks: usize,
    block_internal: usize,
}
