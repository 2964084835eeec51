//! Delivering a round's messages when radios have a budget: receiver by receiver, in
//! parallel, each taking what fits its budget in a fixed order.

use std::ops::ControlFlow;

use glam::DVec2;
use rayon::prelude::*;

use crate::engine::simulation::{Outgoing, Simulation, Turn};
use crate::spatial::RobotIndex;
use crate::world::{Payload, Recipient, RobotType};

impl Simulation {
    /// Deliver this round's messages when radios have a budget: receiver by receiver (in id
    /// order), messages addressed to it first, then broadcasts of senders in range in the
    /// index's fixed order, until the next would overflow its budget. The accepted ones go
    /// to the inbox in sender order, as unbudgeted delivery would put them. Work per
    /// receiver is bounded by its budget, not by the crowd around it.
    pub(super) fn deliver_within_budget(&mut self) {
        let mut outgoing = std::mem::take(&mut self.outgoing);
        if outgoing.is_empty() {
            return;
        }
        let lists = sort_sends(&outgoing, self.robots.len());
        let max_range = outgoing.iter().map(|o| o.range_m).fold(0.0, f64::max);
        let senders = self.index_senders(&lists.span, max_range);
        let (by_entry, broadcasts) = sends_by_entry(&senders, &lists);
        let sends = Sends {
            outgoing: &outgoing,
            broadcasts: &broadcasts,
            by_entry: &by_entry,
            direct: &lists.direct,
            senders: &senders,
            max_range,
            robots: &self.robots,
            types: &self.types,
            turns: &self.turns,
        };
        // Budgeted sends skip the bag until the end: picks are indices into `outgoing`, and
        // into the bag once `outgoing` is moved there, which it starts empty for.
        debug_assert!(self.mailbag.is_empty());
        let used = sends.deliver_all(&mut self.inboxes);
        self.bag_outgoing(&mut outgoing, &used);
        self.outgoing = outgoing;
    }

    /// Index the robots that broadcast this round (those with a part in `span`) where they
    /// sent from, in cells of the widest range: in rows of cells when there are at least as
    /// many senders as a query's box can hold cells (their walk is then the hashed cells'
    /// walk, without a cell check per sender), in hashed cells otherwise. The budgets' picks
    /// follow that walk.
    #[inline]
    fn index_senders(&self, span: &[(u32, u32, f64)], max_range: f64) -> RobotIndex {
        let cell_m = max_range.clamp(1.0, 64.0);
        let count = span.iter().filter(|s| s.0 != s.1).count();
        let mut senders = if count as f64 >= RobotIndex::box_cells_at_most(max_range, cell_m) {
            RobotIndex::rows_when_compact()
        } else {
            RobotIndex::new()
        };
        senders.rebuild(
            (0..self.robots.len())
                .filter(|&i| span[i].0 != span[i].1)
                .map(|i| (self.robots[i].id, self.turns[i].start)),
            cell_m,
        );
        senders
    }

    /// Move `outgoing` into the bag, in order, so that the inboxes' picks (indices into
    /// `outgoing`) point into the bag as they are, without renumbering. Messages nobody
    /// accepted keep their place with an empty payload: theirs (whole known maps, often)
    /// are dropped now, not kept for a round.
    fn bag_outgoing(&mut self, outgoing: &mut Vec<Outgoing>, used: &[u64]) {
        self.mailbag.reserve(outgoing.len());
        for (k, o) in outgoing.drain(..).enumerate() {
            let mut message = o.message;
            if used[k / 64] >> (k % 64) & 1 == 0 {
                message.payload = Payload::Custom {
                    kind: String::new(),
                    data: Vec::new(),
                };
            }
            self.mailbag.push(message);
        }
    }
}

/// A sender's range and its part (start, end) of the broadcasts, beside its entry in the
/// senders' index.
type ByEntry = (f64, u32, u32);

