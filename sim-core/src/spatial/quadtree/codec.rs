//! The tree as a bit string: preorder, 2 bits a node (0 empty, 1 full, 2 internal; children
//! SW, SE, NW, NE), 4 nodes a byte, low bits first. The map file stores obstacles this way.

use super::{EMPTY, FULL, NodeRef, RegionQuadtree, is_leaf};
use crate::spatial::grid::Grid;

impl RegionQuadtree {
    /// Nodes in the preorder encoding (every internal node and every leaf).
    pub fn encoded_node_count(&self) -> u64 {
        4 * self.internal_nodes() as u64 + 1
    }

    /// Append the preorder encoding (`⌈encoded_node_count / 4⌉` bytes) to `out`.
    pub(crate) fn encode_preorder(&self, out: &mut Vec<u8>) {
        let mut bits = BitWriter { out, acc: 0, n: 0 };
        encode(self, self.root(), &mut bits);
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
            groups: Vec::with_capacity(((nodes - 1) / 4) as usize),
        };
        let root = dec.node(grid.depth()).map_err(|e| (dec.next, e))?;
        if dec.next != nodes {
            return Err((0, format!("tree ends after {} of {nodes} nodes", dec.next)));
        }
        Ok(RegionQuadtree::from_parts(grid, root, dec.groups))
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

fn encode(tree: &RegionQuadtree, n: NodeRef, bits: &mut BitWriter) {
    match n {
        EMPTY => bits.put(0),
        FULL => bits.put(1),
        _ => {
            bits.put(2);
            for &k in tree.children(n) {
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
}

impl Decoder<'_> {
    fn node(&mut self, level: u8) -> Result<NodeRef, String> {
        if self.next >= self.nodes {
            return Err(format!("tree runs past its {} nodes", self.nodes));
        }
        let i = self.next;
        self.next += 1;
        match (self.packed[(i / 4) as usize] >> (2 * (i % 4))) & 3 {
            0 => Ok(EMPTY),
            1 => Ok(FULL),
            2 if level == 0 => Err(format!("node {i} splits a single cell")),
            2 => {
                let mut kids = [EMPTY; 4];
                for k in &mut kids {
                    *k = self.node(level - 1)?;
                }
                if is_leaf(kids[0]) && kids.iter().all(|&k| k == kids[0]) {
                    return Err(format!("node {i} has four equal leaves (not canonical)"));
                }
                if self.groups.len() >= self.groups.capacity() {
                    return Err("more internal nodes than the node count allows".into());
                }
                self.groups.push(kids);
                Ok((self.groups.len() - 1) as NodeRef)
            }
            s => Err(format!("node {i} has invalid code {s}")),
        }
    }
}
