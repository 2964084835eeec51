//! Any-angle shortest paths: polylines with real-valued vertices among the map's blocked
//! cells, exact for point robots.
//!
//! A shortest path among polygonal obstacles bends only at their convex corners. Point
//! robots (radius 0) are routed by **Anya** (`anya`: Harabor, Grastien, Öz and Aksakalli,
//! "Optimal Any-Angle Pathfinding In Practice", JAIR 2016): an A* search over *cones*,
//! intervals of a grid row line seen from a root (the start or a corner the path bends at),
//! pushed from row line to row line through the runs of free cells (a rectangle of equal
//! runs at once) and bent round the corners at their ends. It needs no preprocessing and
//! costs what the search sweeps, not what the map holds: no visibility graph is built. The
//! planner also finds the free space's connected regions when it is built (`regions`), so
//! that ends in different regions are answered at once instead of by a search sweeping the
//! start's region. Every leg of the path Anya returns is checked again by the exact sight
//! test; should one fail (rounding in the interval arithmetic), or Anya find no path
//! between ends in one region, or give up (more than 2^31 search nodes), the visibility
//! graph below answers instead. A point robot's planner keeps no corner list for that: the
//! graph is built then, and on a map with more than [`MAX_VERTICES`] corners the answer is
//! [`NoPath::Undecided`] rather than a search that could take hours. A query's memory
//! follows what it sweeps (the corners it bends at, its cones), never the map's size; the
//! buffers each thread keeps between queries are capped.
//!
//! Robots with a radius use the visibility graph: the planner links the convex corners that
//! see each other (its size follows the obstacles' outlines, not the number of cells) and
//! searches it with A*, joining the start and the goal to the corners they see. Only pairs
//! whose joining line grazes both corners are linked: no shortest path needs the rest. A
//! corner is linked when a search first expands it (one sight test per corner of the map);
//! links from the start are checked only when the search takes them (lazy A*), links to the
//! goal only from corners the search expands.
//!
//! The rules are those of the Moving AI any-angle benchmarks: a path may run along the edge of
//! a blocked cell, but not along an edge that two blocked cells share, nor through a point
//! where two blocked cells touch diagonally; outside the map is blocked. For a robot of
//! radius `r > 0` every blocked cell is grown into a square `r` larger on each side: the path
//! bends round the grown squares' corners, and every leg is checked with the exact swept-disc
//! test, so the robot keeps `r` clear; the path may be slightly longer than the true optimum
//! (a square corner instead of an arc) and passages that only a round robot could pass are
//! missed.
//!
//! ```
//! use sim_core::glam::DVec2;
//! use sim_core::spatial::{AnyAnglePlanner, Grid, ObstacleMap};
//!
//! // A 4 m × 3 m map with a 2 m wall standing on the bottom edge at x = 1..2.
//! let grid = Grid::new(DVec2::ZERO, 1.0, 4, 3).unwrap();
//! let map = ObstacleMap::from_fn(grid, |x, y| x == 1 && y < 2);
//! let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
//! let path = planner.path(DVec2::new(0.0, 0.0), DVec2::new(3.0, 0.0)).unwrap();
//! // Up the wall's left side, over its top corners, down the other side.
//! assert_eq!(path.waypoints, [DVec2::new(0.0, 0.0), DVec2::new(1.0, 2.0), DVec2::new(2.0, 2.0), DVec2::new(3.0, 0.0)]);
//! assert!((path.length_m - (2.0 * 5f64.sqrt() + 1.0)).abs() < 1e-12);
//! ```

mod anya;
mod build;
mod raster;
pub mod reference;
mod regions;
mod search;
mod sight;

use glam::DVec2;

pub use build::MAX_VERTICES;
pub use raster::MAX_RASTER_CELLS;

use crate::spatial::grid::Grid;
use crate::spatial::obstacle_map::ObstacleMap;

/// A corner the planner may bend at (cell units) and which of its four cells is blocked.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    pos: DVec2,
    /// 0 south-west, 1 south-east, 2 north-west, 3 north-east.
    quadrant: u8,
}

