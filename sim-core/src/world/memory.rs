//! Scalable memory lists (paper §4.2): remember the last `n` things seen, or those seen in
//! the last `m` rounds, with O(1) updates.

use std::collections::HashMap;
use std::hash::Hash;

/// A fast, fixed-seed hasher: keys are small ids and nothing here faces untrusted input,
/// so `SipHash`'s resistance to flooding is not needed.
type FastMap<K, V> = HashMap<K, V, foldhash::fast::FixedState>;

/// A key a [`MemoryList`] can remember items by. Keys that are small dense numbers (robot
/// and treasure ids) say so with [`dense_index`](Self::dense_index), and are then looked up
/// in a table instead of hashed; the default hashes every key. Either way the list is the
/// same: `matches_a_brute_force_model`.
pub trait ListKey: Eq + Hash + Copy {
    /// The key as a small index, if it is one.
    fn dense_index(self) -> Option<usize> {
        None
    }
}

impl ListKey for crate::spatial::RobotId {
    fn dense_index(self) -> Option<usize> {
        Some(self.index())
    }
}

impl ListKey for crate::spatial::TreasureId {
    fn dense_index(self) -> Option<usize> {
        Some(self.index())
    }
}

/// Integers are dense when not negative.
macro_rules! dense_unsigned {
    ($($t:ty),*) => {$(
        impl ListKey for $t {
            fn dense_index(self) -> Option<usize> {
                usize::try_from(self).ok()
            }
        }
    )*};
}
dense_unsigned!(u8, u16, u32, u64, usize, i32, i64);

impl ListKey for char {}

/// Where a list keeps each key's slot: a table indexed by the key for dense keys up to
/// sixteen times the items kept (so a list's table costs at most 64 bytes an item), a hash
/// map for the rest.
#[derive(Clone, Debug)]
struct SlotIndex<K> {
    table: Vec<u32>,
    map: FastMap<K, u32>,
    len: usize,
}

impl<K: ListKey> SlotIndex<K> {
    fn new() -> Self {
        Self {
            table: Vec::new(),
            map: FastMap::default(),
            len: 0,
        }
    }

    fn get(&self, key: K) -> Option<u32> {
        if let Some(&i) = key.dense_index().and_then(|d| self.table.get(d))
            && i != NIL
        {
            return Some(i);
        }
        // A dense key may be in the map if the table was shorter when it came.
        self.map.get(&key).copied()
    }

    /// Index a key that is not indexed yet.
    fn insert(&mut self, key: K, slot: u32) {
        self.len += 1;
        match key.dense_index() {
            Some(d) if d < 16 * (self.len + 4) => {
                if d >= self.table.len() {
                    self.table.resize(d + 1, NIL);
                }
                self.table[d] = slot;
            }
            _ => {
                self.map.insert(key, slot);
            }
        }
    }

    fn remove(&mut self, key: K) -> Option<u32> {
        let removed = match key.dense_index().and_then(|d| self.table.get_mut(d)) {
            Some(i) if *i != NIL => Some(std::mem::replace(i, NIL)),
            _ => self.map.remove(&key),
        };
        self.len -= usize::from(removed.is_some());
        removed
    }
}

/// How much a [`MemoryList`] keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Retention {
    /// The `n` most recently seen items.
    LastN(usize),
    /// Items seen in the last `m` rounds.
    LastRounds(u64),
}

/// No slot (end of the list).
const NIL: u32 = u32::MAX;
/// The `older` link of a forgotten slot, so that a scan of the slab can skip it.
const FREED: u32 = u32::MAX - 1;

/// One remembered item, a link in the list from oldest to newest sighting.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct Slot<K, T> {
    key: K,
    round: u64,
    item: T,
    older: u32,
    newer: u32,
}

