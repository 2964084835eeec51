//! A robot's frontier, kept up to date by what changed (issue 12, item 3).
//!
//! A node of the navigation graph is a frontier of a known map when the map touches it and
//! it is partly unknown, or borders a node the map does not touch at all: where walking
//! on reveals something. Whether a node is one depends only on which of its own cells and
//! its neighbours' cells are known, so after the map changes only the nodes that meet a
//! changed cell, and their neighbours, can change. [`Frontier::sync`] reads the known map's
//! [`TileLog`](crate::spatial::TileLog) for the tiles changed since it last looked and
//! tests those nodes again; a frontier search then asks the set instead of the known map.

use std::cell::RefCell;
use std::collections::{BTreeSet, HashSet};

use super::{NavGraph, NavNodeId};
use crate::spatial::known_map::KnownMap;
use crate::spatial::tile_log::LogMark;

thread_local! {
    /// Per-thread marks of the nodes a sync has queued, sized to the graph: (stamp, marks).
    static SEEN: RefCell<(u32, Vec<u32>)> = const { RefCell::new((0, Vec::new())) };
}

/// The frontier nodes of one known map.
#[derive(Clone, Debug, Default)]
pub struct Frontier {
    nodes: HashSet<u32, foldhash::fast::FixedState>,
    /// How far the known map's log has been read (`None`: never, so build from scratch).
    read: Option<LogMark>,
}

impl Frontier {
    /// Whether node `n` is a frontier of `known` (the definition the set keeps to).
    pub fn is_frontier(nav: &NavGraph, known: &KnownMap, n: NavNodeId) -> bool {
        nav.touched_by(known, n) && (!nav.covered_by(known, n) || nav.neighbors(n).any(|m| !nav.touched_by(known, m)))
    }

    /// Every frontier node of `known`, worked out from scratch: each node a known leaf meets
    /// is tested.
    pub fn from_scratch(nav: &NavGraph, known: &KnownMap) -> BTreeSet<NavNodeId> {
        let mut candidates = Vec::new();
        known.tree().for_each_leaf(|sq, value| {
            if value {
                nav.for_each_node_meeting(sq, |n| candidates.push(n));
            }
        });
        candidates
            .into_iter()
            .filter(|&n| Self::is_frontier(nav, known, n))
            .collect()
    }

    /// Bring the set up to date with `known`, turning its change log on if it is off (the
    /// first call, and a call after the map was replaced or restored, start from scratch).
    pub fn sync(&mut self, nav: &NavGraph, known: &mut KnownMap) {
        known.track_changes();
        let log = known.change_log().expect("the log was just turned on");
        let Some(mark) = self.read else {
            self.nodes = Self::from_scratch(nav, known).into_iter().map(|n| n.0).collect();
            self.read = Some(log.mark());
            return;
        };
        SEEN.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (stamp, seen) = &mut *guard;
            if seen.len() != nav.len() {
                *seen = vec![0; nav.len()];
                *stamp = 0;
            }
            *stamp = stamp.wrapping_add(1);
            if *stamp == 0 {
                seen.fill(0);
                *stamp = 1;
            }
            let stamp = *stamp;
            // The nodes meeting a changed tile, each once (tiles hold many leaves of few
            // pieces), then their neighbours.
            let mut check: Vec<NavNodeId> = Vec::new();
            let mut first = |n: NavNodeId, check: &mut Vec<NavNodeId>| {
                if seen[n.0 as usize] != stamp {
                    seen[n.0 as usize] = stamp;
                    check.push(n);
                }
            };
            let read = log.changed_since(mark, |tile| nav.for_each_node_meeting(tile, |n| first(n, &mut check)));
            if !read {
                self.nodes = Self::from_scratch(nav, known).into_iter().map(|n| n.0).collect();
                return;
            }
            for i in 0..check.len() {
                for m in nav.neighbors(check[i]) {
                    first(m, &mut check);
                }
            }
            for n in check {
                if Self::is_frontier(nav, known, n) {
                    self.nodes.insert(n.0);
                } else {
                    self.nodes.remove(&n.0);
                }
            }
        });
        self.read = Some(log.mark());
    }

    /// Whether `n` is in the set (as of the last [`sync`](Self::sync)).
    pub fn contains(&self, n: NavNodeId) -> bool {
        self.nodes.contains(&n.0)
    }

    /// The nodes in the set, in id order.
    pub fn nodes(&self) -> BTreeSet<NavNodeId> {
        self.nodes.iter().map(|&n| NavNodeId(n)).collect()
    }

    /// Number of frontier nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether there is no frontier left.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}
