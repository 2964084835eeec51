//! The navigation graph (paper §4.2): computed once per map, its nodes are the free leaves
//! of the obstacle quadtree and its edges join leaves that share a stretch of edge. A robot
//! may only use the nodes its known map touches; paths run through the midpoints of shared
//! edges ("portals").

use std::cell::RefCell;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::ops::ControlFlow;

use glam::DVec2;

use crate::spatial::geometry::Aabb;
use crate::spatial::grid::Grid;
use crate::spatial::known_map::KnownMap;
use crate::spatial::obstacle_map::ObstacleMap;
use crate::spatial::quadtree::Square;

/// A node of the navigation graph (a free quadtree leaf).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub struct NavNodeId(pub u32);

/// A [`NavGraph`] built on first use: most strategies never plan a route, and building the
/// graph of a million-leaf map takes seconds (issue 11). Thread-safe; every caller gets the
/// same graph whichever asks first, so results do not depend on the order.
#[derive(Debug, Default)]
pub struct LazyNavGraph(std::sync::OnceLock<NavGraph>);

impl LazyNavGraph {
    /// Not built yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The graph of `obstacles`, built now if nobody asked before. Always pass the same map.
    pub fn get_or_build(&self, obstacles: &ObstacleMap) -> &NavGraph {
        self.0.get_or_init(|| NavGraph::build(obstacles))
    }

    /// The graph if it has been built.
    pub fn get(&self) -> Option<&NavGraph> {
        self.0.get()
    }
}

/// Free leaves and their edge adjacency, in compressed sparse rows.
#[derive(Clone, Debug)]
pub struct NavGraph {
    grid: Grid,
    squares: Vec<Square>,
    /// Morton keys of the squares' lower-left cells, increasing (leaves in Z order).
    keys: Vec<u64>,
    starts: Vec<u32>,
    adjacent: Vec<u32>,
}

#[inline]
fn spread(v: u32) -> u64 {
    let mut x = u64::from(v);
    x = (x | (x << 16)) & 0x0000_FFFF_0000_FFFF;
    x = (x | (x << 8)) & 0x00FF_00FF_00FF_00FF;
    x = (x | (x << 4)) & 0x0F0F_0F0F_0F0F_0F0F;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    x = (x | (x << 1)) & 0x5555_5555_5555_5555;
    x
}

/// Z-order key of a cell (x in the even bits, matching the quadtree's child order).
#[inline]
fn morton(x: u32, y: u32) -> u64 {
    spread(x) | (spread(y) << 1)
}

/// A route found on the graph.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Route {
    /// Nodes from start to goal.
    pub nodes: Vec<NavNodeId>,
    /// Waypoints: the portals between consecutive nodes, then the goal point.
    pub waypoints: Vec<DVec2>,
    /// Length of the waypoint polyline from the start point, m.
    pub length_m: f64,
}

/// Search marks: the current stamp, and per node (stamp, distance, parent).
type Marks = (u32, Vec<(u32, f64, u32)>);

thread_local! {
    /// Per-thread search scratch, sized to the graph, reused across searches.
    static SCRATCH: RefCell<Marks> = const { RefCell::new((0, Vec::new())) };
}

impl NavGraph {
    /// Build from the obstacle map's free leaves.
    pub fn build(obstacles: &ObstacleMap) -> Self {
        let grid = *obstacles.grid();
        let mut squares = Vec::new();
        obstacles.tree().for_each_leaf(|sq, blocked| {
            if !blocked {
                squares.push(sq);
            }
        });
        let keys: Vec<u64> = squares.iter().map(|s| morton(s.x, s.y)).collect();
        debug_assert!(keys.windows(2).all(|w| w[0] < w[1]), "leaves come in Z order");
        let mut graph = Self {
            grid,
            squares,
            keys,
            starts: Vec::new(),
            adjacent: Vec::new(),
        };
        // East and north neighbours of every leaf; each edge is then stored both ways.
        let mut edges: Vec<(u32, u32)> = Vec::new();
        let half = 0.5 * grid.cell_m();
        for (i, sq) in graph.squares.iter().enumerate() {
            let s = sq.side_cells();
            let east = Aabb {
                min: grid.corner(sq.x + s, sq.y),
                max: grid.corner(sq.x + s, sq.y + s) + DVec2::new(half, 0.0),
            };
            let north = Aabb {
                min: grid.corner(sq.x, sq.y + s),
                max: grid.corner(sq.x + s, sq.y + s) + DVec2::new(0.0, half),
            };
            for strip in [east, north] {
                let _ = obstacles.tree().visit_leaves_in(&strip, false, |n, _| {
                    let j = graph.find(n).expect("free leaf is a node");
                    edges.push((i as u32, j.0));
                    edges.push((j.0, i as u32));
                    ControlFlow::Continue(())
                });
            }
        }
        edges.sort_unstable();
        graph.starts = vec![0; graph.squares.len() + 1];
        for &(a, _) in &edges {
            graph.starts[a as usize + 1] += 1;
        }
        for i in 0..graph.squares.len() {
            graph.starts[i + 1] += graph.starts[i];
        }
        graph.adjacent = edges.into_iter().map(|e| e.1).collect();
        graph
    }

