//! Team mates' announced goals, as a `cooperative` robot keeps them: a set, updated in
//! one pass each round and cut to those heard last.
//!
//! In a crowd a robot hears hundreds of announcements a round and keeps hundreds of
//! claims. Kept in id order, they were merged with the announcements into a second list
//! and cut while copied back (issue 11: with their mispredicted branches, the merge and
//! the cut were a sixth of the moonshot's crowded rounds and a tenth of `bench-1000`).
//! Nothing reads the claims in order (they are the points a new target keeps away from),
//! so the list is now a set: the claims of robots that announced something are dropped by
//! a bit per robot, the others moved down over them in place, and the new ones appended.

use std::cell::RefCell;

use glam::DVec2;

/// A team mate's goal: the robot's id, the goal, and the round it was heard in 32 bits
/// (saturating after 4×10⁹ rounds; 24 bytes a claim instead of 32).
pub(super) type Claim = (u32, DVec2, u32);

/// What an announcement does to the claims: a goal to keep (`Some`) or forget.
pub(super) type Update = (u32, Option<DVec2>);

/// Claims heard this long ago or longer count as equally old when cut.
const OLDEST_AGE: usize = 63;

/// Every tenth round: claims heard more than this many rounds ago are forgotten.
const FORGET_AFTER_ROUNDS: u64 = 50;

