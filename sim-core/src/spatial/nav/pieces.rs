//! Free space in convex pieces: the obstacle quadtree's free leaves, merged into
//! rectangles. Leaves of one size that sit side by side in a row become a run; runs of the
//! same leaves stacked one on the next become a rectangle. A quadtree splits free space
//! wherever the square grid does (a corridor one leaf wide is a chain of leaves); merged,
//! it splits where obstacles do, and searches settle that many fewer nodes.

use crate::spatial::quadtree::Square;

/// A free rectangle of whole cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    /// Lower-left cell column.
    pub x: u32,
    /// Lower-left cell row.
    pub y: u32,
    /// Width in cells.
    pub w: u32,
    /// Height in cells.
    pub h: u32,
}

impl Piece {
    /// Whether cell `(x, y)` is one of the piece's.
    #[inline]
    pub fn holds(&self, (x, y): (u32, u32)) -> bool {
        x >= self.x && y >= self.y && x - self.x < self.w && y - self.y < self.h
    }

    /// Lower-left cell.
    pub fn lo(&self) -> (u32, u32) {
        (self.x, self.y)
    }

    /// Upper-right cell.
    pub fn hi(&self) -> (u32, u32) {
        (self.x + self.w - 1, self.y + self.h - 1)
    }
}

/// The most leaves a piece spans along either side. Searches cost a piece by the walk
/// between points of its portals; a cap keeps that estimate local on long open stretches.
pub(super) const MAX_SPAN_LEAVES: u32 = 16;

/// A run's sort key for stacking: (leaf level, first column, leaves, row).
type RunKey = (u8, u32, u32, u32);

/// Merge disjoint free `leaves` into pieces, sorting on `workers`. Returns the pieces and
/// each leaf's piece (the same whoever sorts).
pub(super) fn merge(leaves: &[Square], workers: super::Workers) -> (Vec<Piece>, Vec<u32>) {
    let leaf = |i: u32| leaves[i as usize];
    // Sorted with their keys beside them (no key is read through an index); keys are
    // distinct (leaves are disjoint), so the order is the keys' alone.
    let mut keyed: Vec<(u8, u32, u32, u32)> = (0..u32::try_from(leaves.len()).expect("leaves fit u32"))
        .map(|i| {
            let s = leaf(i);
            (s.level, s.y, s.x, i)
        })
        .collect();
    workers.sort(&mut keyed);
    let order: Vec<u32> = keyed.into_iter().map(|k| k.3).collect();
    // Runs: where they start in `order`, and how many leaves they hold.
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        let s = leaf(i);
        if let Some(run) = runs.last_mut() {
            let first = leaf(order[run.0 as usize]);
            if first.level == s.level
                && first.y == s.y
                && run.1 < MAX_SPAN_LEAVES
                && first.x + run.1 * s.side_cells() == s.x
            {
                run.1 += 1;
                continue;
            }
        }
        runs.push((u32::try_from(k).expect("leaves fit u32"), 1));
    }
    // Stack runs of the same leaves and columns, bottom to top.
    let key = |r: (u32, u32)| {
        let first = leaf(order[r.0 as usize]);
        (first.level, first.x, r.1, first.y)
    };
    // Distinct keys again (two runs of one level cannot start at one cell).
    let mut keyed: Vec<(RunKey, (u32, u32))> = runs.into_iter().map(|r| (key(r), r)).collect();
    workers.sort(&mut keyed);
    let stacked = keyed.into_iter().map(|k| k.1);
    let mut pieces: Vec<Piece> = Vec::new();
    let mut piece_of = vec![0u32; leaves.len()];
    let mut below: Option<(RunKey, u32)> = None;
    for r in stacked {
        let (level, x, len, y) = key(r);
        let side = 1u32 << level;
        match below {
            Some(((l, bx, blen, by), rows))
                if l == level && bx == x && blen == len && by + side == y && rows < MAX_SPAN_LEAVES =>
            {
                pieces.last_mut().expect("a run below").h += side;
                below = Some(((level, x, len, y), rows + 1));
            }
            _ => {
                pieces.push(Piece {
                    x,
                    y,
                    w: len * side,
                    h: side,
                });
                below = Some(((level, x, len, y), 1));
            }
        }
        let id = u32::try_from(pieces.len() - 1).expect("pieces fit u32");
        for &i in &order[r.0 as usize..(r.0 + r.1) as usize] {
            piece_of[i as usize] = id;
        }
    }
    (pieces, piece_of)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sq(x: u32, y: u32, level: u8) -> Square {
        Square { x, y, level }
    }

    #[test]
    fn rows_and_stacks_of_equal_leaves_merge() {
        // A 3 × 2 block of unit cells, a 2-cell leaf beside it, and one cell apart.
        let leaves = [
            sq(0, 0, 0),
            sq(1, 0, 0),
            sq(2, 0, 0),
            sq(0, 1, 0),
            sq(1, 1, 0),
            sq(2, 1, 0),
            sq(4, 0, 1),
            sq(9, 9, 0),
        ];
        let (pieces, of) = merge(&leaves, super::super::Workers::One);
        assert_eq!(pieces.len(), 3, "{pieces:?}");
        let block = pieces[of[0] as usize];
        assert_eq!(block, Piece { x: 0, y: 0, w: 3, h: 2 });
        assert!(of[..6].iter().all(|&p| p == of[0]));
        assert_eq!(pieces[of[6] as usize], Piece { x: 4, y: 0, w: 2, h: 2 });
        assert_eq!(pieces[of[7] as usize], Piece { x: 9, y: 9, w: 1, h: 1 });
    }

    #[test]
    fn rows_of_different_widths_do_not_stack() {
        let leaves = [sq(0, 0, 0), sq(1, 0, 0), sq(0, 1, 0)];
        let (pieces, _) = merge(&leaves, super::super::Workers::One);
        assert_eq!(pieces.len(), 2, "{pieces:?}");
    }

    #[test]
    fn pieces_span_at_most_the_cap() {
        let n = 3 * MAX_SPAN_LEAVES + 1;
        let leaves: Vec<Square> = (0..n).map(|x| sq(x, 0, 0)).collect();
        let (pieces, _) = merge(&leaves, super::super::Workers::One);
        assert_eq!(pieces.len(), 4);
        assert!(pieces.iter().all(|p| p.w <= MAX_SPAN_LEAVES));
    }
}