    fn find(&self, sq: Square) -> Option<NavNodeId> {
        self.keys
            .binary_search(&morton(sq.x, sq.y))
            .ok()
            .filter(|&i| self.squares[i] == sq)
            .map(|i| NavNodeId(i as u32))
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.squares.len()
    }

    /// Whether the map has no free space.
    pub fn is_empty(&self) -> bool {
        self.squares.is_empty()
    }

    /// Number of (undirected) edges.
    pub fn edge_count(&self) -> usize {
        self.adjacent.len() / 2
    }

    /// The node whose square holds `p`, if `p` is in free space.
    pub fn node_at(&self, p: DVec2) -> Option<NavNodeId> {
        let (x, y) = self.grid.cell_of(p)?;
        let key = morton(x, y);
        let i = self.keys.partition_point(|&k| k <= key).checked_sub(1)?;
        let sq = self.squares[i];
        let s = sq.side_cells();
        (x >= sq.x && x < sq.x + s && y >= sq.y && y < sq.y + s).then_some(NavNodeId(i as u32))
    }

    /// A node's square.
    pub fn square(&self, n: NavNodeId) -> Square {
        self.squares[n.0 as usize]
    }

    /// A node's world box.
    pub fn bounds(&self, n: NavNodeId) -> Aabb {
        let sq = self.square(n);
        self.grid.square(sq.x, sq.y, sq.level)
    }

