//! The bit-packed bottom of the tree: a mixed square of 8 × 8 cells is one `u64`.
//!
//! Cells are in Z order (Morton order): the index of cell `(x, y)` of the block interleaves
//! their bits, `x0 y0 x1 y1 x2 y2` from the lowest. So the cells of any square of the implicit
//! quadtree below the block are a contiguous run of bits, and child `i` (bit 0 east, bit 1
//! north, as for groups) of a square at level `l` is the `i`-th quarter of its run. Whether
//! a square is a leaf, how many cells it has set, and a union are a mask and a compare.

/// Level of the blocks: 8 × 8 cells.
pub(crate) const BLOCK_LEVEL: u8 = 3;

/// A node as walks see it: a leaf, a group, or a mixed square of a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Node {
    /// A uniform square of this value.
    Leaf(bool),
    /// A group of four children.
    Group(u32),
    /// A mixed square at `level` ≤ [`BLOCK_LEVEL`]: its cells are the low `4^level` bits.
    Bits {
        /// The cells, Z order.
        bits: u64,
        /// Level of the square.
        level: u8,
    },
}

impl Node {
    /// The node for the cells `bits` of a square at `level` ≤ [`BLOCK_LEVEL`].
    #[inline]
    pub(crate) fn from_bits(bits: u64, level: u8) -> Node {
        if bits == 0 {
            Node::Leaf(false)
        } else if bits == low_bits(level) {
            Node::Leaf(true)
        } else {
            Node::Bits { bits, level }
        }
    }
}

/// All cells of a square at `level` ≤ [`BLOCK_LEVEL`] set: the low `4^level` bits.
#[inline]
pub(crate) const fn low_bits(level: u8) -> u64 {
    if level >= BLOCK_LEVEL {
        u64::MAX
    } else {
        (1u64 << (1u32 << (2 * level))) - 1
    }
}

/// Cells in a child of a square at `level` ≥ 1: `4^(level − 1)`, the shift between children.
#[inline]
pub(crate) const fn child_cells(level: u8) -> u32 {
    1 << (2 * (level - 1))
}

/// The cells of child `i` of the square `bits` at `level` ≥ 1.
#[inline]
pub(crate) fn child_bits(bits: u64, level: u8, i: usize) -> u64 {
    (bits >> (i as u32 * child_cells(level))) & low_bits(level - 1)
}

/// The cells of a square at `level` ≥ 1 from its children's: `kid(i)` gives child `i`'s
/// cells (low bits), asked in order 0, 1, 2, 3.
#[inline]
pub(crate) fn join_kids(level: u8, mut kid: impl FnMut(usize) -> u64) -> u64 {
    let shift = child_cells(level);
    (0..4).fold(0, |acc, i| acc | kid(i) << (i as u32 * shift))
}

/// Child `i` of the mixed square `bits` at `level`.
#[inline]
pub(crate) fn kid(bits: u64, level: u8, i: usize) -> Node {
    Node::from_bits(child_bits(bits, level, i), level - 1)
}

/// The four children of the mixed square `bits` at `level`.
#[inline]
pub(crate) fn kids(bits: u64, level: u8) -> [Node; 4] {
    [0, 1, 2, 3].map(|i| kid(bits, level, i))
}

/// The Z-order index of cell `(x, y)` of a block (only the low 3 bits of each are used).
#[inline]
pub(crate) fn cell_index(x: u32, y: u32) -> u32 {
    (x & 1) | (y & 1) << 1 | (x & 2) << 1 | (y & 2) << 2 | (x & 4) << 2 | (y & 4) << 3
}

/// Swap bit `i` of the word with bit `i + delta` wherever `mask` has bit `i`.
#[inline]
const fn delta_swap(w: u64, mask: u64, delta: u32) -> u64 {
    let t = (w ^ (w >> delta)) & mask;
    w ^ t ^ (t << delta)
}

/// The positions whose index has bit `a` set and bit `b` clear: with `delta = 2^b − 2^a`,
/// a delta swap on them exchanges bits `a` and `b` of every position's index.
const fn index_bit_swap_mask(a: u32, b: u32) -> u64 {
    let mut m = 0u64;
    let mut i = 0;
    while i < 64 {
        if (i >> a) & 1 == 1 && (i >> b) & 1 == 0 {
            m |= 1 << i;
        }
        i += 1;
    }
    m
}

