//! Content hashes of subtrees, so that a union skips what both trees hold alike.
//!
//! Robots in a crowd merge each other's known maps, and by the time a map arrives its
//! receiver holds most of it already. A tree that keeps hashes stores one per group,
//! worked out from its children's when asked and forgotten (set to [`NO_HASH`]) whenever
//! anything below the group changes; a union then returns at once at a group whose hash
//! equals the other tree's group there. Invariant: a kept hash is the hash of its group's
//! contents now; checked by [`RegionQuadtree::validate`], `packed_trees_are_the_unpacked_tree`
//! and `rows_filled_block_by_block_match_a_grid`.
//!
//! Hashes are 64 bits ([`foldhash`]'s quality hasher with a fixed seed), so two different
//! subtrees compared at the same square share a hash with probability about 2⁻⁶⁴: a
//! union of a few hundred million comparisons a run misses cells it should add with
//! probability under 10⁻¹⁰. Runs stay deterministic either way (the hashes depend only on
//! the contents), and a union that skips gives the tree it would have walked to: an equal
//! subtree adds nothing, so the walk would have written nothing.
//!
//! A tree keeps hashes only once someone asks for one ([`RegionQuadtree::complete_hashes`],
//! or a union with a tree that has them): `hashes` is empty before, and as long as
//! `groups` afterwards. Obstacle maps never pay for them.

use std::hash::BuildHasher;

use super::{EMPTY, FULL, NodeRef, RegionQuadtree, is_block};

/// Unions compare hashes at squares up to this level (256 cells a side); see
/// `union_node`.
pub(super) const HASHED_LEVELS: u8 = 8;

/// A group whose hash is not worked out (no content hashes to it: see [`group_hash`]).
pub(super) const NO_HASH: u64 = 0;

/// The hasher: fixed, so that hashes (and so which merges skip) are the same on every run.
const STATE: foldhash::quality::FixedState = foldhash::quality::FixedState::with_seed(0x5EED_C0DE_F00D_7EE5);

/// Hash of a node whose children's hashes are `kids` (never [`NO_HASH`]).
#[inline]
fn group_hash(kids: [u64; 4]) -> u64 {
    STATE.hash_one((kids[0], kids[1], kids[2], kids[3])).max(1)
}

/// Hash of a leaf or a block (groups aside): their contents, told apart from groups' by
/// the level they sit at (a union only compares nodes of the same square).
#[inline]
fn bits_hash(tree: &RegionQuadtree, n: NodeRef) -> u64 {
    match n {
        EMPTY => 1,
        FULL => 2,
        b => STATE.hash_one(tree.block_bits(b)).max(3),
    }
}

impl RegionQuadtree {
    /// Work out every group's content hash (those not known yet), and keep them up to date
    /// from now on: a tree shared for merging should have them, so that the trees that take
    /// it in skip what they hold alike. Cheap when only a few groups changed since.
    pub fn complete_hashes(&mut self) {
        self.hash_of(self.root);
    }

    /// Whether the tree keeps content hashes (see the module docs).
    pub fn keeps_hashes(&self) -> bool {
        !self.hashes.is_empty()
    }

    /// Node `n`'s content hash, worked out (and kept) where it is not known; starts keeping
    /// hashes if the tree did not.
    pub(super) fn hash_of(&mut self, n: NodeRef) -> u64 {
        if self.hashes.len() != self.groups.len() {
            // Not kept before (or no group existed then): none is known.
            self.hashes.clear();
            self.hashes.resize(self.groups.len(), NO_HASH);
        }
        self.hash_kept(n)
    }

    fn hash_kept(&mut self, n: NodeRef) -> u64 {
        if super::is_leaf(n) || is_block(n) {
            return bits_hash(self, n);
        }
        let known = self.hashes[n as usize];
        if known != NO_HASH {
            return known;
        }
        let kids = self.groups[n as usize].map(|k| self.hash_kept(k));
        let h = group_hash(kids);
        self.hashes[n as usize] = h;
        h
    }

    /// Node `n`'s content hash if it is known (always for leaves and blocks).
    #[inline]
    pub(super) fn known_hash(&self, n: NodeRef) -> Option<u64> {
        if super::is_leaf(n) || is_block(n) {
            return Some(bits_hash(self, n));
        }
        self.hashes.get(n as usize).copied().filter(|&h| h != NO_HASH)
    }

    /// Forget group `g`'s hash (something below it changed, or it is new).
    #[inline]
    pub(super) fn forget_hash(&mut self, g: NodeRef) {
        if let Some(h) = self.hashes.get_mut(g as usize) {
            *h = NO_HASH;
        }
    }

    /// Every kept hash is the hash of its group's contents now (for
    /// [`validate`](Self::validate)); returns the subtree's hash.
    pub(super) fn hash_problems(&self, n: NodeRef) -> Result<u64, String> {
        if super::is_leaf(n) || is_block(n) {
            return Ok(bits_hash(self, n));
        }
        let kids = self.groups[n as usize];
        let mut hashes = [0; 4];
        for (h, &k) in hashes.iter_mut().zip(&kids) {
            *h = self.hash_problems(k)?;
        }
        let h = group_hash(hashes);
        match self.hashes.get(n as usize).copied() {
            Some(kept) if kept != NO_HASH && kept != h => {
                Err(format!("group {n} keeps a content hash its contents no longer have"))
            }
            _ => Ok(h),
        }
    }
}