    /// A node's neighbours.
    pub fn neighbors(&self, n: NavNodeId) -> impl Iterator<Item = NavNodeId> + '_ {
        let (a, b) = (
            self.starts[n.0 as usize] as usize,
            self.starts[n.0 as usize + 1] as usize,
        );
        self.adjacent[a..b].iter().map(|&j| NavNodeId(j))
    }

    /// Midpoint of the edge stretch two adjacent nodes share.
    pub fn portal(&self, a: NavNodeId, b: NavNodeId) -> DVec2 {
        let (p, q) = (self.bounds(a), self.bounds(b));
        let lo = p.min.max(q.min);
        let hi = p.max.min(q.max);
        (lo + hi) * 0.5
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.squares.capacity() * std::mem::size_of::<Square>()
            + self.keys.capacity() * 8
            + (self.starts.capacity() + self.adjacent.capacity()) * 4
    }

    /// Dijkstra from the node holding `from` over nodes accepted by `usable`, until `is_goal`
    /// accepts a node; the route ends at the point `is_goal` returns for it. Edge costs are
    /// distances between portals, so routes through big open leaves cost what they measure.
    pub fn search(
        &self,
        from: DVec2,
        usable: impl FnMut(NavNodeId) -> bool,
        is_goal: impl FnMut(NavNodeId) -> Option<DVec2>,
        max_nodes: usize,
    ) -> Option<Route> {
        self.best_first(from, usable, is_goal, |_| 0.0, max_nodes)
    }

    /// [`search`](Self::search) ordered by distance so far plus `estimate` of the rest from
    /// a portal: Dijkstra with a zero estimate, A* with the straight line to a known goal.
    /// An estimate that never exceeds the length still to go, and never drops faster than
    /// the distance walked, finds the same shortest routes while settling far fewer nodes.
    fn best_first(
        &self,
        from: DVec2,
        mut usable: impl FnMut(NavNodeId) -> bool,
        mut is_goal: impl FnMut(NavNodeId) -> Option<DVec2>,
        estimate: impl Fn(DVec2) -> f64,
        max_nodes: usize,
    ) -> Option<Route> {
        let start = self.node_at(from)?;
        SCRATCH.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (stamp, marks) = &mut *guard;
            if marks.len() != self.squares.len() {
                // All zero bytes, so the allocator hands out pages the kernel maps only
                // when a search first writes them: searches stay local, and a marked copy
                // of a ten-million-node graph per thread cost the moonshot 200 MB and a
                // tenth of its first rounds in page clearing (issue 11). A node's parent
                // is read only once it carries the search's stamp (never 0).
                *marks = vec![(0, 0.0, 0); self.squares.len()];
                *stamp = 0;
            }
            *stamp = stamp.wrapping_add(1);
            if *stamp == 0 {
                for m in marks.iter_mut() {
                    m.0 = 0;
                }
                *stamp = 1;
            }
            let stamp = *stamp;
            // Where the search enters each node (portal or start), for edge costs, and the
            // distance walked to get there.
            let mut entry: Vec<(DVec2, f64)> = vec![(from, 0.0)];
            let mut heap = BinaryHeap::new();
            marks[start.0 as usize] = (stamp, 0.0, u32::MAX);
            heap.push(Reverse((OrdF64(estimate(from)), start.0, 0u32)));
            let mut settled = 0usize;
            while let Some(Reverse((_, n, e))) = heap.pop() {
                let node = NavNodeId(n);
                let (at, d) = entry[e as usize];
                if d > marks[n as usize].1 {
                    continue;
                }
                settled += 1;
                if let Some(goal) = is_goal(node) {
                    let mut nodes = vec![node];
                    let mut cur = n;
                    while marks[cur as usize].2 != u32::MAX {
                        cur = marks[cur as usize].2;
                        nodes.push(NavNodeId(cur));
                    }
                    nodes.reverse();
                    let mut waypoints: Vec<DVec2> = nodes.windows(2).map(|w| self.portal(w[0], w[1])).collect();
                    waypoints.push(goal);
                    let mut length_m = 0.0;
                    let mut prev = from;
                    for w in &waypoints {
                        length_m += prev.distance(*w);
                        prev = *w;
                    }
                    return Some(Route {
                        nodes,
                        waypoints,
                        length_m,
                    });
                }
                if settled >= max_nodes {
                    return None;
                }
                for m in self.neighbors(node) {
                    let p = self.portal(node, m);
                    let nd = d + at.distance(p);
                    let mark = marks[m.0 as usize];
                    // Only nodes found usable are ever stamped, so the test runs once a node.
                    let better = if mark.0 == stamp { nd < mark.1 } else { usable(m) };
                    if better {
                        marks[m.0 as usize] = (stamp, nd, n);
                        entry.push((p, nd));
                        heap.push(Reverse((OrdF64(nd + estimate(p)), m.0, (entry.len() - 1) as u32)));
                    }
                }
            }
            None
        })
    }

    /// Shortest route from `from` to `to` through nodes the known map touches.
    pub fn route_within(&self, known: &KnownMap, from: DVec2, to: DVec2, max_nodes: usize) -> Option<Route> {
        let goal = self.node_at(to)?;
        // A goal the known map does not touch is never reached (only the start is exempt
        // from that test): say so now instead of searching everything known first (issue
        // 12: workers heading for treasures they only heard of spent 18 % of bench-1000's
        // time on such searches).
        if self.node_at(from) != Some(goal) && !known.touches_square(self.square(goal)) {
            return None;
        }
        // A*: the straight line to `to` is never longer than a route's rest, and shrinks by
        // at most what a step walks (issue 12: workers re-planning to treasures and energy
        // management measuring the way home were 22 % of a bench-1000 round with Dijkstra).
        self.best_first(
            from,
            |n| known.touches_square(self.square(n)),
            |n| (n == goal).then_some(to),
            |p| p.distance(to),
            max_nodes,
        )
    }
}

