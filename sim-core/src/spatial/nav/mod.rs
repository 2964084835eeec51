//! The navigation graph (paper §4.2): computed once per map, its nodes are convex pieces of
//! free space (the obstacle quadtree's free leaves merged into rectangles, [`pieces`]) and
//! its edges join pieces that share a stretch of edge (a "portal"). A robot may only use
//! the nodes its known map touches. Searches order nodes by the walk through the nearest
//! points of their portals; the route found is then pulled taut through its corridor of
//! nodes ([`funnel`]), so robots walk straight lines that bend only at corners of the
//! corridor, keeping their radius clear of them.

use std::cell::RefCell;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::ops::ControlFlow;

use glam::DVec2;
use rayon::prelude::*;

use crate::spatial::geometry::Aabb;
use crate::spatial::grid::Grid;
use crate::spatial::known_map::KnownMap;
use crate::spatial::obstacle_map::{MAX_LEG_BLOCKS, ObstacleMap};
use crate::spatial::quadtree::{Finger, Square};

/// Free leaves a task of [`NavGraph::build`]'s edge search takes.
const LEAVES_A_TASK: usize = 4096;

/// Who builds a [`NavGraph`]: the current rayon pool's workers, or the calling thread alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Workers {
    All,
    One,
}

impl Workers {
    /// Sort `v` (keys distinct or not: equal keys are equal values, so the result is the
    /// same either way).
    fn sort<T: Ord + Send>(self, v: &mut [T]) {
        match self {
            Self::All => v.par_sort_unstable(),
            Self::One => v.sort_unstable(),
        }
    }

    /// The least number of tasks (items of a parallel iterator) one job takes: 1 for
    /// [`All`](Self::All); for [`One`](Self::One) all of them, in one job on the calling
    /// thread, which then never splits nor waits.
    fn tasks_a_job(self) -> usize {
        match self {
            Self::All => 1,
            Self::One => usize::MAX,
        }
    }
}

mod corridor;
mod funnel;
mod memo;
mod pieces;

use funnel::Portal;
pub use memo::PieceMemo;
pub use pieces::Piece;

/// A node of the navigation graph (a piece of free space).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub struct NavNodeId(pub u32);

/// A [`NavGraph`] built on first use: most strategies never plan a route, and building the
/// graph of a large map is costly. Thread-safe; every caller gets the same graph whichever
/// asks first, so results do not depend on the order.
#[derive(Debug, Default)]
pub struct LazyNavGraph(std::sync::OnceLock<NavGraph>);

impl LazyNavGraph {
    /// Not built yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The graph of `obstacles`, built now on this thread alone if nobody asked before
    /// ([`NavGraph::build_on_this_thread`]). Always pass the same map. Strategies ask in a
    /// round's parallel step: a build that shared its work with the pool could, while it
    /// waits, be handed another robot's turn asking for the graph it is building.
    pub fn get_or_build(&self, obstacles: &ObstacleMap) -> &NavGraph {
        self.0.get_or_init(|| NavGraph::build_on_this_thread(obstacles))
    }

    /// [`get_or_build`](Self::get_or_build) for callers outside any parallel step (a
    /// simulation's set-up): the build runs on the current rayon pool's workers
    /// ([`NavGraph::build`]). The same graph.
    pub fn get_or_build_on_all_workers(&self, obstacles: &ObstacleMap) -> &NavGraph {
        self.0.get_or_init(|| NavGraph::build(obstacles))
    }

    /// The graph if it has been built.
    pub fn get(&self) -> Option<&NavGraph> {
        self.0.get()
    }
}

/// Pieces of free space and their edge adjacency, in compressed sparse rows.
#[derive(Clone, Debug)]
pub struct NavGraph {
    grid: Grid,
    pieces: Vec<Piece>,
    /// The free leaves, to find the piece holding a point: Morton keys of their lower-left
    /// cells, increasing (Z order), their levels and their pieces.
    keys: Vec<u64>,
    /// Where the keys of each Z-order prefix (`key >> prefix_shift`) start in `keys`, and
    /// where the last one ends: a point's leaf is looked for among a few dozen keys, not
    /// by a binary search of all of them.
    key_starts: Vec<u32>,
    prefix_shift: u32,
    levels: Vec<u8>,
    piece_of: Vec<u32>,
    /// Each node's number in the order pieces are merged (see [`pieces::merge`]): searches
    /// break ties and list neighbours in that order, so routes do not depend on the ids.
    rank: Vec<u32>,
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

/// The even bits of `v`, packed.
#[inline]
fn gather(v: u64) -> u32 {
    let mut x = v & 0x5555_5555_5555_5555;
    x = (x | (x >> 1)) & 0x3333_3333_3333_3333;
    x = (x | (x >> 2)) & 0x0F0F_0F0F_0F0F_0F0F;
    x = (x | (x >> 4)) & 0x00FF_00FF_00FF_00FF;
    x = (x | (x >> 8)) & 0x0000_FFFF_0000_FFFF;
    x = (x | (x >> 16)) & 0x0000_0000_FFFF_FFFF;
    u32::try_from(x).expect("32 bits")
}

/// The cell of a Z-order key.
#[inline]
fn unmorton(key: u64) -> (u32, u32) {
    (gather(key), gather(key >> 1))
}

/// A goal found by [`NavGraph::search_cheapest_goals`].
#[derive(Clone, Debug, PartialEq)]
pub struct FoundGoal {
    /// The walk to the goal's node, on in a straight line to the goal point, plus the
    /// search's bias of the point, m.
    pub cost_m: f64,
    /// Nodes from start to goal.
    pub nodes: Vec<NavNodeId>,
    /// The goal point.
    pub point: DVec2,
}

/// A route found on the graph.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Route {
    /// Nodes from start to goal.
    pub nodes: Vec<NavNodeId>,
    /// Waypoints: where the route bends, then the goal point.
    pub waypoints: Vec<DVec2>,
    /// Length of the waypoint polyline from the start point, m.
    pub length_m: f64,
}

/// The terrain a robot plans in: the map the graph was built from, the robot's known map
/// (routes use nodes it touches, and cut corners only across cells it knows), and the
/// radius the route keeps clear.
#[derive(Clone, Copy, Debug)]
pub struct Terrain<'a> {
    /// The map the graph was built from.
    pub obstacles: &'a ObstacleMap,
    /// What the walking robot knows of it.
    pub known: &'a KnownMap,
    /// The walking robot's radius, m (0 for a point).
    pub radius_m: f64,
}