thread_local! {
    /// A worker's scratch: a bit per robot id (all clear between calls), and the ids of
    /// the claims of the cut's age.
    static SCRATCH: RefCell<(Vec<u64>, Vec<u32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// A round as a claim keeps it (see [`Claim`]).
fn heard_in(round: u64) -> u32 {
    u32::try_from(round).unwrap_or(u32::MAX)
}

/// How long ago a claim was heard, at most [`OLDEST_AGE`].
fn age(round: u64, heard: u32) -> usize {
    (round.saturating_sub(u64::from(heard))).min(OLDEST_AGE as u64) as usize
}

/// Apply a round's `updates` to `claims` (a set: their order carries nothing), then keep
/// the `max` heard last.
///
/// - `updates` are in robot id order (of a robot's updates the last counts): each robot's
///   claim is replaced by its goal, heard in `round`, or dropped if it has none.
/// - With `forget` (every tenth round: the robot's position and a distance), claims heard
///   more than 50 rounds ago or farther than the distance are dropped first. New claims
///   are near (the caller keeps only near goals) and recent.
/// - Of the rest, the `max` heard last are kept; of those heard in the same round, the
///   lowest ids.
pub(super) fn update(
    claims: &mut Vec<Claim>,
    updates: &[Update],
    round: u64,
    max: usize,
    forget: Option<(DVec2, f64)>,
) {
    debug_assert!(updates.is_sorted_by_key(|u| u.0));
    SCRATCH.with_borrow_mut(|(announced, same_age)| {
        for &(id, _) in updates {
            let w = id as usize / 64;
            if w >= announced.len() {
                announced.resize(w + 1, 0);
            }
            announced[w] |= 1 << (id % 64);
        }
        // The claims kept, moved down over the dropped ones and counted by age. (A branch
        // per claim did better than none: the selects cost more than the mispredictions.)
        let mut per_age = [0usize; OLDEST_AGE + 1];
        let mut kept = 0;
        for i in 0..claims.len() {
            let c = claims[i];
            let heard_again = announced
                .get(c.0 as usize / 64)
                .is_some_and(|w| (w >> (c.0 % 64)) & 1 == 1);
            let keep = !heard_again
                && forget.is_none_or(|(p, near_m)| {
                    round <= u64::from(c.2) + FORGET_AFTER_ROUNDS && c.1.distance(p) <= near_m
                });
            claims[kept] = c;
            kept += usize::from(keep);
            per_age[age(round, c.2)] += usize::from(keep);
        }
        claims.truncate(kept);
        for &(id, _) in updates {
            // Only this call's bits are set in these words.
            announced[id as usize / 64] = 0;
        }
        let heard = heard_in(round);
        let fresh = updates
            .iter()
            .enumerate()
            .filter(|&(k, u)| updates.get(k + 1).is_none_or(|next| next.0 != u.0))
            .filter_map(|(_, &(id, goal))| goal.map(|g| (id, g, heard)));
        let fresh_count = fresh.clone().count();
        if kept + fresh_count <= max {
            claims.extend(fresh);
            return;
        }
        per_age[age(round, heard)] += fresh_count;
        // The oldest age kept, and how many claims of that age fit.
        let (mut cut, mut room) = (OLDEST_AGE, 0);
        let mut newer = 0;
        for (a, &n) in per_age.iter().enumerate() {
            if newer + n >= max {
                (cut, room) = (a, max - newer);
                break;
            }
            newer += n;
        }
        // Of the claims of the cut's age, the `room` lowest ids are kept.
        same_age.clear();
        same_age.extend(claims.iter().filter(|c| age(round, c.2) == cut).map(|c| c.0));
        same_age.extend(fresh.clone().filter(|c| age(round, c.2) == cut).map(|c| c.0));
        let highest_kept = if room == 0 {
            None
        } else if room >= same_age.len() {
            Some(u32::MAX)
        } else {
            Some(*same_age.select_nth_unstable(room - 1).1)
        };
        let keeps = |c: &Claim| {
            let a = age(round, c.2);
            a < cut || (a == cut && highest_kept.is_some_and(|h| c.0 <= h))
        };
        let mut kept = 0;
        for i in 0..claims.len() {
            let c = claims[i];
            claims[kept] = c;
            kept += usize::from(keeps(&c));
        }
        claims.truncate(kept);
        claims.extend(fresh.filter(keeps));
    });
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use glam::DVec2;
    use proptest::prelude::*;

    use super::{Claim, Update, update};

    /// The claims as a brute force works them out: the updates applied one by one to a map
    /// by id, the forgetting, then all sorted by recency (then id) and cut.
    fn brute_force(
        old: &[Claim],
        updates: &[Update],
        round: u64,
        max: usize,
        forget: Option<(DVec2, f64)>,
    ) -> Vec<Claim> {
        let mut map: BTreeMap<u32, (DVec2, u32)> = old.iter().map(|c| (c.0, (c.1, c.2))).collect();
        for &(id, goal) in updates {
            match goal {
                Some(g) => map.insert(id, (g, round as u32)),
                None => map.remove(&id),
            };
        }
        if let Some((p, near)) = forget {
            map.retain(|_, (g, heard)| round <= u64::from(*heard) + 50 && g.distance(p) <= near);
        }
        let mut all: Vec<Claim> = map.into_iter().map(|(id, (g, h))| (id, g, h)).collect();
        // Heard 63 rounds ago or earlier counts as equally old.
        all.sort_by_key(|c| (round.saturating_sub(u64::from(c.2)).min(63), c.0));
        all.truncate(max);
        all.sort_by_key(|c| c.0);
        all
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 1000, rng_seed: proptest::test_runner::RngSeed::Fixed(3), ..ProptestConfig::default() })]

        /// Issue 11: the claims after a round are those of a brute force: announcements
        /// applied one by one (the last of a robot's counting), old and far claims
        /// forgotten every tenth round, and the `max` heard last kept (of those heard in
        /// the same round, the lowest ids), whatever the list's order before.
        #[test]
        fn issue11_claims_equal_a_brute_force(
            old in proptest::collection::btree_map(0u32..300, (0.0f64..30.0, 0u32..100), 0..120),
            mut updates in proptest::collection::vec((0u32..300, proptest::option::of(0.0f64..30.0)), 0..80),
            max in 0usize..150,
            forget in proptest::option::of((0.0f64..30.0, 0.0f64..40.0)),
            shuffle in any::<u64>(),
        ) {
            let round = 100;
            updates.sort_by_key(|u| u.0);
            let forget = forget.map(|(x, near)| (DVec2::new(x, 0.0), near));
            // The caller announces only near goals (of the forgetting's distance).
            let near = |g: DVec2| forget.is_none_or(|(p, near)| g.distance(p) <= near);
            let updates: Vec<Update> = updates
                .into_iter()
                .map(|(id, g)| (id, g.map(|x| DVec2::new(x, 1.0)).filter(|&g| near(g))))
                .collect();
            let mut claims: Vec<Claim> = old.iter().map(|(&id, &(x, heard))| (id, DVec2::new(x, -1.0), heard)).collect();
            // Any order: the list is a set.
            let n = claims.len().max(1);
            claims.rotate_left(shuffle as usize % n);
            let expected = brute_force(&claims, &updates, round, max, forget);
            update(&mut claims, &updates, round, max, forget);
            claims.sort_by_key(|c| c.0);
            prop_assert_eq!(claims, expected);
        }
    }

    /// Ties in the cut go to the lowest ids, among new claims as among old ones.
    #[test]
    fn issue11_the_cut_keeps_the_lowest_ids_of_its_round() {
        let g = DVec2::ZERO;
        let sorted = |claims: &[Claim]| {
            let mut list = claims.to_vec();
            list.sort_by_key(|c| c.0);
            list
        };
        let mut claims = vec![(9, g, 5), (2, g, 4), (7, g, 5), (1, g, 3)];
        update(&mut claims, &[(4, Some(g)), (8, Some(g))], 6, 4, None);
        // New: 4 and 8 (round 6); then 7 and 9 (round 5) fill the rest.
        assert_eq!(sorted(&claims), vec![(4, g, 6), (7, g, 5), (8, g, 6), (9, g, 5)]);
        update(&mut claims, &[(3, Some(g)), (5, Some(g)), (6, Some(g))], 7, 2, None);
        assert_eq!(sorted(&claims), vec![(3, g, 7), (5, g, 7)]);
    }
}