/// f64 ordered by `total_cmp`, for the search heap (ties broken by node id: deterministic).
#[derive(Clone, Copy, Debug, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn maze() -> ObstacleMap {
        // 16 × 16 with a wall at x = 8 open only at y = 14.
        let grid = Grid::new(DVec2::ZERO, 1.0, 16, 16).unwrap();
        ObstacleMap::from_fn(grid, |x, y| x == 8 && y != 14)
    }

    #[test]
    fn graph_edges_match_cell_adjacency() {
        let map = maze();
        let g = NavGraph::build(&map);
        // Every free cell lies in exactly one node; two free cells that share an edge lie in
        // the same node or in adjacent nodes.
        for y in 0..16 {
            for x in 0..16 {
                let p = map.grid().cell_center(x, y);
                let n = g.node_at(p);
                assert_eq!(n.is_some(), map.is_point_free(p), "cell ({x}, {y})");
                if let (Some(a), Some(b)) = (n, g.node_at(p + DVec2::X)) {
                    assert!(a == b || g.neighbors(a).any(|m| m == b), "({x}, {y}) east");
                }
                if let (Some(a), Some(b)) = (n, g.node_at(p + DVec2::Y)) {
                    assert!(a == b || g.neighbors(a).any(|m| m == b), "({x}, {y}) north");
                }
            }
        }
        for i in 0..g.len() {
            let a = NavNodeId(i as u32);
            for b in g.neighbors(a) {
                assert!(g.neighbors(b).any(|c| c == a), "asymmetric edge");
            }
        }
    }

    #[test]
    fn route_goes_through_the_door() {
        let map = maze();
        let g = NavGraph::build(&map);
        let mut known = KnownMap::new(*map.grid());
        known.mark(&map.grid().extent());
        let from = DVec2::new(2.5, 2.5);
        let to = DVec2::new(13.5, 2.5);
        let r = g.route_within(&known, from, to, usize::MAX).unwrap();
        // Must pass the door cell (8, 14): at least up to y = 14 and back.
        assert!(
            r.waypoints.iter().any(|w| w.y >= 14.0 && (w.x - 8.5).abs() <= 1.0),
            "{r:?}"
        );
        // No path is shorter than the taut string through the door's corners:
        // |(2.5,2.5)-(8,14)| + 1 + |(9,14)-(13.5,2.5)| = 12.747 + 1 + 12.349.
        let taut = DVec2::new(2.5, 2.5).distance(DVec2::new(8.0, 14.0)) + 1.0 + DVec2::new(9.0, 14.0).distance(to);
        assert!(
            r.length_m >= taut - 1e-9 && r.length_m < 1.2 * taut,
            "{} vs {taut}",
            r.length_m
        );
        // Straight segments between waypoints stay in free space.
        let mut prev = from;
        for w in &r.waypoints {
            assert!(map.is_segment_free(prev, *w), "{prev} → {w}");
            prev = *w;
        }
        // Unknown terrain is off limits.
        let mut half = KnownMap::new(*map.grid());
        half.mark(&Aabb::from_corners(DVec2::ZERO, DVec2::new(8.0, 16.0)));
        assert!(g.route_within(&half, from, to, usize::MAX).is_none());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..proptest::prelude::ProptestConfig::default() })]

        /// Issue 12: A* (`route_within`) finds a route exactly when a Dijkstra search over
        /// the same known nodes does, never longer than it, never shorter than the straight
        /// line, and along segments free of obstacles.
        #[test]
        fn a_star_routes_match_dijkstra(
            cells in proptest::collection::vec(proptest::bool::weighted(0.3), 256),
            known_to in (4u32..=16, 4u32..=16),
            from in (0u32..16, 0u32..16),
            to in (0u32..16, 0u32..16),
        ) {
            let grid = Grid::new(DVec2::ZERO, 1.0, 16, 16).unwrap();
            let map = ObstacleMap::from_fn(grid, |x, y| cells[(y * 16 + x) as usize]);
            let g = NavGraph::build(&map);
            let mut known = KnownMap::new(grid);
            known.mark(&Aabb::from_corners(DVec2::ZERO, DVec2::new(f64::from(known_to.0), f64::from(known_to.1))));
            let from = grid.cell_center(from.0, from.1) + DVec2::new(0.1, -0.2);
            let to = grid.cell_center(to.0, to.1) + DVec2::new(-0.3, 0.15);
            let a_star = g.route_within(&known, from, to, usize::MAX);
            let dijkstra = g.node_at(to).and_then(|goal| {
                g.search(from, |n| known.touches_square(g.square(n)), |n| (n == goal).then_some(to), usize::MAX)
            });
            proptest::prop_assert_eq!(a_star.is_some(), dijkstra.is_some());
            if let (Some(a), Some(d)) = (a_star, dijkstra) {
                proptest::prop_assert!(a.length_m <= d.length_m + 1e-9, "{} > {}", a.length_m, d.length_m);
                proptest::prop_assert!(a.length_m >= from.distance(to) - 1e-9);
                let mut prev = from;
                for w in &a.waypoints {
                    proptest::prop_assert!(map.is_segment_free(prev, *w), "{} -> {}", prev, w);
                    prev = *w;
                }
                proptest::prop_assert_eq!(prev, to);
            }
        }
    }
}
