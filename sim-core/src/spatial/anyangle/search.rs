//! A* on the visibility graph, with the start and the goal joined to the corners they see.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use glam::DVec2;

use super::build::grazes;
use super::{AnyAnglePath, AnyAnglePlanner, NoPath, Vertex, anya};

/// A heap entry: estimated total length, then node (for a deterministic order among ties),
/// and whether it is a link from the start not yet checked for sight.
#[derive(Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    node: u32,
    unchecked: bool,
}

impl Eq for Open {}

impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        self.f
            .total_cmp(&other.f)
            .then(self.node.cmp(&other.node))
            .then(self.unchecked.cmp(&other.unchecked))
    }
}

const NONE: u32 = u32::MAX;

/// A search's best lengths so far, the corners they come through, and the open entries.
struct Front {
    dist: Vec<f64>,
    parent: Vec<u32>,
    open: BinaryHeap<Reverse<Open>>,
    goal: DVec2,
}

impl Front {
    /// Reach `node` (at `at`) through `via` with length `d`, if that is shorter.
    fn relax(&mut self, node: usize, at: DVec2, via: u32, d: f64) {
        if d < self.dist[node] {
            self.dist[node] = d;
            self.parent[node] = via;
            self.open.push(Reverse(Open {
                f: d + at.distance(self.goal),
                node: u32::try_from(node).expect("at most MAX_VERTICES corners"),
                unchecked: false,
            }));
        }
    }
}

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
        if let Some(regions) = &self.regions {
            // Ends in different regions: no search (it would sweep the start's region).
            if regions.of_point(s) != regions.of_point(g) {
                return Err(NoPath::Unreachable(from, to));
            }
            match self.anya_path(from, to) {
                Some(Ok(path)) => return Ok(path),
                // A path exists between ends in one 4-connected region: an Anya bug. Tests
                // (debug assertions on) stop here; a release build asks the visibility graph.
                Some(Err(_)) => debug_assert!(false, "Anya finds no path from {s} to {g} in one region"),
                // A leg failed the exact sight test or the search gave up: the visibility
                // graph decides.
                None => {}
            }
        }
        self.graph_path(from, to)
    }

    /// A point robot's shortest path by Anya (`anya`): the answer, or `None` if a leg of the
    /// path it found fails the exact sight test or the search gave up. The ends must be
    /// checked already.
    pub(crate) fn anya_path(&self, from: DVec2, to: DVec2) -> Option<Result<AnyAnglePath, NoPath>> {
        let (s, g) = (self.to_cells(from), self.to_cells(to));
        let corners = match anya::shortest(&self.raster, s, g) {
            anya::Outcome::Found(corners) => corners,
            anya::Outcome::Unreachable => return Some(Err(NoPath::Unreachable(from, to))),
            anya::Outcome::GaveUp => return None,
        };
        let mut prev = s;
        for &c in corners.iter().chain(std::iter::once(&g)) {
            if !self.clear(prev, c) {
                return None;
            }
            prev = c;
        }
        let mut waypoints = Vec::with_capacity(corners.len() + 2);
        waypoints.push(from);
        waypoints.extend(corners.iter().map(|&c| self.to_world(c)));
        waypoints.push(to);
        let length_m = waypoints.windows(2).map(|w| w[0].distance(w[1])).sum();
        Some(Ok(AnyAnglePath { waypoints, length_m }))
    }

    /// The shortest path by A* over the visibility graph of the (grown) corners: robots with
    /// a radius, point robots should Anya fail, and the reference the tests hold Anya to.
    /// The ends must be checked already and not see each other. A point robot's planner
    /// builds the graph first, and answers [`NoPath::Undecided`] if it would have more than
    /// [`MAX_VERTICES`](super::MAX_VERTICES) corners.
    pub(crate) fn graph_path(&self, from: DVec2, to: DVec2) -> Result<AnyAnglePath, NoPath> {
        let Some(graph) = self.graph() else {
            return Err(NoPath::Undecided(from, to));
        };
        let vertices = &graph.vertices;
        let (s, g) = (self.to_cells(from), self.to_cells(to));
        let n = vertices.len();
        // Node n is the goal. The start is the root and never re-entered.
        let mut closed = vec![false; n + 1];
        // Every corner the start might see enters unchecked; its sight line is tested only
        // if the search takes it (it is then the best way to that corner, or the test fails
        // and the corner waits for another way in).
        let open = (0..n)
            .filter(|&i| grazes(vertices[i].quadrant, s - vertices[i].pos))
            .map(|i| {
                let at = vertices[i].pos;
                Reverse(Open {
                    f: s.distance(at) + at.distance(g),
                    node: u32::try_from(i).expect("at most MAX_VERTICES corners"),
                    unchecked: true,
                })
            })
            .collect();
        let mut front = Front {
            dist: vec![f64::INFINITY; n + 1],
            parent: vec![NONE; n + 1],
            open,
            goal: g,
        };
        while let Some(Reverse(Open { node, unchecked, .. })) = front.open.pop() {
            let u = node as usize;
            if closed[u] {
                continue;
            }
            if unchecked {
                // Entries with a shorter way to `u` came first (and closed it): this one is
                // the best, if the start does see `u`.
                let at = vertices[u].pos;
                if !self.clear(s, at) {
                    continue;
                }
                front.dist[u] = s.distance(at);
                front.parent[u] = NONE;
            }
            closed[u] = true;
            if u == n {
                return Ok(self.trace(vertices, from, to, &front.parent));
            }
            let (pu, du) = (vertices[u].pos, front.dist[u]);
            // Whether a corner sees the goal is asked only when the search expands it (once).
            if grazes(vertices[u].quadrant, g - pu) && self.clear(g, pu) {
                front.relax(n, g, node, du + pu.distance(g));
            }
            for &v in self.neighbours(graph, u) {
                let v = v as usize;
                if !closed[v] {
                    let at = vertices[v].pos;
                    front.relax(v, at, node, du + pu.distance(at));
                }
            }
        }
        Err(NoPath::Unreachable(from, to))
    }

    /// The path found by a search, from the goal's parents back to the start.
    fn trace(&self, vertices: &[Vertex], from: DVec2, to: DVec2, parent: &[u32]) -> AnyAnglePath {
        let mut waypoints = vec![to];
        let mut at = parent[vertices.len()];
        while at != NONE {
            waypoints.push(self.to_world(vertices[at as usize].pos));
            at = parent[at as usize];
        }
        waypoints.push(from);
        waypoints.reverse();
        let length_m = waypoints.windows(2).map(|w| w[0].distance(w[1])).sum();
        AnyAnglePath { waypoints, length_m }
    }
}