/// A row-major 8 × 8 mask (bit `8 y + x`) in Z order (bit [`cell_index`]`(x, y)`).
///
/// A position's index goes from `x0 x1 x2 y0 y1 y2` to `x0 y0 x1 y1 x2 y2` (lowest bit
/// first) by three exchanges of index bits: 1↔3, 2↔3, 3↔4.
#[inline]
pub(crate) const fn z_order(w: u64) -> u64 {
    let w = delta_swap(w, index_bit_swap_mask(1, 3), (1 << 3) - (1 << 1));
    let w = delta_swap(w, index_bit_swap_mask(2, 3), (1 << 3) - (1 << 2));
    delta_swap(w, index_bit_swap_mask(3, 4), (1 << 4) - (1 << 3))
}

/// A block's cells in Z order as a row-major 8 × 8 mask: the inverse of [`z_order`] (each
/// exchange undoes itself, so the three are made in the reverse order).
#[inline]
pub(crate) const fn row_major(z: u64) -> u64 {
    let z = delta_swap(z, index_bit_swap_mask(3, 4), (1 << 4) - (1 << 3));
    let z = delta_swap(z, index_bit_swap_mask(2, 3), (1 << 3) - (1 << 2));
    delta_swap(z, index_bit_swap_mask(1, 3), (1 << 3) - (1 << 1))
}

/// The leaves of a mixed block whose cells are all in `wanted` and that share a cell with
/// `hits`, as the Z index of their first cell: `(every such leaf, those that are 4 × 4
/// quarters, those that are 2 × 2 squares)`; the rest are single cells. Word operations
/// only, so a query pays per leaf it reports, not per node of the block.
#[inline]
pub(crate) fn leaves_hit(wanted: u64, hits: u64) -> (u64, u64, u64) {
    const NIBBLES: u64 = 0x1111_1111_1111_1111;
    const QUARTERS: u64 = 0x0001_0001_0001_0001;
    let w = wanted;
    let z = !wanted;
    let full_2x2 = w & (w >> 1) & (w >> 2) & (w >> 3) & NIBBLES;
    let empty_2x2 = z & (z >> 1) & (z >> 2) & (z >> 3) & NIBBLES;
    let hit_2x2 = (hits | hits >> 1 | hits >> 2 | hits >> 3) & NIBBLES;
    let full_4x4 = full_2x2 & (full_2x2 >> 4) & (full_2x2 >> 8) & (full_2x2 >> 12) & QUARTERS;
    let hit_4x4 = (hit_2x2 | hit_2x2 >> 4 | hit_2x2 >> 8 | hit_2x2 >> 12) & QUARTERS;
    // A run of equal bits is a leaf only if its parent's run is not also uniform (a
    // uniform 2 × 2 inside a uniform 4 × 4 is part of that leaf).
    let quarters = full_4x4 & hit_4x4;
    let squares = full_2x2 & !(full_4x4 * 0xFFFF) & hit_2x2;
    let cells = w & !((full_2x2 | empty_2x2) * 0xF) & hits;
    (quarters | squares | cells, quarters, squares)
}

/// The cell `(x, y)` of a block (each in `0..8`) at Z index `i`.
#[inline]
pub(crate) fn cell_at(i: u32) -> (u32, u32) {
    (
        (i & 1) | (i >> 1 & 2) | (i >> 2 & 4),
        (i >> 1 & 1) | (i >> 2 & 2) | (i >> 3 & 4),
    )
}

