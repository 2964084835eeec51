//! The tree as a bit string: preorder, 2 bits a node (0 empty, 1 full, 2 internal; children
//! SW, SE, NW, NE), 4 nodes a byte, low bits first. The map file stores obstacles this way.

use super::block::{self, BLOCK_LEVEL, Node};
use super::{EMPTY, FULL, NodeRef, RegionQuadtree, leaf};
use crate::spatial::grid::Grid;

impl RegionQuadtree {
    /// Nodes in the preorder encoding (every internal node and every leaf).
    pub fn encoded_node_count(&self) -> u64 {
        4 * self.internal_nodes() as u64 + 1
    }

    /// Append the preorder encoding (`⌈encoded_node_count / 4⌉` bytes) to `out`.
    pub(crate) fn encode_preorder(&self, out: &mut Vec<u8>) {
        let mut bits = BitWriter { out, acc: 0, n: 0 };
        encode(self, self.node(self.root()), &mut bits);
        bits.flush();
    }

    /// Decode `nodes` nodes from `packed` (which holds at least `⌈nodes / 4⌉` bytes) into a
    /// tree over `grid`. Never trusts the input: a wrong count, a split single cell or a
    /// non-canonical group is an error `(node index, problem)`.
    pub(crate) fn decode_preorder(grid: Grid, packed: &[u8], nodes: u64) -> Result<Self, (u64, String)> {
        if nodes == 0 || !(nodes - 1).is_multiple_of(4) || (packed.len() as u64) < nodes.div_ceil(4) {
            return Err((
                0,
                format!("node count {nodes} does not fit {} bytes as 4k+1 nodes", packed.len()),
            ));
        }
        let mut dec = Decoder {
            packed,
            next: 0,
            nodes,
            groups: Vec::new(),
            blocks: Vec::new(),
            pack: RegionQuadtree::uniform(grid, false).packs(BLOCK_LEVEL),
        };
        let root = dec.node(grid.depth()).map_err(|e| (dec.next, e))?;
        if dec.next != nodes {
            return Err((0, format!("tree ends after {} of {nodes} nodes", dec.next)));
        }
        dec.groups.shrink_to_fit();
        dec.blocks.shrink_to_fit();
        Ok(RegionQuadtree::from_parts(grid, root, dec.groups, dec.blocks))
    }
}

struct BitWriter<'a> {
    out: &'a mut Vec<u8>,
    acc: u8,
    n: u8,
}

impl BitWriter<'_> {
    fn put(&mut self, sym: u8) {
        self.acc |= sym << (2 * self.n);
        self.n += 1;
        if self.n == 4 {
            self.flush();
        }
    }
    fn flush(&mut self) {
        if self.n > 0 {
            self.out.push(self.acc);
            self.acc = 0;
            self.n = 0;
        }
    }
}

fn encode(tree: &RegionQuadtree, n: Node, bits: &mut BitWriter) {
    match n {
        Node::Leaf(false) => bits.put(0),
        Node::Leaf(true) => bits.put(1),
        _ => {
            bits.put(2);
            for k in tree.kids(n) {
                encode(tree, k, bits);
            }
        }
    }
}

struct Decoder<'a> {
    packed: &'a [u8],
    next: u64,
    nodes: u64,
    groups: Vec<[NodeRef; 4]>,
    blocks: Vec<u64>,
    /// Whether mixed squares at [`BLOCK_LEVEL`] become blocks.
    pack: bool,
}

impl Decoder<'_> {
    /// The next node's code, its index in preorder.
    fn code(&mut self) -> Result<(u8, u64), String> {
        if self.next >= self.nodes {
            return Err(format!("tree runs past its {} nodes", self.nodes));
        }
        let i = self.next;
        self.next += 1;
        match (self.packed[(i / 4) as usize] >> (2 * (i % 4))) & 3 {
            3 => Err(format!("node {i} has invalid code 3")),
            c => Ok((c, i)),
        }
    }

    fn node(&mut self, level: u8) -> Result<NodeRef, String> {
        if self.pack && level == BLOCK_LEVEL {
            let bits = self.bits(level)?;
            if let Node::Leaf(v) = Node::from_bits(bits, level) {
                return Ok(leaf(v));
            }
            self.blocks.push(bits);
            return Ok(super::BLOCK_TAG + (self.blocks.len() - 1) as NodeRef);
        }
        match self.code()? {
            (0, _) => Ok(EMPTY),
            (1, _) => Ok(FULL),
            (_, i) if level == 0 => Err(format!("node {i} splits a single cell")),
            (_, i) => {
                let mut kids = [EMPTY; 4];
                for k in &mut kids {
                    *k = self.node(level - 1)?;
                }
                if super::is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
                    return Err(format!("node {i} has four equal leaves (not canonical)"));
                }
                self.groups.push(kids);
                Ok((self.groups.len() - 1) as NodeRef)
            }
        }
    }

    /// The cells of the next subtree, a square at `level` ≤ [`BLOCK_LEVEL`], as bits.
    fn bits(&mut self, level: u8) -> Result<u64, String> {
        match self.code()? {
            (0, _) => Ok(0),
            (1, _) => Ok(block::low_bits(level)),
            (_, i) if level == 0 => Err(format!("node {i} splits a single cell")),
            (_, i) => {
                let shift = block::child_cells(level);
                let mut bits = 0;
                let mut leaves = [None; 4];
                for (k, leaf) in leaves.iter_mut().enumerate() {
                    let kid = self.bits(level - 1)?;
                    if let Node::Leaf(v) = Node::from_bits(kid, level - 1) {
                        *leaf = Some(v);
                    }
                    bits |= kid << (k as u32 * shift);
                }
                // Four equal leaves are one leaf; four equal mixed children are fine.
                if leaves[0].is_some() && leaves.iter().all(|&l| l == leaves[0]) {
                    return Err(format!("node {i} has four equal leaves (not canonical)"));
                }
                Ok(bits)
            }
        }
    }
}