/// Shortest any-angle paths on one map for robots of one radius; built once, queried often.
#[derive(Clone, Debug)]
pub struct AnyAnglePlanner {
    grid: Grid,
    radius_m: f64,
    raster: raster::CellRaster,
    /// Corners a path may bend at (the graph's, or for point robots the map's convex ones).
    corners: usize,
    /// The visibility graph: built with the planner for robots with a radius; for point
    /// robots only if Anya's answer needs checking (a fallback), and then `None` above
    /// [`MAX_VERTICES`] corners.
    graph: std::sync::OnceLock<Option<build::Graph>>,
    /// The map, kept for exact swept-disc tests when the radius is positive.
    obstacles: Option<ObstacleMap>,
    /// The free space's connected regions: point robots' planners only.
    regions: Option<regions::Regions>,
}

/// A path: its waypoints in world coordinates from start to goal, and its length.
#[derive(Clone, Debug, PartialEq)]
pub struct AnyAnglePath {
    /// Start, the corners it bends at, goal.
    pub waypoints: Vec<DVec2>,
    /// Sum of the legs' lengths, metres.
    pub length_m: f64,
}

/// Why there is no path: an answer about the map, except [`NoPath::Undecided`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoPath {
    /// The start is blocked (inside an obstacle, outside the map, or too close to an obstacle
    /// for the robot).
    StartBlocked(DVec2),
    /// The goal is blocked (as for the start).
    GoalBlocked(DVec2),
    /// Both ends are free but no path joins them.
    Unreachable(DVec2, DVec2),
    /// Not decided: a point robot's search (Anya) failed, which is not expected (a leg
    /// that fails the exact sight test, more than 2^31 search nodes, or no path between ends
    /// in one region), and the map has more corners than the visibility graph that would
    /// decide instead accepts ([`MAX_VERTICES`]).
    Undecided(DVec2, DVec2),
}

impl std::fmt::Display for NoPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let blocked = "inside an obstacle, outside the map, or closer to an obstacle than the robot's radius";
        match self {
            Self::StartBlocked(p) => write!(f, "start ({}, {}) is {blocked}", p.x, p.y),
            Self::GoalBlocked(p) => write!(f, "goal ({}, {}) is {blocked}", p.x, p.y),
            Self::Unreachable(a, b) => write!(f, "goal ({}, {}) cannot be reached from ({}, {})", b.x, b.y, a.x, a.y),
            Self::Undecided(a, b) => write!(
                f,
                "the search from ({}, {}) to ({}, {}) failed and the map has more than {MAX_VERTICES} \
                 corners for the visibility graph that would decide",
                a.x, a.y, b.x, b.y
            ),
        }
    }
}

impl std::error::Error for NoPath {}

impl AnyAnglePlanner {
    /// Corners in the graph: the grown corners a robot with a radius may stand at, or for
    /// point robots every convex corner of the map.
    pub fn vertex_count(&self) -> usize {
        self.corners
    }

    /// Edges among the corners linked so far (each counted once); all of them after
    /// [`link_all`](Self::link_all). Point robots' searches link none.
    pub fn edge_count(&self) -> usize {
        self.graph
            .get()
            .and_then(Option::as_ref)
            .map_or(0, build::Graph::edge_count)
    }

    /// The robot radius the planner was built for, metres.
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// Heap bytes of the graph, the cell raster, the map (robots with a radius) and the
    /// regions (point robots).
    pub fn memory_bytes(&self) -> usize {
        self.raster.memory_bytes()
            + self
                .graph
                .get()
                .and_then(Option::as_ref)
                .map_or(0, build::Graph::memory_bytes)
            + self.obstacles.as_ref().map_or(0, ObstacleMap::memory_bytes)
            + self.regions.as_ref().map_or(0, regions::Regions::memory_bytes)
    }

    /// Whether a robot of the planner's radius may move straight from `a` to `b` (world
    /// coordinates) under the planner's rules.
    pub fn is_leg_clear(&self, a: DVec2, b: DVec2) -> bool {
        let (a, b) = (self.to_cells(a), self.to_cells(b));
        self.stand_clear(a) && self.stand_clear(b) && self.clear(a, b)
    }

    fn to_cells(&self, p: DVec2) -> DVec2 {
        (p - self.grid.origin()) / self.grid.cell_m()
    }

    fn to_world(&self, p: DVec2) -> DVec2 {
        self.grid.origin() + p * self.grid.cell_m()
    }

    /// Whether a robot may stand at `p` (cell units).
    fn stand_clear(&self, p: DVec2) -> bool {
        match &self.obstacles {
            None => sight::point_clear(&self.raster, p),
            Some(map) => map.is_disc_free(self.to_world(p), self.radius_m),
        }
    }
}

#[cfg(test)]
mod tests;