/// Items keyed by id, newest sighting wins, bounded by a [`Retention`] policy.
///
/// A doubly linked list in a slab, oldest sighting first, plus a map from key to slot:
/// recording, forgetting and evicting are O(1) each (no stale entries, no scans).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(bound(serialize = "K: serde::Serialize, T: serde::Serialize"))]
#[serde(bound(deserialize = "K: serde::Deserialize<'de>, T: serde::Deserialize<'de>"))]
#[serde(try_from = "ListState<K, T>")]
pub struct MemoryList<K: ListKey, T> {
    retention: Retention,
    slots: Vec<Slot<K, T>>,
    /// Slots of forgotten items, reused first.
    free: Vec<u32>,
    /// Rebuilt from the slots when a checkpoint is read.
    #[serde(skip)]
    index: SlotIndex<K>,
    oldest: u32,
    newest: u32,
}

/// A [`MemoryList`] as a checkpoint stores it (the index is rebuilt from the slots).
#[derive(serde::Deserialize)]
struct ListState<K, T> {
    retention: Retention,
    slots: Vec<Slot<K, T>>,
    free: Vec<u32>,
    oldest: u32,
    newest: u32,
}

impl<K: ListKey, T> TryFrom<ListState<K, T>> for MemoryList<K, T> {
    type Error = String;

    fn try_from(s: ListState<K, T>) -> Result<Self, String> {
        let n = s.slots.len();
        let link_ok = |i: u32| i == NIL || (i as usize) < n;
        if !(link_ok(s.oldest) && link_ok(s.newest) && s.free.iter().all(|&i| (i as usize) < n)) {
            return Err("a memory list links to a slot it does not have".into());
        }
        let mut index = SlotIndex::new();
        // Live slots are those on the list from oldest to newest.
        let mut at = s.oldest;
        let mut steps = 0;
        while at != NIL {
            let slot = s.slots.get(at as usize).ok_or("a memory list links out of its slots")?;
            if !link_ok(slot.newer) || steps > n {
                return Err("a memory list's links are broken".into());
            }
            if index.get(slot.key).is_some() {
                return Err("a memory list remembers a key twice".into());
            }
            index.insert(slot.key, at);
            at = slot.newer;
            steps += 1;
        }
        Ok(Self {
            retention: s.retention,
            slots: s.slots,
            free: s.free,
            index,
            oldest: s.oldest,
            newest: s.newest,
        })
    }
}

impl<K: ListKey, T: Clone> MemoryList<K, T> {
    /// An empty list.
    pub fn new(retention: Retention) -> Self {
        Self {
            retention,
            slots: Vec::new(),
            free: Vec::new(),
            index: SlotIndex::new(),
            oldest: NIL,
            newest: NIL,
        }
    }

    /// Record that `item` (key `key`) was seen in `round`.
    pub fn record(&mut self, key: K, item: T, round: u64) {
        if let Some(i) = self.index.get(key) {
            let slot = &mut self.slots[i as usize];
            slot.item = item;
            slot.round = round;
            if self.newest != i {
                self.unlink(i);
                self.push_newest(i);
            }
        } else {
            let slot = Slot {
                key,
                round,
                item,
                older: NIL,
                newer: NIL,
            };
            let i = if let Some(i) = self.free.pop() {
                self.slots[i as usize] = slot;
                i
            } else {
                self.slots.push(slot);
                u32::try_from(self.slots.len() - 1).expect("fewer than 2^32 remembered items")
            };
            self.index.insert(key, i);
            self.push_newest(i);
        }
        self.evict(round);
    }

    /// Forget an item.
    pub fn forget(&mut self, key: K) {
        if let Some(i) = self.index.remove(key) {
            self.unlink(i);
            self.slots[i as usize].older = FREED;
            self.free.push(i);
        }
    }

    /// Drop what the policy no longer keeps at `round`.
    pub fn evict(&mut self, round: u64) {
        while self.oldest != NIL {
            let oldest = &self.slots[self.oldest as usize];
            let expired = match self.retention {
                Retention::LastN(n) => self.index.len > n,
                Retention::LastRounds(m) => oldest.round + m < round,
            };
            if !expired {
                break;
            }
            self.forget(oldest.key);
        }
    }

