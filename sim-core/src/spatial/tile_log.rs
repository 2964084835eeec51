//! Which coarse tiles of a known map changed, and when (issue 12, item 3): what lets a
//! robot's frontier be kept up to date by looking only at what changed since it last did.
//!
//! Tiles are aligned squares of [`TILE_LEVEL`] (32 × 32 cells). Every mutation of a
//! tracking known map starts a new epoch and stamps the tiles its new cells lie in. A
//! reader keeps a [`LogMark`] (the log's identity and the epoch it read up to) and asks
//! for the tiles stamped after it. A log is one map's: a copy of a known map starts a new
//! log, and a reader holding a mark of another log must start over.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::spatial::quadtree::Square;

/// Level of the tiles: 2⁵ = 32 cells a side.
pub const TILE_LEVEL: u8 = 5;

/// Identities of logs: only ever compared, so their values do not affect any result.
static NEXT_LOG: AtomicU64 = AtomicU64::new(1);

/// How far a reader has read a [`TileLog`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogMark {
    log: u64,
    epoch: u64,
}

/// Tiles of a known map stamped with the epoch they last changed in.
#[derive(Debug)]
pub struct TileLog {
    id: u64,
    epoch: u64,
    /// Tile (column, row, in tiles) → epoch of its last change.
    tiles: HashMap<(u32, u32), u64, foldhash::fast::FixedState>,
    /// The tile stamped last (most changes come in runs within one tile).
    last: Option<(u32, u32)>,
}

impl Default for TileLog {
    fn default() -> Self {
        Self {
            id: NEXT_LOG.fetch_add(1, Ordering::Relaxed),
            epoch: 1,
            tiles: HashMap::default(),
            last: None,
        }
    }
}

impl Clone for TileLog {
    /// A new, empty log: a copy of a known map is another map to its readers.
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl TileLog {
    /// Start a mutation: what it stamps is newer than every mark handed out so far.
    pub fn begin(&mut self) {
        self.epoch += 1;
        self.last = None;
    }

    /// Stamp every tile `sq` meets.
    pub fn stamp(&mut self, sq: Square) {
        let t = u32::from(TILE_LEVEL);
        if sq.level <= TILE_LEVEL {
            let tile = (sq.x >> t, sq.y >> t);
            if self.last != Some(tile) {
                self.tiles.insert(tile, self.epoch);
                self.last = Some(tile);
            }
            return;
        }
        let n = 1u32 << (sq.level - TILE_LEVEL);
        for ty in (sq.y >> t)..(sq.y >> t) + n {
            for tx in (sq.x >> t)..(sq.x >> t) + n {
                self.tiles.insert((tx, ty), self.epoch);
            }
        }
        self.last = None;
    }

    /// Where a reader that has seen everything so far stands.
    pub fn mark(&self) -> LogMark {
        LogMark {
            log: self.id,
            epoch: self.epoch,
        }
    }

    /// Visit the tiles (as squares of cells) stamped after `mark`; `false` (visiting
    /// nothing) if `mark` is another log's.
    pub fn changed_since(&self, mark: LogMark, mut visit: impl FnMut(Square)) -> bool {
        if mark.log != self.id {
            return false;
        }
        let t = u32::from(TILE_LEVEL);
        for (&(tx, ty), &epoch) in &self.tiles {
            if epoch > mark.epoch {
                visit(Square {
                    x: tx << t,
                    y: ty << t,
                    level: TILE_LEVEL,
                });
            }
        }
        true
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.tiles.capacity() * (std::mem::size_of::<((u32, u32), u64)>() + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sq(x: u32, y: u32, level: u8) -> Square {
        Square { x, y, level }
    }

    fn changed(log: &TileLog, mark: LogMark) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        assert!(log.changed_since(mark, |s| v.push((s.x, s.y))));
        v.sort_unstable();
        v
    }

    #[test]
    fn readers_see_the_tiles_stamped_after_their_mark() {
        let mut log = TileLog::default();
        log.begin();
        log.stamp(sq(3, 40, 0));
        let first = log.mark();
        assert!(changed(&log, first).is_empty());
        log.begin();
        log.stamp(sq(64, 0, 3));
        // A square of 4 × 4 tiles.
        log.stamp(sq(128, 128, 7));
        let seen = changed(&log, first);
        assert_eq!(seen.len(), 1 + 16);
        assert!(seen.contains(&(64, 0)) && seen.contains(&(128, 128)) && seen.contains(&(224, 224)));
        assert!(!seen.contains(&(0, 32)));
        // Stamped again later: seen again by the first reader, not by a newer one.
        let second = log.mark();
        log.begin();
        log.stamp(sq(0, 32, 1));
        assert_eq!(changed(&log, second), [(0, 32)]);
        assert!(changed(&log, first).contains(&(0, 32)));
    }

    #[test]
    fn a_copy_is_another_log() {
        let log = TileLog::default();
        let copy = log.clone();
        assert!(!copy.changed_since(log.mark(), |_| {}));
        assert!(log.changed_since(log.mark(), |_| {}));
    }
}
