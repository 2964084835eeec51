//! A [`RegionQuadtree`] as checkpoints store it: its vectors with their capacities, so
//! that a restored tree costs what the saved one did (its memory is a metric) and grows as
//! it would have; a resumed run must be the same, byte for byte. The vectors are written as
//! little-endian byte strings, one CBOR item each, not item by item, which would be slow.
//! Written from borrowed vectors (a checkpoint never copies a tree); whoever reads a tree
//! back checks it with `validate`.

use serde::{Deserialize, Serialize, Serializer};
use serde_bytes::ByteBuf;

use super::{Grid, NodeRef, RegionQuadtree};

/// Words as one little-endian byte string.
struct Words<'a, T>(&'a [T]);

/// A word that can be written little-endian.
trait LeWord: Copy {
    fn put(self, out: &mut Vec<u8>);
}

impl LeWord for u32 {
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl LeWord for u64 {
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl<T: LeWord> Serialize for Words<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut bytes = Vec::with_capacity(std::mem::size_of_val(self.0));
        for &w in self.0 {
            w.put(&mut bytes);
        }
        s.serialize_bytes(&bytes)
    }
}

/// Little-endian words back from a byte string; `None` if it does not split into them.
fn words<const N: usize, T>(bytes: &[u8], from_le: fn([u8; N]) -> T) -> Option<Vec<T>> {
    let chunks = bytes.chunks_exact(N);
    chunks.remainder().is_empty().then(|| {
        chunks
            .map(|c| from_le(c.try_into().expect("chunks_exact gives N bytes")))
            .collect()
    })
}

#[derive(Serialize)]
struct TreeStateRef<'a> {
    grid: Grid,
    root: NodeRef,
    /// Groups flattened (four references each), and the vectors' capacities.
    groups: Words<'a, u32>,
    free_groups: Words<'a, u32>,
    blocks: Words<'a, u64>,
    free_blocks: Words<'a, u32>,
    capacities: [usize; 4],
    block_internal: usize,
    packed: bool,
    /// Content hashes kept (see `hash`; empty if none) and their vector's capacity: a
    /// restored tree skips the same subtrees in unions and reports the same memory.
    hashes: Words<'a, u64>,
    hashes_capacity: usize,
}

/// [`TreeStateRef`] read back.
#[derive(Deserialize)]
pub(super) struct TreeState {
    grid: Grid,
    root: NodeRef,
    groups: ByteBuf,
    free_groups: ByteBuf,
    blocks: ByteBuf,
    free_blocks: ByteBuf,
    capacities: [usize; 4],
    block_internal: usize,
    packed: bool,
    /// Optional when read: a checkpoint without them keeps no hashes.
    #[serde(default)]
    hashes: ByteBuf,
    #[serde(default)]
    hashes_capacity: usize,
}

impl Serialize for RegionQuadtree {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        TreeStateRef {
            grid: self.grid,
            root: self.root,
            groups: Words(self.groups.as_flattened()),
            free_groups: Words(&self.free_groups),
            blocks: Words(&self.blocks),
            free_blocks: Words(&self.free_blocks),
            capacities: [
                self.groups.capacity(),
                self.free_groups.capacity(),
                self.blocks.capacity(),
                self.free_blocks.capacity(),
            ],
            block_internal: self.block_internal,
            packed: self.packed,
            hashes: Words(&self.hashes),
            hashes_capacity: self.hashes.capacity(),
        }
        .serialize(s)
    }
}

/// The vector, grown to the capacity it had. Vectors grow by doubling, so a capacity far
/// beyond `bound` (the length of the vector it belongs to) comes from a corrupt file, and
/// is refused rather than allocated.
fn restored<T>(mut v: Vec<T>, capacity: usize, bound: usize, what: &str) -> Result<Vec<T>, String> {
    if capacity > 4 * bound + 1024 {
        return Err(format!(
            "a quadtree's {what} claim a capacity of {capacity} for {} entries",
            v.len()
        ));
    }
    v.reserve_exact(capacity.saturating_sub(v.len()));
    Ok(v)
}

impl TryFrom<TreeState> for RegionQuadtree {
    type Error = String;

    fn try_from(s: TreeState) -> Result<Self, String> {
        let ragged = |what: &str| format!("a quadtree's {what} are not whole words");
        let refs = words(&s.groups, u32::from_le_bytes)
            .filter(|w| w.len() % 4 == 0)
            .ok_or_else(|| ragged("groups"))?;
        let groups: Vec<[NodeRef; 4]> = refs.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
        let free_groups = words(&s.free_groups, u32::from_le_bytes).ok_or_else(|| ragged("free groups"))?;
        let blocks = words(&s.blocks, u64::from_le_bytes).ok_or_else(|| ragged("blocks"))?;
        let free_blocks = words(&s.free_blocks, u32::from_le_bytes).ok_or_else(|| ragged("free blocks"))?;
        let hashes = words(&s.hashes, u64::from_le_bytes).ok_or_else(|| ragged("content hashes"))?;
        let (n_groups, n_blocks) = (groups.len(), blocks.len());
        let [c_groups, c_free_groups, c_blocks, c_free_blocks] = s.capacities;
        Ok(Self {
            grid: s.grid,
            root: s.root,
            groups: restored(groups, c_groups, n_groups, "groups")?,
            free_groups: restored(free_groups, c_free_groups, n_groups, "free groups")?,
            blocks: restored(blocks, c_blocks, n_blocks, "blocks")?,
            free_blocks: restored(free_blocks, c_free_blocks, n_blocks, "free blocks")?,
            block_internal: s.block_internal,
            packed: s.packed,
            hashes: restored(hashes, s.hashes_capacity, n_groups, "content hashes")?,
        })
    }
}
