//! The any-angle path bench: a map's corners and the planner's build time (and, for robots
//! with a radius, the visibility graph's size and linking time), then query times and,
//! where the queries carry published optima, how far the paths are from them.

use std::time::Instant;

/// The bench's queries and maps, shared with the editor's timing harness.
pub use editor::path::{PathQuery, load_map, random_queries, read_scenario};
use sim_core::spatial::{AnyAnglePlanner, KnownMap, NavGraph, ObstacleMap, Terrain};

use crate::Result;

/// What the bench measured.
#[derive(Clone, Debug, PartialEq)]
pub struct PathBench {
    /// Corners in the visibility graph.
    pub vertices: usize,
    /// Its edges (0 for point robots: none is linked).
    pub edges: usize,
    /// Seconds to build the planner (find the corners, and a point robot's free regions).
    pub build_s: f64,
    /// Seconds to link every corner (the whole visibility graph, on all threads); 0 for
    /// point robots, whose queries (Anya) search no graph.
    pub link_s: f64,
    /// Mean time of a query on a planner just built (what `smartteams-editor path` pays
    /// beyond the build), over the first ten queries, milliseconds.
    pub cold_query_ms: f64,
    /// Heap bytes of the planner.
    pub memory_bytes: usize,
    /// Queries run.
    pub queries: usize,
    /// Queries with a path.
    pub reachable: usize,
    /// Mean query (on the linked graph, for robots with a radius), milliseconds.
    pub mean_query_ms: f64,
    /// Slowest query, milliseconds.
    pub max_query_ms: f64,
    /// Over queries with a published any-angle optimum: mean and worst relative excess of
    /// the path's length over it (negative = shorter, within the file's rounding).
    pub excess: Option<(f64, f64)>,
    /// Queries whose reachability disagrees with the octile column (0 = unreachable).
    pub reachability_mismatches: usize,
}

/// Build the planner for `radius_m`; time the first ten queries each on a planner just
/// built; link every corner if the robot has a radius (point robots' queries search no
/// graph); then run every query once, one after another.
pub fn bench(map: &ObstacleMap, queries: &[PathQuery], radius_m: f64) -> Result<PathBench> {
    let t = Instant::now();
    let planner = AnyAnglePlanner::build(map, radius_m)?;
    let build_s = t.elapsed().as_secs_f64();
    let mut cold = 0.0;
    let first = &queries[..queries.len().min(10)];
    for q in first {
        let fresh = AnyAnglePlanner::build(map, radius_m)?;
        let t = Instant::now();
        let _ = fresh.path(q.from, q.to);
        cold += t.elapsed().as_secs_f64() * 1e3;
    }
    let t = Instant::now();
    if radius_m > 0.0 {
        planner.link_all();
    }
    let link_s = t.elapsed().as_secs_f64();
    let (mut total, mut max, mut reachable, mut mismatches) = (0.0, 0.0f64, 0, 0);
    let mut excess = Vec::new();
    for q in queries {
        let t = Instant::now();
        let found = planner.path(q.from, q.to);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        total += ms;
        max = max.max(ms);
        reachable += usize::from(found.is_ok());
        if let Some(oct) = q.octile {
            let says_reachable = oct > 0.0 || q.from == q.to;
            mismatches += usize::from(says_reachable != found.is_ok());
        }
        if let (Some(best), Ok(p)) = (q.optimum, &found)
            && best > 0.0
        {
            excess.push(p.length_m / best - 1.0);
        }
    }
    Ok(PathBench {
        vertices: planner.vertex_count(),
        edges: planner.edge_count(),
        build_s,
        link_s,
        cold_query_ms: mean(cold, first.len()),
        memory_bytes: planner.memory_bytes(),
        queries: queries.len(),
        reachable,
        mean_query_ms: mean(total, queries.len()),
        max_query_ms: max,
        excess: mean_and_worst(&excess),
        reachability_mismatches: mismatches,
    })
}

/// What the navigation-graph bench measured.
#[derive(Clone, Debug, PartialEq)]
pub struct NavBench {
    /// Free leaves of the map's quadtree.
    pub free_leaves: usize,
    /// Pieces (nodes) they merged into.
    pub pieces: usize,
    /// Edges between pieces.
    pub edges: usize,
    /// Seconds to build the graph.
    pub build_s: f64,
    /// Heap bytes of the graph.
    pub memory_bytes: usize,
    /// Queries run, and those with a route.
    pub queries: usize,
    /// Queries with a route.
    pub reachable: usize,
    /// Mean and slowest route query (the whole map known), milliseconds.
    pub mean_query_ms: f64,
    /// Slowest query, milliseconds.
    pub max_query_ms: f64,
    /// Over reachable queries the exact any-angle planner also answered: how many, and the
    /// mean and worst relative excess of the route's length over a point's exact optimum.
    pub excess: Option<(usize, f64, f64)>,
}

/// Build the kernel's navigation graph of `map`, then route each query for a robot of
/// `radius_m` that knows the whole map, and compare the lengths with the exact any-angle
/// planner's point paths where it can be built (maps of at most `compare_cells` cells).
pub fn nav_bench(map: &ObstacleMap, queries: &[PathQuery], radius_m: f64, compare_cells: u64) -> Result<NavBench> {
    let t = Instant::now();
    let graph = NavGraph::build(map);
    let build_s = t.elapsed().as_secs_f64();
    let mut known = KnownMap::new(*map.grid());
    known.mark(&map.grid().extent());
    let terrain = Terrain {
        obstacles: map,
        known: &known,
        radius_m,
    };
    let g = map.grid();
    let cells = u64::from(g.width_cells()) * u64::from(g.height_cells());
    let exact = if cells <= compare_cells {
        AnyAnglePlanner::build(map, 0.0).ok()
    } else {
        None
    };
    let (mut total, mut max, mut reachable) = (0.0, 0.0f64, 0);
    let mut excess = Vec::new();
    for q in queries {
        let t = Instant::now();
        let route = graph.route_within(terrain, q.from, q.to, usize::MAX);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        total += ms;
        max = max.max(ms);
        let Some(route) = route else { continue };
        reachable += 1;
        if let Some(Ok(best)) = exact.as_ref().map(|p| p.path(q.from, q.to))
            && best.length_m > 0.0
        {
            excess.push(route.length_m / best.length_m - 1.0);
        }
    }
    Ok(NavBench {
        free_leaves: graph.leaf_count(),
        pieces: graph.len(),
        edges: graph.edge_count(),
        build_s,
        memory_bytes: graph.memory_bytes(),
        queries: queries.len(),
        reachable,
        mean_query_ms: mean(total, queries.len()),
        max_query_ms: max,
        excess: mean_and_worst(&excess).map(|(mean, worst)| (excess.len(), mean, worst)),
    })
}

/// `total` over `n` (0 for none).
#[allow(clippy::cast_precision_loss)] // Counts far below 2^52.
fn mean(total: f64, n: usize) -> f64 {
    if n == 0 { 0.0 } else { total / n as f64 }
}

/// The mean and the largest of `values`, if there are any.
fn mean_and_worst(values: &[f64]) -> Option<(f64, f64)> {
    (!values.is_empty()).then(|| {
        (
            mean(values.iter().sum(), values.len()),
            values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    })
}