/// A round's sends under radio budgets, as the receivers read them.
struct Sends<'a> {
    outgoing: &'a [Outgoing],
    /// The broadcasts as (index in `outgoing`, bytes), each sender's contiguous, the
    /// senders in the order of `senders`' entries.
    broadcasts: &'a [(u32, u64)],
    /// For each of `senders`' entries, in its order: the sender's range and its part of
    /// `broadcasts`.
    by_entry: &'a [ByEntry],
    /// Direct messages as (receiver id, index in `outgoing`), sorted.
    direct: &'a [(u32, u32)],
    /// The senders where they sent from, in cells of the widest range.
    senders: &'a RobotIndex,
    max_range: f64,
    robots: &'a [crate::world::Robot],
    types: &'a [RobotType],
    /// Where each robot sent from (its start of the round).
    turns: &'a [Turn],
}

/// A round's budgeted sends, sorted for delivery.
struct SendLists {
    /// Per robot: its part of `broadcasts` (start, end) and its range, noted with its first
    /// broadcast (all of a sender's sends have its type's range).
    span: Vec<(u32, u32, f64)>,
    /// The broadcasts as (index in `outgoing`, bytes), each sender's contiguous.
    broadcasts: Vec<(u32, u64)>,
    /// Direct messages as (receiver id, index in `outgoing`), sorted.
    direct: Vec<(u32, u32)>,
}

/// Sort the round's budgeted sends (of `n` robots) into each sender's broadcasts and the
/// direct messages by receiver.
#[inline]
fn sort_sends(outgoing: &[Outgoing], n: usize) -> SendLists {
    // Each sender's broadcasts, as (index in `outgoing`, bytes): contiguous, as resolve
    // runs in sender order; `span[s]` is sender s's part, and its range.
    let mut span = vec![(0u32, 0u32, 0.0f64); n];
    let mut broadcasts: Vec<(u32, u64)> = Vec::new();
    let mut direct: Vec<(u32, u32)> = Vec::new();
    for (k, o) in outgoing.iter().enumerate() {
        let k = k as u32;
        match o.message.to {
            Recipient::Broadcast => {
                let end = u32::try_from(broadcasts.len() + 1).expect("fewer than 2^32 messages a round");
                if span[o.from].0 == span[o.from].1 {
                    span[o.from].0 = end - 1;
                    span[o.from].2 = o.range_m;
                }
                span[o.from].1 = end;
                broadcasts.push((k, o.bytes));
            }
            Recipient::Direct(target) => direct.push((target.get(), k)),
        }
    }
    direct.sort_unstable();
    SendLists {
        span,
        broadcasts,
        direct,
    }
}

/// Beside the index's entries, in its order, each sender's range and its part of the
/// broadcasts, which are copied into the same order: a receiver reads both in step with the
/// entries, a row of cells' senders one stretch of memory, rather than jumping about by id.
#[inline]
fn sends_by_entry(senders: &RobotIndex, lists: &SendLists) -> (Vec<ByEntry>, Vec<(u32, u64)>) {
    let mut broadcasts = Vec::with_capacity(lists.broadcasts.len());
    let by_entry = senders
        .entries()
        .iter()
        .map(|e| {
            let (b0, b1, range_m) = lists.span[e.id.index()];
            let start = broadcasts.len() as u32;
            broadcasts.extend_from_slice(&lists.broadcasts[b0 as usize..b1 as usize]);
            (range_m, start, broadcasts.len() as u32)
        })
        .collect();
    (by_entry, broadcasts)
}