    /// Take slot `i` out of the list.
    fn unlink(&mut self, i: u32) {
        let (older, newer) = {
            let s = &self.slots[i as usize];
            (s.older, s.newer)
        };
        match older {
            NIL => self.oldest = newer,
            o => self.slots[o as usize].newer = newer,
        }
        match newer {
            NIL => self.newest = older,
            n => self.slots[n as usize].older = older,
        }
    }

    /// Put slot `i` at the newest end.
    fn push_newest(&mut self, i: u32) {
        let newest = self.newest;
        {
            let s = &mut self.slots[i as usize];
            s.older = newest;
            s.newer = NIL;
        }
        match newest {
            NIL => self.oldest = i,
            n => self.slots[n as usize].newer = i,
        }
        self.newest = i;
    }

    /// Of `keys`, distinct and all to be recorded in one round, in order, the tail that
    /// gives the same list as recording them all: all of them, or under
    /// [`Retention::LastN`]`(n)` the last `n` when there are more (those are all the list
    /// keeps after, newest last, and everything else is forgotten either way).
    pub fn kept_of<'k, Q>(&self, keys: &'k [Q]) -> &'k [Q] {
        match self.retention {
            Retention::LastN(n) => &keys[keys.len().saturating_sub(n)..],
            Retention::LastRounds(_) => keys,
        }
    }

    /// Number of items remembered.
    pub fn len(&self) -> usize {
        self.index.len
    }

    /// Whether nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.index.len == 0
    }

    /// Items with the round each was last seen, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = (&T, u64)> {
        let mut at = self.oldest;
        std::iter::from_fn(move || {
            let s = self.slots.get(at as usize)?;
            at = s.newer;
            Some((&s.item, s.round))
        })
    }

    /// Whether any remembered item satisfies `pred`, in no particular order.
    ///
    /// A scan of the slab, not a walk of the list (no dependent loads), for checks that
    /// usually fail, such as "is any remembered treasure in view" every round.
    pub fn any(&self, mut pred: impl FnMut(&T) -> bool) -> bool {
        self.slots.iter().any(|s| s.older != FREED && pred(&s.item))
    }

    /// The live item of a key.
    pub fn get(&self, key: K) -> Option<&T> {
        self.index.get(key).map(|i| &self.slots[i as usize].item)
    }

    /// Check the list's invariants: every key maps to a slot holding it, the links run
    /// both ways from oldest to newest through exactly the live slots, rounds never
    /// decrease along the list, and the policy holds. Panics with the broken rule.
    pub fn assert_well_formed(&self) {
        let mut seen = 0;
        let mut at = self.oldest;
        let mut prev = NIL;
        let mut last_round = 0;
        while at != NIL {
            let s = &self.slots[at as usize];
            assert_eq!(s.older, prev, "back link of slot {at}");
            assert_eq!(self.index.get(s.key), Some(at), "index entry of slot {at}");
            assert!(s.round >= last_round, "rounds decrease at slot {at}");
            last_round = s.round;
            seen += 1;
            assert!(seen <= self.index.len, "the list has a cycle or extra slots");
            prev = at;
            at = s.newer;
        }
        assert_eq!(prev, self.newest, "newest end");
        assert_eq!(seen, self.index.len, "listed vs indexed items");
        let indexed = self.index.map.len() + self.index.table.iter().filter(|&&i| i != NIL).count();
        assert_eq!(indexed, seen, "index entries vs items");
        assert_eq!(self.slots.len(), seen + self.free.len(), "slots leaked");
        for &f in &self.free {
            assert_eq!(self.slots[f as usize].older, FREED, "free slot {f} not marked");
        }
        if let Retention::LastN(n) = self.retention {
            assert!(self.index.len <= n, "more than {n} kept");
        }
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

    /// Recording only the tail `kept_of` gives of a round's distinct keys leaves the list
    /// as recording them all does, under either policy, whatever it held before.
    #[test]
    fn recording_the_kept_tail_is_recording_all() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for retention in [
            Retention::LastN(1),
            Retention::LastN(5),
            Retention::LastN(64),
            Retention::LastRounds(3),
        ] {
            let (mut all, mut tail) = (MemoryList::new(retention), MemoryList::new(retention));
            for round in 0..200u64 {
                // A round's keys: distinct, in increasing order (as robots seen, by id).
                let mut keys: Vec<u32> = (0..rng.random_range(0..120))
                    .map(|_| rng.random_range(0..300))
                    .collect();
                keys.sort_unstable();
                keys.dedup();
                for &k in &keys {
                    all.record(k, round * 1000 + u64::from(k), round);
                }
                for &k in tail.kept_of(&keys) {
                    tail.record(k, round * 1000 + u64::from(k), round);
                }
                all.evict(round);
                tail.evict(round);
                tail.assert_well_formed();
                let listed = |m: &MemoryList<u32, u64>| m.iter().map(|(v, r)| (*v, r)).collect::<Vec<_>>();
                assert_eq!(listed(&tail), listed(&all), "{retention:?}, round {round}");
            }
        }
    }

    #[test]
    fn memory_stays_bounded_under_repeated_sightings() {
        let mut m = MemoryList::new(Retention::LastN(10));
        for round in 0..10_000u64 {
            m.record(round % 7, round, round);
        }
        assert_eq!(m.len(), 7);
        assert_eq!(m.slots.len(), 7);
        m.assert_well_formed();
    }

    /// The list against a brute-force model (a vector of (key, item, round) in sighting
    /// order), through random records, forgets and evictions under both policies: small
    /// dense keys (a table), keys some of which are too large for the table (a table and a
    /// map), keys that are never dense (a map), and keys that move between them.
    #[test]
    fn matches_a_brute_force_model() {
        use rand::Rng;
        check_against_model(|rng| rng.random_range(0..12u8));
        check_against_model(|rng| [0, 1_000, 1_000_000_000][rng.random_range(0..3)] + rng.random_range(0..6u64));
        check_against_model(|rng| char::from(b'a' + rng.random_range(0..12u8)));
        // Keys that go to the map while the list is short and would fit the table once it
        // has grown (and the table grows past them).
        check_against_model(|rng| rng.random_range(0..200u32));
    }

    fn check_against_model<K: ListKey + std::fmt::Debug>(mut draw: impl FnMut(&mut rand_chacha::ChaCha8Rng) -> K) {
        use rand::{Rng, SeedableRng};
        for (seed, retention) in [
            (1, Retention::LastN(5)),
            (2, Retention::LastRounds(4)),
            (3, Retention::LastN(1)),
            (4, Retention::LastN(100)),
        ] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut list = MemoryList::new(retention);
            let mut model: Vec<(K, u32, u64)> = Vec::new();
            let mut round = 0;
            for step in 0..3_000u32 {
                round += u64::from(rng.random_bool(0.3));
                let key = draw(&mut rng);
                model.retain(|e| e.0 != key);
                if rng.random_bool(0.1) {
                    list.forget(key);
                } else {
                    list.record(key, step, round);
                    model.push((key, step, round));
                    // The model's eviction, after every record as the list's.
                    match retention {
                        Retention::LastN(n) => {
                            let excess = model.len().saturating_sub(n);
                            model.drain(..excess);
                        }
                        Retention::LastRounds(m) => model.retain(|e| e.2 + m >= round),
                    }
                }
                list.assert_well_formed();
                let got: Vec<_> = list.iter().map(|(v, r)| (*v, r)).collect();
                let want: Vec<_> = model.iter().map(|e| (e.1, e.2)).collect();
                assert_eq!(got, want, "seed {seed}, step {step}");
                assert_eq!(list.get(key).copied(), model.iter().find(|e| e.0 == key).map(|e| e.1));
                let odd = |v: &u32| v % 2 == 1;
                assert_eq!(
                    list.any(odd),
                    model.iter().any(|e| odd(&e.1)),
                    "seed {seed}, step {step}"
                );
            }
        }
    }
}