impl Terrain<'_> {
    /// The clearance a route's legs keep: the radius, and a twentieth of a cell more, so
    /// that a robot nudged off its line (by collision avoidance, say) does not end up
    /// pressed against the corner its route bends round.
    fn clearance_m(&self) -> f64 {
        self.radius_m + 0.05 * self.obstacles.grid().cell_m()
    }

    /// Whether the robot's disc, widened to the clearance, may sweep straight from `a` to `b`.
    fn leg_clear(&self, a: DVec2, b: DVec2) -> bool {
        self.obstacles.is_swept_disc_free(a, b, self.clearance_m())
    }

    /// Whether a leg from `a` to `b` may be hoped for, taking unknown terrain as open: no
    /// cell the robot knows to be blocked lies within its radius of the leg (a blocked leaf
    /// that meets the leg counts when the robot knows one of its cells within the leg's
    /// bounding box; what the robot has not seen never enters the answer).
    pub fn hopeful(&self, a: DVec2, b: DVec2) -> bool {
        let swept = crate::spatial::geometry::Capsule {
            a,
            b,
            radius: self.radius_m,
        };
        let grid = self.obstacles.grid();
        let Some((lo, hi)) = grid.cells_touching(&crate::spatial::geometry::Shape::bounds(&swept)) else {
            return false;
        };
        self.obstacles
            .visit_blocked(&swept, |sq, _| {
                let side = sq.side_cells();
                let (x0, y0) = (sq.x.max(lo.0), sq.y.max(lo.1));
                let (x1, y1) = ((sq.x + side - 1).min(hi.0), (sq.y + side - 1).min(hi.1));
                if x0 <= x1 && y0 <= y1 && self.known.touches_cells((x0, y0), (x1, y1)) {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })
            .is_continue()
    }

    /// Whether a leg from `a` to `b` that no route proposed may be walked: clear, and over
    /// known cells only.
    fn shortcut_clear(&self, a: DVec2, b: DVec2) -> bool {
        let swept = crate::spatial::geometry::Capsule {
            a,
            b,
            radius: self.radius_m,
        };
        // The obstacle test first: it is cheaper, and often fails.
        self.leg_clear(a, b) && {
            let known = self.known.tree();
            match known.capsule_meets_cells(&swept, false, MAX_LEG_BLOCKS) {
                Some(meets_unknown) => !meets_unknown,
                None => known.all_in(&swept, true),
            }
        }
    }
}

/// How many waypoints ahead a route looks for a shortcut.
const SHORTCUT_LOOKAHEAD: usize = 8;

/// A search's scratch, kept per thread and reused: the current stamp; per node (stamp, its
/// current entry); where the search entered nodes (point, distance walked, node, the node
/// it came from), indexed by the heap's entries; the heap of (estimate, node's rank, entry).
/// A node's mark is 8 bytes, its distance and parent in its entry, so that the marks of
/// neighbouring nodes share cache lines.
#[derive(Default)]
struct Scratch {
    stamp: u32,
    marks: Vec<(u32, u32)>,
    entry: Vec<(DVec2, f64, u32, u32)>,
    heap: BinaryHeap<Reverse<u128>>,
}

impl Scratch {
    /// Make the scratch ready for a search of a graph of `nodes` nodes; returns the
    /// search's stamp. Two stamps a search: `stamp` for a node reached, `stamp + 1` once
    /// settled; a node's entry is read only once it carries the search's stamp (never 0).
    fn begin(&mut self, nodes: usize) -> u32 {
        if self.marks.len() != nodes {
            // All zero bytes, so the allocator hands out pages the kernel maps only when a
            // search first writes them: a thread's searches pay only for the part of a big
            // graph they reach.
            self.marks = vec![(0, 0); nodes];
            self.stamp = 0;
        }
        self.stamp = self.stamp.wrapping_add(2);
        if self.stamp == 0 {
            for m in &mut self.marks {
                m.0 = 0;
            }
            self.stamp = 2;
        }
        self.stamp
    }
}

/// The nodes of a search's route from its start to node `n`, following each node's entry's
/// parent (one allocation of the route's size).
fn chain_to(entry: &[(DVec2, f64, u32, u32)], marks: &[(u32, u32)], n: u32) -> Vec<NavNodeId> {
    let parent = |cur: u32| Some(entry[marks[cur as usize].1 as usize].3).filter(|&p| p != u32::MAX);
    let len = std::iter::successors(Some(n), |&cur| parent(cur)).count();
    let mut nodes = Vec::with_capacity(len + 1);
    nodes.extend(std::iter::successors(Some(n), |&cur| parent(cur)).map(NavNodeId));
    nodes.reverse();
    nodes
}

/// A best-first search's entries, marks and heap, in the thread's scratch: entry `e` is
/// (where the search enters, walk so far, node, parent node or [`GOAL_ENTRY`]); a node's
/// mark is (stamp, its current entry), the stamp `stamp` once reached and `stamp + 1` once
/// settled.
struct Open<'s> {
    marks: &'s mut [(u32, u32)],
    entry: &'s mut Vec<(DVec2, f64, u32, u32)>,
    heap: &'s mut BinaryHeap<Reverse<u128>>,
    stamp: u32,
}

impl Open<'_> {
    /// The stamp of a settled node.
    fn settled_stamp(&self) -> u32 {
        self.stamp + 1
    }

    /// Whether node `m` has been reached (or settled) in this search.
    fn is_reached(&self, m: NavNodeId) -> bool {
        self.marks[m.0 as usize].0 | 1 == self.settled_stamp()
    }

    /// Add `entry` and queue it at `cost`, ties broken by `rank`; returns its number.
    fn push(&mut self, entry: (DVec2, f64, u32, u32), cost: f64, rank: u32) -> u32 {
        let e = u32::try_from(self.entry.len()).expect("fewer entries than u32");
        self.entry.push(entry);
        self.heap.push(Reverse(heap_key(cost, rank, e)));
        e
    }

    /// Add `entry` as the current entry of its node, now reached, and queue it at `cost`,
    /// ties broken by `rank`.
    fn reach(&mut self, entry: (DVec2, f64, u32, u32), cost: f64, rank: u32) {
        let e = self.push(entry, cost, rank);
        self.marks[entry.2 as usize] = (self.stamp, e);
    }

    /// The route to goal entry `e`: its node's chain of nodes and the goal point.
    fn route_to(&self, e: u32) -> (Vec<NavNodeId>, DVec2) {
        let (goal, _, n, _) = self.entry[e as usize];
        (chain_to(self.entry, self.marks, n), goal)
    }

    /// Goal entry `e` as `Goals::Cheapest` gathers it.
    fn found_goal(&self, e: u32) -> FoundGoal {
        let (nodes, point) = self.route_to(e);
        FoundGoal {
            cost_m: self.entry[e as usize].1,
            nodes,
            point,
        }
    }

    /// The search's answer once its node budget is spent: for `Goals::Cheapest`, the goals
    /// waiting in the heap gathered cheapest first (no route); otherwise the route to
    /// `best_goal`, the cheapest goal queued, if any.
    fn cut_short(&mut self, goals: &Goals, best_goal: Option<(f64, u32)>) -> Option<(Vec<NavNodeId>, DVec2)> {
        if let Goals::Cheapest(_, out, k) = goals {
            let mut out = out.borrow_mut();
            while out.len() < *k
                && let Some(Reverse(key)) = self.heap.pop()
            {
                let e = key as u32;
                if self.entry[e as usize].3 == GOAL_ENTRY {
                    out.push(self.found_goal(e));
                }
            }
            return None;
        }
        best_goal.map(|(_, e)| self.route_to(e))
    }
}