/// Internal nodes of the implicit quadtree of a mixed block: the block itself, its mixed
/// 4 × 4 quarters and its mixed 2 × 2 squares.
#[inline]
pub(crate) fn internal_nodes_in(bits: u64) -> usize {
    const NIBBLES: u64 = 0x1111_1111_1111_1111;
    let ones = bits & (bits >> 1) & (bits >> 2) & (bits >> 3) & NIBBLES;
    let z = !bits;
    let zeros = z & (z >> 1) & (z >> 2) & (z >> 3) & NIBBLES;
    let mixed_2x2 = 16 - (ones.count_ones() + zeros.count_ones()) as usize;
    let mixed_4x4 = (0..4)
        .filter(|i| {
            let q = (bits >> (16 * i)) & 0xFFFF;
            q != 0 && q != 0xFFFF
        })
        .count();
    1 + mixed_4x4 + mixed_2x2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Internal nodes counted by walking the implicit tree.
    fn walk_internal(bits: u64, level: u8) -> usize {
        match Node::from_bits(bits, level) {
            Node::Leaf(_) => 0,
            _ => {
                1 + (0..4)
                    .map(|i| walk_internal(child_bits(bits, level, i), level - 1))
                    .sum::<usize>()
            }
        }
    }

    #[test]
    fn internal_node_count_matches_a_walk_of_the_implicit_tree() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for k in 0..5000 {
            // Random words, and words with uniform quarters and 2 × 2 squares.
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let bits = match k % 3 {
                0 => x,
                1 => x & 0xFFFF_0000_F0F0_FFFF,
                _ => (x & 0x1111_1111_1111_1111) * 0xF,
            };
            if bits != 0 && bits != u64::MAX {
                assert_eq!(internal_nodes_in(bits), walk_internal(bits, BLOCK_LEVEL), "{bits:#x}");
            }
        }
    }

    /// Leaves of the implicit tree with their first cell's index and level.
    fn walk_leaves(bits: u64, level: u8, first: u32, out: &mut Vec<(u32, u8, bool)>) {
        match Node::from_bits(bits, level) {
            Node::Leaf(v) => out.push((first, level, v)),
            _ => {
                for i in 0..4 {
                    let kid = child_bits(bits, level, i);
                    walk_leaves(kid, level - 1, first + i as u32 * child_cells(level), out);
                }
            }
        }
    }

    #[test]
    fn leaves_hit_matches_a_walk_of_the_implicit_tree() {
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for k in 0..5000 {
            let (a, b) = (next(), next());
            let bits = match k % 3 {
                0 => a,
                1 => a & 0xFFFF_0000_F0F0_FFFF | 0x0000_0000_0F00_0000,
                _ => (a & 0x1111_1111_1111_1111) * 0xF,
            };
            if bits == 0 || bits == u64::MAX {
                continue;
            }
            let hits = if k % 2 == 0 { b } else { b & next() & next() };
            for value in [true, false] {
                let mut leaves = Vec::new();
                walk_leaves(bits, BLOCK_LEVEL, 0, &mut leaves);
                let mut want = (0, 0, 0);
                for (first, level, v) in leaves {
                    let cells = low_bits(level) << first;
                    if v == value && cells & hits != 0 {
                        want.0 |= 1 << first;
                        want.1 |= u64::from(level == 2) << first;
                        want.2 |= u64::from(level == 1) << first;
                    }
                }
                let wanted = if value { bits } else { !bits };
                assert_eq!(leaves_hit(wanted, hits), want, "{bits:#x} {hits:#x} {value}");
            }
        }
        for i in 0..64 {
            let (x, y) = cell_at(i);
            assert_eq!(cell_index(x, y), i);
        }
    }

    #[test]
    fn row_major_undoes_z_order() {
        for y in 0..8 {
            for x in 0..8 {
                assert_eq!(row_major(1 << cell_index(x, y)), 1 << (8 * y + x), "cell ({x}, {y})");
            }
        }
        let mut w = 0x0123_4567_89AB_CDEFu64;
        for _ in 0..100 {
            assert_eq!(row_major(z_order(w)), w);
            w = w.rotate_left(7).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5555;
        }
    }

    #[test]
    fn z_order_moves_each_cell_to_its_cell_index() {
        for y in 0..8 {
            for x in 0..8 {
                assert_eq!(z_order(1 << (8 * y + x)), 1 << cell_index(x, y), "cell ({x}, {y})");
            }
        }
        assert_eq!(z_order(u64::MAX), u64::MAX);
    }

    #[test]
    fn cell_index_is_z_order_and_children_are_quarters() {
        // Cell (x, y) lies in child (x ≥ 4) | (y ≥ 4) << 1 of the block, then in the child
        // of that quarter given by the next bit, and so on: the same descent as groups.
        for y in 0..8 {
            for x in 0..8 {
                let bits = 1u64 << cell_index(x, y);
                let mut node = Node::from_bits(bits, BLOCK_LEVEL);
                let mut level = BLOCK_LEVEL;
                while let Node::Bits { bits, level: l } = node {
                    level -= 1;
                    let i = ((x >> level) & 1 | ((y >> level) & 1) << 1) as usize;
                    for j in 0..4 {
                        assert_eq!(child_bits(bits, l, j) != 0, i == j, "cell ({x}, {y}) level {l}");
                    }
                    node = kid(bits, l, i);
                }
                assert_eq!(node, Node::Leaf(true));
                assert_eq!(level, 0);
            }
        }
    }
}