impl Sends<'_> {
    /// Fill every robot's inbox. Receivers are independent (each reads the shared sends and
    /// writes its own inbox), so they run in parallel; each worker also gathers which
    /// messages anyone accepted, so the bag is made without another pass over every pick.
    /// Returns that bitset over `outgoing`.
    #[inline]
    fn deliver_all(&self, inboxes: &mut [Vec<u32>]) -> Vec<u64> {
        let words = self.outgoing.len().div_ceil(64);
        inboxes
            .par_iter_mut()
            .enumerate()
            .fold(
                || (vec![0u64; words], vec![0u64; words]),
                |(mut used, mut accepted), (r, inbox)| {
                    self.deliver_to(r, inbox, &mut used, &mut accepted);
                    (used, accepted)
                },
            )
            .map(|(used, _)| used)
            .reduce(
                || vec![0u64; words],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(&b) {
                        *x |= *y;
                    }
                    a
                },
            )
    }

    /// Fill robot `r`'s inbox: messages addressed to it first, then broadcasts of senders in
    /// range in the index's fixed order, until the next would overflow its budget; the
    /// accepted ones in sender order, as unbudgeted delivery would put them. `accepted` is
    /// a clear bitset over `outgoing` (left clear); the accepted messages are also set in
    /// `used`.
    ///
    /// The bitset is read back a word at a time, which gives sender order without a sort;
    /// `a_budget_that_never_fills_delivers_exactly_what_no_budget_does` (tests/radio.rs)
    /// checks the order.
    fn deliver_to(&self, r: usize, inbox: &mut Vec<u32>, used: &mut [u64], accepted: &mut [u64]) {
        let robot = &self.robots[r];
        if !robot.alive {
            return;
        }
        let to = robot.id;
        let here = self.turns[r].start;
        let budget = self.types[robot.type_index].radio_bytes_per_round;
        let mut spent = 0u64;
        let mut fits = |bytes: u64| {
            let ok = spent.checked_add(bytes).is_some_and(|u| u <= budget);
            if ok {
                spent += bytes;
            }
            ok
        };
        // The words of `accepted` written (all clear outside them).
        let (mut lo, mut hi) = (accepted.len(), 0);
        let mut accept = |k: u32| {
            let w = k as usize / 64;
            accepted[w] |= 1u64 << (k % 64);
            (lo, hi) = (lo.min(w), hi.max(w + 1));
        };
        let mine = self.direct.partition_point(|e| e.0 < to.get());
        for &(_, k) in self.direct[mine..].iter().take_while(|e| e.0 == to.get()) {
            let o = &self.outgoing[k as usize];
            if o.from != r && within_range(self.turns[o.from].start, here, o.range_m) && fits(o.bytes) {
                accept(k);
            }
        }
        // Senders within the widest range, in the index's walk order, each read with its
        // sends beside it (`by_entry` follows the entries).
        let entries = self.senders.entries();
        let _ = self.senders.try_for_each_entry_within(here, self.max_range, |i| {
            let (e, &(range_m, b0, b1)) = (&entries[i], &self.by_entry[i]);
            if e.id.index() == r || !within_range(e.position, here, range_m) {
                return ControlFlow::Continue(());
            }
            for &(k, bytes) in &self.broadcasts[b0 as usize..b1 as usize] {
                if !fits(bytes) {
                    return ControlFlow::Break(());
                }
                accept(k);
            }
            ControlFlow::Continue(())
        });
        for w in lo..hi {
            let mut bits = std::mem::take(&mut accepted[w]);
            used[w] |= bits;
            while bits != 0 {
                inbox.push((w * 64 + bits.trailing_zeros() as usize) as u32);
                bits &= bits - 1;
            }
        }
    }
}

/// `to.distance(from) <= range_m`, without the square root for all but the points within a
/// part in 10¹² of the range. Below `range_m² (1 − 10⁻¹²)`, rounded either way, the squared
/// distance's root is below the range by far more than its rounding, so the test agrees
/// with the distance's: `within_range_agrees_with_the_distance`.
#[inline]
fn within_range(to: DVec2, from: DVec2, range_m: f64) -> bool {
    let d2 = to.distance_squared(from);
    d2 <= range_m * range_m * (1.0 - 1e-12) || d2.sqrt() <= range_m
}

#[cfg(test)]
mod tests {
    use glam::DVec2;
    use rand::{Rng, SeedableRng};

    use super::within_range;

    /// The range test without a square root agrees with the distance's, for points at
    /// random and for points within a few rounding steps of the rim.
    #[test]
    fn within_range_agrees_with_the_distance() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200_000 {
            let from = DVec2::new(rng.random_range(-1e4..1e4), rng.random_range(-1e4..1e4));
            let range_m: f64 = rng.random_range(0.0..50.0);
            let dir = DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU));
            // Half the points at random distances, half on the rim give or take a few ulps.
            let d = if rng.random_bool(0.5) {
                rng.random_range(0.0..2.0 * range_m.max(1e-9))
            } else {
                range_m * (1.0 + f64::from(rng.random_range(-4i32..=4)) * f64::EPSILON)
            };
            let to = from + dir * d;
            assert_eq!(
                within_range(to, from, range_m),
                to.distance(from) <= range_m,
                "{to} from {from}, range {range_m}"
            );
        }
    }
}
