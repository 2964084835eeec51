//! Scalable memory lists (paper §4.2): remember the last `n` things seen, or those seen in
//! the last `m` rounds, with O(1) amortised updates.

use std::collections::{HashMap, VecDeque};
use std::hash::Hash;

/// How much a [`MemoryList`] keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Retention {
    /// The `n` most recently seen items.
    LastN(usize),
    /// Items seen in the last `m` rounds.
    LastRounds(u64),
}

/// Items keyed by id, newest sighting wins, bounded by a [`Retention`] policy.
#[derive(Clone, Debug)]
pub struct MemoryList<K: Eq + Hash + Copy, T> {
    retention: Retention,
    /// Sightings in the order they were recorded (key, sequence number, round); entries
    /// whose sequence number is no longer the key's live one are stale.
    log: VecDeque<(K, u64, u64)>,
    /// Key → (sequence number, round, item) of its live sighting.
    live: HashMap<K, (u64, u64, T)>,
    next_seq: u64,
}

impl<K: Eq + Hash + Copy, T: Clone> MemoryList<K, T> {
    /// An empty list.
    pub fn new(retention: Retention) -> Self {
        Self {
            retention,
            log: VecDeque::new(),
            live: HashMap::new(),
            next_seq: 0,
        }
    }

    /// Record that `item` (key `key`) was seen in `round`.
    pub fn record(&mut self, key: K, item: T, round: u64) {
        let seq = self.next_seq;
        self.next_seq += 1;
        self.live.insert(key, (seq, round, item));
        self.log.push_back((key, seq, round));
        self.evict(round);
    }

    /// Forget an item.
    pub fn forget(&mut self, key: K) {
        self.live.remove(&key);
    }

    fn is_live(&self, key: K, seq: u64) -> bool {
        self.live.get(&key).is_some_and(|e| e.0 == seq)
    }

    /// Drop what the policy no longer keeps at `round`.
    pub fn evict(&mut self, round: u64) {
        while let Some(&(k, seq, seen)) = self.log.front() {
            let stale = !self.is_live(k, seq);
            let expired = match self.retention {
                Retention::LastN(n) => self.live.len() > n,
                Retention::LastRounds(m) => seen + m < round,
            };
            if stale {
                self.log.pop_front();
            } else if expired {
                self.live.remove(&k);
                self.log.pop_front();
            } else {
                break;
            }
        }
        // Keep the log from filling with stale entries behind a long-lived front.
        if self.log.len() > 2 * self.live.len() + 16 {
            let live = &self.live;
            self.log.retain(|(k, seq, _)| live.get(k).is_some_and(|e| e.0 == *seq));
        }
    }

    /// Number of items remembered.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// Items with the round each was last seen, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = (&T, u64)> {
        self.log.iter().filter_map(|(k, seq, _)| {
            let (s, round, item) = self.live.get(k)?;
            (s == seq).then_some((item, *round))
        })
    }

    /// The live item of a key.
    pub fn get(&self, key: K) -> Option<&T> {
        self.live.get(&key).map(|e| &e.2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn last_n_keeps_the_newest_distinct_items() {
        let mut m = MemoryList::new(Retention::LastN(3));
        for (round, key) in [1, 2, 3, 1, 4, 5].into_iter().enumerate() {
            m.record(key, key * 10, round as u64);
        }
        // Seen order by latest sighting: 2 (r1), 3 (r2), 1 (r3), 4 (r4), 5 (r5) → keep 1, 4, 5.
        let kept: Vec<_> = m.iter().map(|(v, r)| (*v, r)).collect();
        assert_eq!(kept, vec![(10, 3), (40, 4), (50, 5)]);
        assert_eq!(m.get(1), Some(&10));
        assert_eq!(m.get(2), None);
    }

    #[test]
    fn last_rounds_forgets_old_sightings() {
        let mut m = MemoryList::new(Retention::LastRounds(5));
        m.record('a', 1, 0);
        m.record('b', 2, 3);
        m.record('c', 3, 6);
        // At round 6, 'a' (seen at 0) is more than 5 rounds old.
        assert_eq!(m.len(), 2);
        m.record('b', 22, 9);
        m.evict(12);
        assert_eq!(m.iter().map(|(v, _)| *v).collect::<Vec<_>>(), vec![22]);
    }

    #[test]
    fn memory_stays_bounded_under_repeated_sightings() {
        let mut m = MemoryList::new(Retention::LastN(10));
        for round in 0..10_000u64 {
            m.record(round % 7, round, round);
        }
        assert_eq!(m.len(), 7);
        assert!(m.log.len() <= 2 * 7 + 17);
    }
}