thread_local! {
    /// Per-thread search scratch, sized to the graph, reused across searches.
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl NavGraph {
    /// Build from the obstacle map's free leaves. Cost: O(leaves × log leaves); the edge
    /// search and the sorts run on the current rayon pool's workers, and the graph does not
    /// depend on how many there are (edges are sorted into one order;
    /// `graphs_built_on_one_thread_and_on_all_workers_are_equal`). Not for a task of a
    /// parallel step that may ask for the graph again (see [`LazyNavGraph::get_or_build`]).
    pub fn build(obstacles: &ObstacleMap) -> Self {
        Self::build_with(obstacles, Workers::All)
    }

    /// [`build`](Self::build) on the calling thread alone: it runs no job of the pool's and
    /// takes none.
    pub fn build_on_this_thread(obstacles: &ObstacleMap) -> Self {
        Self::build_with(obstacles, Workers::One)
    }

    fn build_with(obstacles: &ObstacleMap, workers: Workers) -> Self {
        let grid = *obstacles.grid();
        let mut leaves = Vec::new();
        obstacles.tree().for_each_leaf(|sq, blocked| {
            if !blocked {
                leaves.push(sq);
            }
        });
        let keys: Vec<u64> = leaves.iter().map(|s| morton(s.x, s.y)).collect();
        debug_assert!(keys.windows(2).all(|w| w[0] < w[1]), "leaves come in Z order");
        let (pieces, piece_of) = pieces::merge(&leaves, workers);
        // Nodes numbered in Z order of their pieces' lower-left cells (distinct: pieces are
        // disjoint), so that neighbours have nearby ids and a search's reads of nodes,
        // marks and neighbour lists fall in few cache lines. Searches break ties by `rank`
        // (the merge's order), so routes do not depend on this numbering; checked by
        // `graph_of_the_maze_matches_its_cells` and `a_star_routes_match_dijkstra`.
        let mut rank: Vec<u32> = (0..u32::try_from(pieces.len()).expect("pieces fit u32")).collect();
        rank.sort_unstable_by_key(|&i| morton(pieces[i as usize].x, pieces[i as usize].y));
        let mut id_of = vec![0u32; pieces.len()];
        for (id, &r) in rank.iter().enumerate() {
            id_of[r as usize] = u32::try_from(id).expect("pieces fit u32");
        }
        let mut graph = Self {
            grid,
            pieces: rank.iter().map(|&r| pieces[r as usize]).collect(),
            levels: leaves.iter().map(|s| s.level).collect(),
            key_starts: Vec::new(),
            prefix_shift: 0,
            keys,
            piece_of: piece_of.iter().map(|&p| id_of[p as usize]).collect(),
            rank,
            starts: Vec::new(),
            adjacent: Vec::new(),
        };
        graph.index_keys();
        // Each node's neighbours in the merge's order, as they were listed before the
        // renumbering: edges as keys (node << 32 | the neighbour's rank), sorted.
        let mut edges = graph.edge_keys(obstacles, &leaves, workers);
        workers.sort(&mut edges);
        edges.dedup();
        graph.starts = vec![0; graph.pieces.len() + 1];
        for &key in &edges {
            graph.starts[(key >> 32) as usize + 1] += 1;
        }
        for i in 0..graph.pieces.len() {
            graph.starts[i + 1] += graph.starts[i];
        }
        graph.adjacent = edges
            .into_iter()
            .map(|key| id_of[(key & 0xFFFF_FFFF) as usize])
            .collect();
        graph
    }

    /// The edges between pieces whose leaves share a stretch of edge (found east and north
    /// of every leaf of `leaves`, the free leaves in Z order), each pair both ways, as keys
    /// `a << 32 | rank[b]`: in tasks of [`LEAVES_A_TASK`] leaves on `workers`, each task's
    /// keys sorted without repeats, one task's after another (a key may repeat across
    /// tasks). O(leaves × log leaves).
    fn edge_keys(&self, obstacles: &ObstacleMap, leaves: &[Square], workers: Workers) -> Vec<u64> {
        let grid = self.grid;
        let half = 0.5 * grid.cell_m();
        let key = |a: u32, b: u32| u64::from(a) << 32 | u64::from(self.rank[b as usize]);
        let parts: Vec<Vec<u64>> = leaves
            .par_chunks(LEAVES_A_TASK)
            .with_min_len(workers.tasks_a_job())
            .enumerate()
            .map(|(c, chunk)| {
                let mut out = Vec::new();
                for (k, sq) in chunk.iter().enumerate() {
                    let s = sq.side_cells();
                    let east = Aabb {
                        min: grid.corner(sq.x + s, sq.y),
                        max: grid.corner(sq.x + s, sq.y + s) + DVec2::new(half, 0.0),
                    };
                    let north = Aabb {
                        min: grid.corner(sq.x, sq.y + s),
                        max: grid.corner(sq.x + s, sq.y + s) + DVec2::new(0.0, half),
                    };
                    let a = self.piece_of[c * LEAVES_A_TASK + k];
                    // A strip inside the leaf's own piece (a rectangle) meets only that
                    // piece: no edge, no search.
                    let p = self.pieces[a as usize];
                    for (strip, inside) in [(east, sq.x + s < p.x + p.w), (north, sq.y + s < p.y + p.h)] {
                        if inside {
                            continue;
                        }
                        let _ = obstacles.tree().visit_leaves_in(&strip, false, |n, _| {
                            let b = self.piece_of[self.find(n).expect("free leaf is a node")];
                            if a != b {
                                out.push(key(a, b));
                                out.push(key(b, a));
                            }
                            ControlFlow::Continue(())
                        });
                    }
                }
                // Neighbouring leaves of one piece list the same edges: fewer to copy and sort.
                out.sort_unstable();
                out.dedup();
                out
            })
            .collect();
        let mut edges = Vec::with_capacity(parts.iter().map(Vec::len).sum());
        for part in parts {
            edges.extend_from_slice(&part);
        }
        edges
    }

    /// Fill `key_starts`: prefixes of whole squares of cells (two bits a level), about 16
    /// keys a prefix.
    fn index_keys(&mut self) {
        // Keys of a covering square of side 2^d use the low 2d bits. The finest prefixes
        // that hold at least 16 keys each on average, at most 2^24 of them.
        let depth_bits = 2 * u32::from(self.grid.depth());
        let mut shift = depth_bits;
        while shift >= 2 && depth_bits - shift + 2 <= 24 && (16usize << (depth_bits - shift + 2)) <= self.keys.len() {
            shift -= 2;
        }
        let prefixes = 1usize << (depth_bits - shift);
        let mut starts = vec![0u32; prefixes + 1];
        for &k in &self.keys {
            starts[(k >> shift) as usize + 1] += 1;
        }
        for i in 0..prefixes {
            starts[i + 1] += starts[i];
        }
        (self.key_starts, self.prefix_shift) = (starts, shift);
    }

    /// How many keys are at most `key` (the first index past them): among the keys of its
    /// prefix, as all before them are smaller and all after larger.
    #[inline]
    fn keys_up_to(&self, key: u64) -> usize {
        let prefix = (key >> self.prefix_shift) as usize;
        let (lo, hi) = (self.key_starts[prefix] as usize, self.key_starts[prefix + 1] as usize);
        lo + self.keys[lo..hi].partition_point(|&k| k <= key)
    }

    /// The index of free leaf `sq`.
    fn find(&self, sq: Square) -> Option<usize> {
        self.keys
            .binary_search(&morton(sq.x, sq.y))
            .ok()
            .filter(|&i| self.levels[i] == sq.level)
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// Whether the map has no free space.
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// Number of free leaves the pieces were merged from.
    pub fn leaf_count(&self) -> usize {
        self.keys.len()
    }

    /// Number of (undirected) edges.
    pub fn edge_count(&self) -> usize {
        self.adjacent.len() / 2
    }

    /// The node whose piece holds `p`, if `p` is in free space.
    pub fn node_at(&self, p: DVec2) -> Option<NavNodeId> {
        let (x, y) = self.grid.cell_of(p)?;
        let key = morton(x, y);
        let i = self.keys_up_to(key).checked_sub(1)?;
        // The leaf at or before the cell in Z order holds it if its square reaches it.
        let (lx, ly) = unmorton(self.keys[i]);
        let s = 1u32 << self.levels[i];
        (x >= lx && x < lx + s && y >= ly && y < ly + s).then_some(NavNodeId(self.piece_of[i]))
    }

    /// Visit the nodes whose pieces meet the aligned square `sq` (a node may come more than
    /// once): the leaves inside it are a run of Z order, and a leaf bigger than it holds its
    /// first cell.
    pub fn for_each_node_meeting(&self, sq: Square, mut visit: impl FnMut(NavNodeId)) {
        let last = sq.side_cells() - 1;
        let (lo, hi) = (morton(sq.x, sq.y), morton(sq.x + last, sq.y + last));
        let first = self.keys.partition_point(|&k| k < lo);
        if let Some(i) = first.checked_sub(1) {
            let (lx, ly) = unmorton(self.keys[i]);
            let s = 1u32 << self.levels[i];
            if sq.x < lx + s && sq.y < ly + s && lx <= sq.x && ly <= sq.y {
                visit(NavNodeId(self.piece_of[i]));
            }
        }
        for i in first..self.keys.len() {
            if self.keys[i] > hi {
                break;
            }
            visit(NavNodeId(self.piece_of[i]));
        }
    }

    /// A node's piece of free space.
    pub fn piece(&self, n: NavNodeId) -> Piece {
        self.pieces[n.0 as usize]
    }

    /// [`node_at`](Self::node_at), trying `hint` and its neighbours first: a robot's next
    /// search mostly starts where its last route ended. The same answer for any hint;
    /// checked by `graph_of_the_maze_matches_its_cells`.
    pub fn node_at_near(&self, p: DVec2, hint: Option<NavNodeId>) -> Option<NavNodeId> {
        let cell = self.grid.cell_of(p)?;
        hint.filter(|h| (h.0 as usize) < self.pieces.len())
            .and_then(|h| self.holder_near(h, cell))
            .or_else(|| self.node_at(p))
    }

    /// Node `n` or the neighbour of it whose piece holds `cell`, if one does: `node_at`'s
    /// answer for the cell when it is one of those (pieces partition the free cells),
    /// without its look-up among the leaves.
    fn holder_near(&self, n: NavNodeId, cell: (u32, u32)) -> Option<NavNodeId> {
        if self.piece(n).holds(cell) {
            return Some(n);
        }
        self.neighbors(n).find(|&m| self.piece(m).holds(cell))
    }

    /// Whether node `n` is on the frontier of `known`: the known map touches it, and it is
    /// partly unknown or borders a node not known at all.
    pub fn is_frontier(&self, known: &KnownMap, n: NavNodeId) -> bool {
        self.touched_by(known, n)
            && (!self.covered_by(known, n) || self.neighbors(n).any(|m| !self.touched_by(known, m)))
    }

    /// Whether `known` knows some cell of node `n`.
    pub fn touched_by(&self, known: &KnownMap, n: NavNodeId) -> bool {
        let p = self.piece(n);
        known.touches_cells(p.lo(), p.hi())
    }

    /// Whether `known` knows every cell of node `n`.
    pub fn covered_by(&self, known: &KnownMap, n: NavNodeId) -> bool {
        let p = self.piece(n);
        known.covers_cells(p.lo(), p.hi())
    }

    /// Whether `known` knows some cell of node `n`, and whether it knows every cell
    /// ([`touched_by`](Self::touched_by) and [`covered_by`](Self::covered_by) at once),
    /// descending `known`'s tree from `finger` (see
    /// [`KnownMap::touches_and_covers_cells_from`]).
    pub fn touched_and_covered_from(&self, known: &KnownMap, finger: &mut Finger, n: NavNodeId) -> (bool, bool) {
        let p = self.piece(n);
        known.touches_and_covers_cells_from(finger, p.lo(), p.hi())
    }

    /// A node's world box.
    pub fn bounds(&self, n: NavNodeId) -> Aabb {
        let p = self.piece(n);
        Aabb {
            min: self.grid.corner(p.x, p.y),
            max: self.grid.corner(p.x + p.w, p.y + p.h),
        }
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
        let (lo, hi) = self.portal_ends(a, b);
        (lo + hi) * 0.5
    }

    /// Where a search that reached node `a` at `at` enters neighbour `b`: the point of their
    /// portal nearest to `at`, kept half a cell from the portal's ends. Costing a piece by
    /// the walk between such points, not between portal midpoints, keeps searches from
    /// preferring corridors that look short only through the middles of big pieces.
    pub(crate) fn entry_point(&self, a: NavNodeId, b: NavNodeId, at: DVec2) -> DVec2 {
        let (lo, hi) = self.portal_ends(a, b);
        let inset = DVec2::splat(0.5 * self.grid.cell_m()).min(0.5 * (hi - lo));
        at.clamp(lo + inset, hi - inset)
    }

    /// Ends of the edge stretch two adjacent nodes share (lower left first).
    pub fn portal_ends(&self, a: NavNodeId, b: NavNodeId) -> (DVec2, DVec2) {
        // In cells, then to the world: the corners are the same, as a corner grows with its
        // cell, and the boxes in metres are not worked out.
        let (p, q) = (self.piece(a), self.piece(b));
        let lo = self.grid.corner(p.x.max(q.x), p.y.max(q.y));
        let hi = self.grid.corner((p.x + p.w).min(q.x + q.w), (p.y + p.h).min(q.y + q.h));
        (lo, hi)
    }

    /// The route through `nodes` when the pulled string cannot keep the clearance: through
    /// each portal square's middle ([`deep_crossings`](Self::deep_crossings)) on maps whose
    /// half cell is at least the clearance (cells as large as the robot), else the shortest chain of
    /// cells the disc stands free on through the pieces and the ring round them
    /// ([`corridor::corridor_path`]) pulled straight by sight ([`pull_chain`]), else the
    /// crossings anyway (the robot, held back, plans again).
    fn fallback_route(&self, from: DVec2, nodes: Vec<NavNodeId>, goal: DVec2, terrain: Terrain) -> Route {
        let clearance_m = terrain.clearance_m();
        // Crossings keep half a cell clear: enough where that is the clearance or more.
        let chain = (0.5 * self.grid.cell_m() < clearance_m)
            .then(|| {
                let pieces: Vec<Piece> = nodes.iter().map(|&n| self.piece(n)).collect();
                corridor::corridor_path(&self.grid, &pieces, from, goal, |c| {
                    terrain.obstacles.is_disc_free(c, clearance_m)
                })
            })
            .flatten();
        let waypoints = if let Some(chain) = chain {
            pull_chain(from, &chain, terrain)
        } else {
            let mut crossings = self.deep_crossings(&nodes);
            crossings.push(goal);
            shortcut(from, &crossings, terrain)
        };
        Self::route_of(from, nodes, waypoints)
    }

    /// Where a route through `nodes` that keeps well inside them crosses their portals: for
    /// each portal, a point either side of its middle, as deep into each piece as half the
    /// portal's length and half of either piece allow. Legs between such points stay that
    /// deep too (the points at a given depth of a rectangle form a rectangle), so the route
    /// keeps half a cell clear on maps of unit cells, whatever its pieces' shapes.
    fn deep_crossings(&self, nodes: &[NavNodeId]) -> Vec<DVec2> {
        let mut points = Vec::with_capacity(2 * nodes.len());
        for w in nodes.windows(2) {
            let (lo, hi) = self.portal_ends(w[0], w[1]);
            let (a, b) = (self.bounds(w[0]), self.bounds(w[1]));
            let along = hi - lo;
            // The portal's normal from `a` into `b`, and the pieces' depths along it.
            let (normal, depth) = if along.x.abs() >= along.y.abs() {
                (
                    DVec2::Y * (b.center().y - a.center().y).signum(),
                    (a.max.y - a.min.y).min(b.max.y - b.min.y),
                )
            } else {
                (
                    DVec2::X * (b.center().x - a.center().x).signum(),
                    (a.max.x - a.min.x).min(b.max.x - b.min.x),
                )
            };
            let d = 0.5 * along.length().min(depth);
            let mid = 0.5 * (lo + hi);
            points.push(mid - normal * d);
            points.push(mid + normal * d);
        }
        points
    }

    /// The portal from `a` into `b` as a walker sees it, each end pulled in by `margin_m`
    /// (down to the midpoint on short portals).
    fn walked_portal(&self, a: NavNodeId, b: NavNodeId, margin_m: f64) -> Portal {
        let (lo, hi) = self.portal_ends(a, b);
        let len = lo.distance(hi);
        let (lo, hi) = if len > 0.0 {
            let cut = (hi - lo) * (margin_m.min(0.5 * len) / len);
            (lo + cut, hi - cut)
        } else {
            (lo, hi)
        };
        let travel = self.bounds(b).center() - self.bounds(a).center();
        if travel.perp_dot(hi - lo) > 0.0 {
            Portal { left: hi, right: lo }
        } else {
            Portal { left: lo, right: hi }
        }
    }

    /// The route through `nodes` (a chain of neighbours from the node holding `from`) to
    /// `goal`, pulled taut. Its bends keep the terrain's clearance from the portals' ends,
    /// and every leg is checked with the swept-disc test.
    fn taut_route(&self, from: DVec2, mut nodes: Vec<NavNodeId>, goal: DVec2, terrain: Terrain) -> Route {
        let last = *nodes.last().expect("a route holds its start");
        // A goal across the last node's edge (a frontier just inside an unknown node) is
        // reached through that edge too.
        if let Some(m) = self
            .grid
            .cell_of(goal)
            .and_then(|cell| self.holder_near(last, cell))
            .filter(|&m| m != last)
        {
            nodes.push(m);
        }
        let first_margin_m = terrain.clearance_m();
        let mut margins_m = vec![first_margin_m; nodes.len() - 1];
        let walked = |margins_m: &[f64]| -> Vec<Portal> {
            (nodes.windows(2).zip(margins_m))
                .map(|(w, &m)| self.walked_portal(w[0], w[1], m))
                .collect()
        };
        // A leg that meets a portal at a shallow angle passes the corner at the portal's end
        // closer than the margin: a bend at distance `m` along the portal from the corner
        // clears it by `m·sin θ`, θ the angle between leg and portal. Such a bend's portal
        // is pulled in to `r / sin θ` and the string pulled again (portals a failing leg
        // only crosses are pulled in twice as far), three times at most. If a leg is still
        // too close, the route crosses every portal square at its middle instead
        // ([`deep_crossings`](Self::deep_crossings)), cutting only the corners that are clear.
        let mut attempt = 0;
        loop {
            let portals = walked(&margins_m);
            let bends = funnel::pull(from, &portals, goal);
            let mut legs = Vec::with_capacity(bends.len());
            let (mut prev, mut passed) = (from, 0usize);
            for &(p, i) in &bends {
                let clear = terrain.leg_clear(prev, p);
                legs.push((prev, p, passed, i, clear));
                (prev, passed) = (p, i);
            }
            attempt += 1;
            if legs.iter().all(|l| l.4) {
                let waypoints: Vec<DVec2> = bends.iter().map(|b| b.0).collect();
                break Self::route_of(from, nodes, shortcut(from, &waypoints, terrain));
            }
            if attempt == 4 {
                break self.fallback_route(from, nodes, goal, terrain);
            }
            for &(a, b, passed, i, clear) in &legs {
                if clear {
                    continue;
                }
                let d = (b - a).normalize_or_zero();
                // Portals counted from 0: the leg starts on `passed - 1` and ends on `i - 1`.
                for k in passed.saturating_sub(1)..i.min(portals.len()) {
                    let m = &mut margins_m[k];
                    if k + 1 == passed || k + 1 == i {
                        let along = (portals[k].left - portals[k].right).normalize_or_zero();
                        let sin = along.perp_dot(d).abs().max(0.1);
                        *m = (terrain.clearance_m() / sin).max(1.2 * *m);
                    } else {
                        *m *= 2.0;
                    }
                }
            }
        }
    }

    /// A route of `nodes` along `waypoints` from `from`, with its length.
    fn route_of(from: DVec2, nodes: Vec<NavNodeId>, waypoints: Vec<DVec2>) -> Route {
        let mut length_m = 0.0;
        let mut prev = from;
        for w in &waypoints {
            length_m += prev.distance(*w);
            prev = *w;
        }
        Route {
            nodes,
            waypoints,
            length_m,
        }
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.pieces.capacity() * std::mem::size_of::<Piece>()
            + self.keys.capacity() * 8
            + self.key_starts.capacity() * 4
            + self.levels.capacity()
            + (self.piece_of.capacity() + self.rank.capacity() + self.starts.capacity() + self.adjacent.capacity()) * 4
    }

    /// Dijkstra from the node holding `from` over nodes accepted by `usable`, until `is_goal`
    /// accepts a node; the route ends at the point `is_goal` returns for it, pulled taut for
    /// a robot in `terrain`. A route costs the walk from entry point to entry point (see
    /// `entry_point`), so routes through big open pieces cost what they measure.
    pub fn search(
        &self,
        from: DVec2,
        terrain: Terrain,
        usable: impl FnMut(NavNodeId) -> bool,
        mut is_goal: impl FnMut(NavNodeId) -> Option<DVec2>,
        max_nodes: usize,
    ) -> Option<Route> {
        self.search_knowing_reached(
            from,
            None,
            terrain,
            usable,
            |n, _, _| is_goal(n).map(|g| (n, g)),
            max_nodes,
        )
    }

    /// [`search`](Self::search) whose goal test also gets a test of whether this search has
    /// reached a node (found it usable) yet: a goal test that asks about a node's
    /// neighbours can skip what the search knows already.
    /// The node holding `from` is looked for at `start_hint` and its neighbours first (see
    /// [`node_at_near`](Self::node_at_near)).
    pub fn search_knowing_reached(
        &self,
        from: DVec2,
        start_hint: Option<NavNodeId>,
        terrain: Terrain,
        usable: impl FnMut(NavNodeId) -> bool,
        mut is_goal: impl FnMut(NavNodeId, f64, &dyn Fn(NavNodeId) -> bool) -> Option<(NavNodeId, DVec2)>,
        max_nodes: usize,
    ) -> Option<Route> {
        let (nodes, goal) = self.best_first(
            from,
            start_hint,
            usable,
            |n, d, _, reached| is_goal(n, d, reached),
            Goals::First,
            None,
            max_nodes,
        )?;
        Some(self.taut_route(from, nodes, goal, terrain))
    }

    /// [`search_knowing_reached`](Self::search_knowing_reached) for the goal nearest by
    /// route, not the first node accepted: `is_goal` also gets where the search entered the
    /// node, and a goal costs the walk to that entry plus the straight line on to the goal
    /// point (inside the node, a convex piece, or just across its edge), plus `bias` of the
    /// goal point (never negative: a goal then costs at least the walk to its node). Goals
    /// found wait in the search's queue with that cost, so the one returned is the
    /// cheapest; the search settles the nodes nearer than it as well, a few more than the
    /// first-accepted search. In big pieces the first node accepted can hold a goal metres
    /// farther than a later one's. Checked by
    /// `goal_searches_take_the_goals_nearest_by_route`.
    #[allow(clippy::too_many_arguments)] // `search_knowing_reached`'s, and the bias
    pub fn search_nearest_goal(
        &self,
        from: DVec2,
        start_hint: Option<NavNodeId>,
        terrain: Terrain,
        usable: impl FnMut(NavNodeId) -> bool,
        is_goal: impl FnMut(NavNodeId, f64, DVec2, &dyn Fn(NavNodeId) -> bool) -> Option<(NavNodeId, DVec2)>,
        bias: &dyn Fn(DVec2) -> f64,
        max_nodes: usize,
    ) -> Option<Route> {
        let (nodes, goal) =
            self.best_first(from, start_hint, usable, is_goal, Goals::Nearest(bias), None, max_nodes)?;
        Some(self.taut_route(from, nodes, goal, terrain))
    }

    /// [`search`](Self::search) ordered by distance so far plus `estimate` of the rest from
    /// a portal: Dijkstra with a zero estimate, A* with the straight line to a known goal.
    /// An estimate that never exceeds the length still to go, and never drops faster than
    /// the distance walked, finds the same shortest routes while settling far fewer nodes.
    ///
    /// With a zero estimate (Dijkstra: `estimate` is `None`) a node's cost is final once
    /// settled, as costs popped never decrease, so the moves back into settled nodes are
    /// not worked out. With an estimate a later, cheaper way into a settled node reopens
    /// it, as entry points depend on the way in. Checked by `a_star_routes_match_dijkstra`.
    #[allow(clippy::too_many_arguments)] // each is one aspect of the search; a struct would only wrap them
    fn best_first(
        &self,
        from: DVec2,
        start_hint: Option<NavNodeId>,
        mut usable: impl FnMut(NavNodeId) -> bool,
        mut is_goal: impl FnMut(NavNodeId, f64, DVec2, &dyn Fn(NavNodeId) -> bool) -> Option<(NavNodeId, DVec2)>,
        goals: Goals,
        estimate: Option<&dyn Fn(DVec2) -> f64>,
        max_nodes: usize,
    ) -> Option<(Vec<NavNodeId>, DVec2)> {
        let settled_final = estimate.is_none();
        let estimate = |p: DVec2| estimate.map_or(0.0, |e| e(p));
        let start = self.node_at_near(from, start_hint)?;
        SCRATCH.with(|cell| {
            let mut guard = cell.borrow_mut();
            let stamp = guard.begin(self.pieces.len());
            let Scratch { marks, entry, heap, .. } = &mut *guard;
            // Where the search enters each node (portal or start), for edge costs, and the
            // distance walked to get there (buffers reused: every explorer plans a search
            // every few rounds).
            entry.clear();
            heap.clear();
            let mut open = Open {
                marks,
                entry,
                heap,
                stamp,
            };
            open.reach(
                (from, 0.0, start.0, u32::MAX),
                estimate(from),
                self.rank[start.0 as usize],
            );
            let mut settled = 0usize;
            // The cheapest goal waiting in the heap (`Goals::Nearest`), as its cost and entry.
            let mut best_goal: Option<(f64, u32)> = None;
            while let Some(Reverse(key)) = open.heap.pop() {
                let e = key as u32;
                let (at, d, n, parent) = open.entry[e as usize];
                if parent == GOAL_ENTRY {
                    let Goals::Cheapest(_, out, k) = goals else {
                        return Some(open.route_to(e));
                    };
                    let mut out = out.borrow_mut();
                    out.push(open.found_goal(e));
                    if out.len() >= k {
                        return None;
                    }
                    continue;
                }
                // An entry other than the node's current one was bettered since.
                if open.marks[n as usize].1 != e {
                    continue;
                }
                open.marks[n as usize].0 = open.settled_stamp();
                settled += 1;
                let node = NavNodeId(n);
                let goal = is_goal(node, d, at, &|m: NavNodeId| open.is_reached(m));
                if let Some((NavNodeId(g), goal)) = goal {
                    let bias = match goals {
                        Goals::Nearest(bias) | Goals::Cheapest(bias, _, _) => bias,
                        Goals::First => return Some((chain_to(open.entry, open.marks, g), goal)),
                    };
                    // It waits for the nodes nearer than itself, in the heap.
                    let cost = d + at.distance(goal) + bias(goal);
                    let e = open.push((goal, cost, g, GOAL_ENTRY), cost, self.rank[g as usize]);
                    if best_goal.is_none_or(|(c, _)| cost < c) {
                        best_goal = Some((cost, e));
                    }
                }
                if settled >= max_nodes {
                    return open.cut_short(&goals, best_goal);
                }
                self.open_neighbors(&mut open, (node, at, d), &mut usable, &estimate, settled_final);
            }
            None
        })
    }

    /// Open the neighbours of `node`, settled and entered at `at` after walking `d`: each
    /// usable one not yet reached, or reached by a longer way (and, when `settled_final`,
    /// not settled yet), gets an entry at its portal's entry point and a place in the heap
    /// by the walk plus `estimate` of the rest.
    fn open_neighbors(
        &self,
        open: &mut Open,
        (node, at, d): (NavNodeId, DVec2, f64),
        usable: &mut impl FnMut(NavNodeId) -> bool,
        estimate: &impl Fn(DVec2) -> f64,
        settled_final: bool,
    ) {
        let settled_stamp = open.settled_stamp();
        for m in self.neighbors(node) {
            let mark = open.marks[m.0 as usize];
            // Only nodes found usable are ever stamped, so the test runs once a node.
            let reached = mark.0 | 1 == settled_stamp;
            if (settled_final && mark.0 == settled_stamp) || (!reached && !usable(m)) {
                continue;
            }
            let p = self.entry_point(node, m, at);
            let nd = d + at.distance(p);
            if !reached || nd < open.entry[mark.1 as usize].1 {
                open.reach((p, nd, m.0, node.0), nd + estimate(p), self.rank[m.0 as usize]);
            }
        }
    }

    /// The `k` cheapest goals, cheapest first, as [`search_nearest_goal`](Self::search_nearest_goal)
    /// ranks them (the first is the goal that search routes to, when the search is not cut
    /// short by `max_nodes`): the search goes on past the first goal until `k` have come out
    /// of its queue, or every usable node is settled, or `max_nodes` are. Fewer than `k`
    /// when there are fewer. Cost: the nodes nearer than the `k`-th goal are settled.
    /// Checked by `goal_searches_take_the_goals_nearest_by_route`.
    #[allow(clippy::too_many_arguments)] // `search_nearest_goal`'s, and how many goals
    pub fn search_cheapest_goals(
        &self,
        from: DVec2,
        start_hint: Option<NavNodeId>,
        usable: impl FnMut(NavNodeId) -> bool,
        is_goal: impl FnMut(NavNodeId, f64, DVec2, &dyn Fn(NavNodeId) -> bool) -> Option<(NavNodeId, DVec2)>,
        bias: &dyn Fn(DVec2) -> f64,
        k: usize,
        max_nodes: usize,
    ) -> Vec<FoundGoal> {
        let out = RefCell::new(Vec::with_capacity(k));
        if k > 0 {
            let none = self.best_first(
                from,
                start_hint,
                usable,
                is_goal,
                Goals::Cheapest(bias, &out, k),
                None,
                max_nodes,
            );
            debug_assert!(
                none.is_none(),
                "a search for the cheapest goals gathers them, it routes to none"
            );
        }
        out.into_inner()
    }

    /// The route to a goal [`search_cheapest_goals`](Self::search_cheapest_goals) found from
    /// `from`, pulled taut for a robot in `terrain`.
    pub fn route_to_found(&self, from: DVec2, goal: FoundGoal, terrain: Terrain) -> Route {
        self.taut_route(from, goal.nodes, goal.point, terrain)
    }

    /// Shortest route from `from` to `to` through nodes the terrain's known map touches,
    /// pulled taut for its robot.
    pub fn route_within(&self, terrain: Terrain, from: DVec2, to: DVec2, max_nodes: usize) -> Option<Route> {
        let known = terrain.known;
        let goal = self.node_at(to)?;
        // A goal the known map does not touch is never reached (only the start is exempt
        // from that test): say so now instead of searching everything known first.
        if self.node_at(from) != Some(goal) && !self.touched_by(known, goal) {
            return None;
        }
        // A*: the straight line to `to` is never longer than a route's rest, and shrinks by
        // at most what a step walks, so it finds Dijkstra's routes.
        let (nodes, to) = self.best_first(
            from,
            None,
            |n| self.touched_by(known, n),
            |n, _, _, _| (n == goal).then_some((n, to)),
            Goals::First,
            Some(&|p: DVec2| p.distance(to)),
            max_nodes,
        )?;
        Some(self.taut_route(from, nodes, to, terrain))
    }

    /// The shortest route from `from` to `to` if unknown terrain were open: through nodes
    /// the known map touches either to the goal, or to a frontier node from which a hopeful
    /// straight leg (no cell known to be blocked near it) leads on to `to`, from the node's
    /// point nearest to `to` or else from its corner nearest to `to` that allows one; the
    /// search takes the node whose way there plus the straight line on is shortest. The
    /// known part is pulled taut and checked like any route; the last leg is a hope, never
    /// checked against what the robot has not seen, and a robot that meets an obstacle on
    /// it plans again. `None` if no such route exists within `max_nodes`.
    pub fn route_optimistic(&self, terrain: Terrain, from: DVec2, to: DVec2, max_nodes: usize) -> Option<Route> {
        let known = terrain.known;
        // The map's edges are known to every robot.
        let extent = self.grid.extent();
        if !extent.contains_strictly(to) || !extent.contains_strictly(from) {
            return None;
        }
        // `to` may lie in a node the robot knows, or in terrain it has not seen (blocked or
        // not: only what it knows counts).
        let goal = self.node_at(to).filter(|&g| self.touched_by(known, g));
        let (nodes, end) = self.best_first(
            from,
            None,
            |n| self.touched_by(known, n),
            |n, _, _, _| {
                if Some(n) == goal {
                    return Some((n, to));
                }
                if !self.is_frontier(known, n) {
                    return None;
                }
                // Leave the node at its point nearest to `to`, or else at the corner nearest
                // to it from which the way on is hopeful (round the end of a wall the robot
                // has seen part of), kept the clearance inside.
                let b = self.bounds(n);
                let inset = DVec2::splat(terrain.clearance_m()).min(0.5 * (b.max - b.min));
                let (lo, hi) = (b.min + inset, b.max - inset);
                let mut exits = [to.clamp(lo, hi), lo, DVec2::new(hi.x, lo.y), DVec2::new(lo.x, hi.y), hi];
                exits[1..].sort_by(|a, b| a.distance_squared(to).total_cmp(&b.distance_squared(to)));
                exits
                    .into_iter()
                    .find(|&exit| terrain.hopeful(exit, to))
                    .map(|e| (n, e))
            },
            Goals::First,
            Some(&|p: DVec2| p.distance(to)),
            max_nodes,
        )?;
        let mut route = self.taut_route(from, nodes, end, terrain);
        if end != to {
            route.length_m += end.distance(to);
            route.waypoints.push(to);
        }
        Some(route)
    }
}

/// A chain of cell centres, each next to the one before, straightened by sight: from each
/// point kept, the next kept is the last of the run of chain points it reaches by legs
/// [`Terrain::shortcut_clear`] allows. A cell chain steps in eight directions only, and
/// [`shortcut`]'s few waypoints of look-ahead would leave a staircase of 0.1 m steps on fine
/// maps. O(chain) leg tests.
fn pull_chain(from: DVec2, chain: &[DVec2], terrain: Terrain) -> Vec<DVec2> {
    let mut out = Vec::new();
    let (mut at, mut i) = (from, 0);
    while i < chain.len() {
        // The next point is always walkable: a neighbouring cell the disc stands free on.
        let mut j = i;
        while j + 1 < chain.len() && terrain.shortcut_clear(at, chain[j + 1]) {
            j += 1;
        }
        out.push(chain[j]);
        (at, i) = (chain[j], j + 1);
    }
    out
}

/// `waypoints` (walked from `from`) with corners cut where the terrain allows: from each
/// point, straight to the farthest of the next [`SHORTCUT_LOOKAHEAD`] waypoints reachable in
/// one clear leg over known cells. A corridor of nodes can bend more than the free space
/// around it does; the cut legs take that back.
fn shortcut(from: DVec2, waypoints: &[DVec2], terrain: Terrain) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(waypoints.len());
    let (mut at, mut i) = (from, 0);
    while i < waypoints.len() {
        let last = (i + SHORTCUT_LOOKAHEAD).min(waypoints.len()) - 1;
        // The next waypoint itself is always walkable: it is the route's own leg.
        let j = (i + 1..=last)
            .rev()
            .find(|&j| terrain.shortcut_clear(at, waypoints[j]))
            .unwrap_or(i);
        out.push(waypoints[j]);
        (at, i) = (waypoints[j], j + 1);
    }
    out
}

/// Which goal a best-first search returns.
#[derive(Clone, Copy)]
enum Goals<'b> {
    /// The goal of the first node its goal test accepts, in the order nodes are settled.
    First,
    /// The goal nearest by the walk to its node's entry plus the straight line on, plus
    /// the bias (never negative) of the goal point.
    Nearest(&'b dyn Fn(DVec2) -> f64),
    /// As `Nearest`, but the goals are gathered, cheapest first, until there are as many
    /// as asked for (the search then ends without a route).
    Cheapest(&'b dyn Fn(DVec2) -> f64, &'b RefCell<Vec<FoundGoal>>, usize),
}

/// The parent mark of a search entry that is a goal waiting in the heap, not a node.
const GOAL_ENTRY: u32 = u32::MAX - 1;

/// A search heap entry as one number, ordered as the tuple (`cost` by `total_cmp`, `node`,
/// `entry`): ties broken by the node's rank, so searches are deterministic. One integer
/// compare instead of a float's `total_cmp` and two more; checked by
/// `heap_keys_order_as_their_tuples`.
#[inline]
fn heap_key(cost: f64, node: u32, entry: u32) -> u128 {
    let bits = cost.to_bits();
    // `total_cmp`'s order as unsigned integers: negatives reversed below the positives.
    let ordered = if bits >> 63 == 1 { !bits } else { bits | 1 << 63 };
    u128::from(ordered) << 64 | u128::from(node) << 32 | u128::from(entry)
}

#[cfg(test)]
mod tests;
