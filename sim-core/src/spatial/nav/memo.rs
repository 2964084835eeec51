//! What one robot's searches learnt about pieces of its own known map.

use super::{NavGraph, NavNodeId};
use crate::spatial::KnownMap;
use crate::spatial::quadtree::Finger;

/// Slots of the memo (a power of two), an open-addressed table kept at most half full: a
/// robot's frontier search asks about a few hundred pieces (those it settles and their
/// neighbours), mostly the same ones from one search to the next.
const SLOTS: usize = 1024;

/// Pieces held before the table is emptied: a search then asks its pieces again.
const MAX_HELD: usize = SLOTS / 2;

/// Slots in a cache line: pieces numbered alike but for their last four bits (neighbours,
/// as the graph numbers pieces in Z order) share one line of slots, one slot each.
const LANES: usize = 16;

/// Lines of slots.
const LINES: usize = SLOTS / LANES;

/// Facts in a slot's low bits: a "yes" (bits 0–1) holds for good, a "no" (bits 2–3) only
/// while the map is as it was (its epoch in bits 4–9, the table emptied when they wrap);
/// the piece's line tag (its number without the lane bits, plus one) in the bits above (an
/// empty slot is 0). Four bytes a slot, so that a line holds 16.
const TOUCHED: u32 = 1;
const COVERED: u32 = 2;
const NO_SHIFT: u32 = 2;
const EPOCH_SHIFT: u32 = 4;
const KEY_SHIFT: u32 = 10;

/// Graphs with this many pieces or more are asked directly (their line tags would not fit).
const MAX_PIECES: usize = (LANES << (32 - KEY_SHIFT)) - LANES;

/// A small cache of "the known map touches piece n" and "covers piece n" for one robot's
/// own known map and navigation graph, each otherwise a descent of the known map's tree: a
/// robot searches again every few rounds over much the same pieces.
///
/// Invariant: a robot's known map only grows, so a "yes" stays right for good, and a "no"
/// as long as the map's number of known cells is the same (any change adds cells). The
/// answers are exactly those of [`NavGraph::touched_by`] and [`NavGraph::covered_by`];
/// checked by `piece_memo_answers_as_the_map_does`. A question the memo cannot answer is
/// asked of the map for both facts at once. The table is 4 KB, allocated at its first use,
/// and emptied when half full. Use it with one robot's map and one graph only (it forgets
/// everything if the graph's size changes); it is not part of a strategy's saved state, as
/// it can always be worked out again.
#[derive(Clone, Debug, Default)]
pub struct PieceMemo {
    slots: Option<Box<[u32; SLOTS]>>,
    /// Slots in use.
    held: usize,
    /// The graph's piece count when the slots were filled.
    pieces: usize,
    /// The known map's cell count when the current epoch began.
    known_cells: u64,
    /// Which "no"s are current (never 0 once slots exist).
    epoch: u32,
    /// The last node of the robot's last route: where its next search likely starts.
    route_end: Option<NavNodeId>,
}

impl PieceMemo {
    /// The last node of the last route [`set_route_end`](Self::set_route_end) noted: a hint
    /// for [`NavGraph::node_at_near`].
    pub fn route_end(&self) -> Option<NavNodeId> {
        self.route_end
    }

    /// Note the last node of the robot's new route.
    pub fn set_route_end(&mut self, n: Option<NavNodeId>) {
        self.route_end = n;
    }

    /// Whether `known` knows some cell of `n` ([`NavGraph::touched_by`]).
    pub fn touched(&mut self, nav: &NavGraph, known: &KnownMap, n: NavNodeId) -> bool {
        self.ask(nav, known, &mut Finger::new(known.tree()), n, TOUCHED)
    }

    /// Whether `known` knows every cell of `n` ([`NavGraph::covered_by`]).
    pub fn covered(&mut self, nav: &NavGraph, known: &KnownMap, n: NavNodeId) -> bool {
        self.ask(nav, known, &mut Finger::new(known.tree()), n, COVERED)
    }

    /// [`touched`](Self::touched), asking the map (if need be) from `finger`, a finger of
    /// `known`'s tree: a search's questions are about pieces close together.
    pub fn touched_from(&mut self, nav: &NavGraph, known: &KnownMap, finger: &mut Finger, n: NavNodeId) -> bool {
        self.ask(nav, known, finger, n, TOUCHED)
    }

    /// [`covered`](Self::covered), asking the map (if need be) from `finger`.
    pub fn covered_from(&mut self, nav: &NavGraph, known: &KnownMap, finger: &mut Finger, n: NavNodeId) -> bool {
        self.ask(nav, known, finger, n, COVERED)
    }

    fn ask(&mut self, nav: &NavGraph, known: &KnownMap, finger: &mut Finger, n: NavNodeId, fact: u32) -> bool {
        if nav.len() >= MAX_PIECES {
            let (touched, covered) = nav.touched_and_covered_from(known, finger, n);
            return if fact == TOUCHED { touched } else { covered };
        }
        if self.pieces != nav.len() || self.slots.is_none() {
            self.slots = Some(Box::new([0; SLOTS]));
            (self.pieces, self.known_cells, self.epoch, self.held) = (nav.len(), known.known_cells(), 1, 0);
        }
        let slots = self.slots.as_mut().expect("allocated above");
        if known.known_cells() != self.known_cells {
            self.known_cells = known.known_cells();
            self.epoch += 1;
            if self.epoch >> (KEY_SHIFT - EPOCH_SHIFT) != 0 {
                // The epoch field wrapped: old "no"s could pass for current ones.
                slots.fill(0);
                (self.epoch, self.held) = (1, 0);
            }
        }
        let tag = n.0 / LANES as u32 + 1;
        let key = tag << KEY_SHIFT;
        let lane = n.0 as usize % LANES;
        let home = (u64::from(tag).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 58) as usize % LINES;
        // Linear probing, line by line in the piece's lane, from its home line to its entry
        // or the first empty slot; a lane full all round (never in practice: the table is
        // emptied half full) empties the table.
        let mut line = home;
        let mut slot = line * LANES + lane;
        while slots[slot] != 0 && slots[slot] >> KEY_SHIFT != key >> KEY_SHIFT {
            line = (line + 1) % LINES;
            if line == home {
                slots.fill(0);
                self.held = 0;
            }
            slot = line * LANES + lane;
        }
        let entry = slots[slot];
        let current = (entry >> EPOCH_SHIFT) & ((1 << (KEY_SHIFT - EPOCH_SHIFT)) - 1) == self.epoch;
        if entry & fact != 0 {
            return true;
        }
        if current && entry & (fact << NO_SHIFT) != 0 {
            return false;
        }
        let (touched, covered) = nav.touched_and_covered_from(known, finger, n);
        // Both facts are known now: yeses for good, noes for this epoch.
        let facts = if covered {
            TOUCHED | COVERED
        } else {
            (u32::from(touched) * TOUCHED) | (COVERED << NO_SHIFT)
        };
        let facts = facts | (u32::from(!touched) * (TOUCHED << NO_SHIFT));
        if entry == 0 {
            if self.held == MAX_HELD {
                slots.fill(0);
                (self.held, slot) = (0, home * LANES + lane);
            }
            self.held += 1;
        }
        slots[slot] = key | (self.epoch << EPOCH_SHIFT) | facts;
        if fact == TOUCHED { touched } else { covered }
    }
}
