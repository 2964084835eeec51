//! What one robot's searches learnt about pieces of its own known map.

use super::{NavGraph, NavNodeId};
use crate::spatial::KnownMap;

/// Slots of the memo (a power of two): a robot's frontier searches settle a few dozen
/// pieces and ask about their neighbours, mostly the same ones from one search to the next.
const SLOTS: usize = 512;

/// Facts in a slot's low bits: a "yes" (bits 0–1) holds for good, a "no" (bits 2–3) only
/// while the map is as it was (its epoch in bits 4–19); the piece in the bits above.
const TOUCHED: u64 = 1;
const COVERED: u64 = 2;
const NO_SHIFT: u32 = 2;
const EPOCH_SHIFT: u32 = 4;
const KEY_SHIFT: u32 = 20;

/// A small cache of "the known map touches piece n" and "covers piece n" for one robot's
/// own known map and navigation graph (issue 12: these tests, each a descent of the known
/// map's tree, were a third of the frontier searches, and a robot searches again every few
/// rounds over much the same pieces, often twice in a round).
///
/// A robot's known map only grows, so a "yes" stays right for good, and a "no" as long as
/// the map's number of known cells is the same (any change adds cells). The answers are
/// exactly those of [`NavGraph::touched_by`] and [`NavGraph::covered_by`]. The cache is
/// direct-mapped (a piece whose slot another took is asked of the map again), 4 KB,
/// allocated at its first use. Use it with one robot's map and one graph only (it forgets
/// everything if the graph's size changes); it is not part of a strategy's saved state, as
/// it can always be worked out again.
#[derive(Clone, Debug, Default)]
pub struct PieceMemo {
    slots: Option<Box<[u64; SLOTS]>>,
    /// The graph's piece count when the slots were filled.
    pieces: usize,
    /// The known map's cell count when the current epoch began.
    known_cells: u64,
    /// Which "no"s are current (never 0 once slots exist).
    epoch: u64,
}

impl PieceMemo {
    /// Whether `known` knows some cell of `n` ([`NavGraph::touched_by`]).
    pub fn touched(&mut self, nav: &NavGraph, known: &KnownMap, n: NavNodeId) -> bool {
        self.ask(nav, known, n, TOUCHED, || nav.touched_by(known, n))
    }

    /// Whether `known` knows every cell of `n` ([`NavGraph::covered_by`]).
    pub fn covered(&mut self, nav: &NavGraph, known: &KnownMap, n: NavNodeId) -> bool {
        self.ask(nav, known, n, COVERED, || nav.covered_by(known, n))
    }

    fn ask(
        &mut self,
        nav: &NavGraph,
        known: &KnownMap,
        n: NavNodeId,
        fact: u64,
        work_out: impl FnOnce() -> bool,
    ) -> bool {
        if self.pieces != nav.len() || self.slots.is_none() {
            self.slots = Some(Box::new([0; SLOTS]));
            (self.pieces, self.known_cells, self.epoch) = (nav.len(), known.known_cells(), 1);
        }
        let slots = self.slots.as_mut().expect("allocated above");
        if known.known_cells() != self.known_cells {
            self.known_cells = known.known_cells();
            self.epoch += 1;
            if self.epoch >> (KEY_SHIFT - EPOCH_SHIFT) != 0 {
                // The epoch field wrapped: old "no"s could pass for current ones.
                slots.fill(0);
                self.epoch = 1;
            }
        }
        let key = (u64::from(n.0) + 1) << KEY_SHIFT;
        let slot = (u64::from(n.0).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 55) as usize % SLOTS;
        let mut entry = slots[slot];
        if entry >> KEY_SHIFT != key >> KEY_SHIFT {
            entry = key;
        }
        let current = (entry >> EPOCH_SHIFT) & ((1 << (KEY_SHIFT - EPOCH_SHIFT)) - 1) == self.epoch;
        if entry & fact != 0 {
            return true;
        }
        if current && entry & (fact << NO_SHIFT) != 0 {
            return false;
        }
        let answer = work_out();
        // Keep the yeses; the noes only if they are of this epoch.
        let mut facts = entry & (TOUCHED | COVERED);
        let mut noes = if current {
            entry & ((TOUCHED | COVERED) << NO_SHIFT)
        } else {
            0
        };
        if answer {
            // A piece covered is touched too (pieces are never empty).
            facts |= if fact == COVERED { TOUCHED | COVERED } else { fact };
        } else {
            // A piece not touched is not covered either.
            noes |= if fact == TOUCHED {
                (TOUCHED | COVERED) << NO_SHIFT
            } else {
                fact << NO_SHIFT
            };
        }
        slots[slot] = key | (self.epoch << EPOCH_SHIFT) | noes | facts;
        answer
    }
}
