//! A* on the visibility graph, with the start and the goal joined to the corners they see.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use glam::DVec2;

use super::build::grazes;
use super::{AnyAnglePath, AnyAnglePlanner, NoPath};

/// A heap entry: estimated total length, then node (for a deterministic order among ties).
#[derive(Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    node: u32,
}

impl Eq for Open {}

impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        self.f.total_cmp(&other.f).then(self.node.cmp(&other.node))
    }
}

const NONE: u32 = u32::MAX;

impl AnyAnglePlanner {
    /// The shortest path from `from` to `to` (world coordinates, metres) for the planner's
    /// robots, or why there is none.
    pub fn path(&self, from: DVec2, to: DVec2) -> Result<AnyAnglePath, NoPath> {
        let (s, g) = (self.to_cells(from), self.to_cells(to));
        if !self.stand_clear(s) {
            return Err(NoPath::StartBlocked(from));
        }
        if !self.stand_clear(g) {
            return Err(NoPath::GoalBlocked(to));
        }
        if self.clear(s, g) {
            return Ok(AnyAnglePath {
                waypoints: if s == g { vec![from] } else { vec![from, to] },
                length_m: from.distance(to),
            });
        }
        let n = self.vertices.len();
        // Node n is the goal. The start is the root and never re-entered.
        let sees = |p: DVec2, i: usize| {
            let v = self.vertices[i];
            grazes(v.quadrant, p - v.pos) && self.clear(p, v.pos)
        };
        // Whether a corner sees the goal is asked only of corners the search expands.
        let mut sees_goal = vec![None::<bool>; n];
        let mut dist = vec![f64::INFINITY; n + 1];
        let mut parent = vec![NONE; n + 1];
        let mut closed = vec![false; n + 1];
        let mut open = BinaryHeap::new();
        let mut relax = |open: &mut BinaryHeap<Reverse<Open>>, dist: &mut [f64], node: usize, via: u32, d: f64| {
            if d < dist[node] {
                dist[node] = d;
                parent[node] = via;
                let at = if node == n { g } else { self.vertices[node].pos };
                let node = u32::try_from(node).expect("vertex count is bounded");
                open.push(Reverse(Open {
                    f: d + at.distance(g),
                    node,
                }));
            }
        };
        for i in 0..n {
            if sees(s, i) {
                relax(&mut open, &mut dist, i, NONE, s.distance(self.vertices[i].pos));
            }
        }
        while let Some(Reverse(Open { node, .. })) = open.pop() {
            let u = node as usize;
            if closed[u] {
                continue;
            }
            closed[u] = true;
            if u == n {
                return Ok(self.trace(from, to, &parent));
            }
            let (pu, du) = (self.vertices[u].pos, dist[u]);
            if *sees_goal[u].get_or_insert_with(|| sees(g, u)) {
                relax(&mut open, &mut dist, n, node, du + pu.distance(g));
            }
            for &v in &self.adjacent[self.starts[u] as usize..self.starts[u + 1] as usize] {
                let v = v as usize;
                if !closed[v] {
                    relax(&mut open, &mut dist, v, node, du + pu.distance(self.vertices[v].pos));
                }
            }
        }
        Err(NoPath::Unreachable(from, to))
    }

    /// The path found by a search, from the goal's parents back to the start.
    fn trace(&self, from: DVec2, to: DVec2, parent: &[u32]) -> AnyAnglePath {
        let mut waypoints = vec![to];
        let mut at = parent[self.vertices.len()];
        while at != NONE {
            waypoints.push(self.to_world(self.vertices[at as usize].pos));
            at = parent[at as usize];
        }
        waypoints.push(from);
        waypoints.reverse();
        let length_m = waypoints.windows(2).map(|w| w[0].distance(w[1])).sum();
        AnyAnglePath { waypoints, length_m }
    }
}
