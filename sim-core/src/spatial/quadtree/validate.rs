//! Structural invariants, checked by tests after every mutation and by the map loader.

use super::{NodeRef, RegionQuadtree, is_leaf};

impl RegionQuadtree {
    /// Check the invariants: every group is reachable exactly once or on the free list (never
    /// both), no internal node sits below the finest level, and no internal node has four
    /// equal leaves as children (uniform siblings are merged, so the tree is canonical: one
    /// region, one tree).
    pub fn validate(&self) -> crate::Result<()> {
        self.problems().map_err(crate::Error::Malformed)
    }

    pub(crate) fn problems(&self) -> Result<(), String> {
        let n = self.groups.len();
        let mut seen = vec![false; n];
        for &f in &self.free_groups {
            let f = f as usize;
            if f >= n {
                return Err(format!("free group {f} out of range ({n} groups)"));
            }
            if seen[f] {
                return Err(format!("group {f} is on the free list twice"));
            }
            seen[f] = true;
        }
        let mut stack: Vec<(NodeRef, u8)> = vec![(self.root, self.grid.depth())];
        let mut reached = 0usize;
        while let Some((node, level)) = stack.pop() {
            if is_leaf(node) {
                continue;
            }
            let i = node as usize;
            if i >= n {
                return Err(format!("node refers to group {i}, but there are {n}"));
            }
            if level == 0 {
                return Err(format!("group {i} is an internal node below the finest level"));
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
