//! The visibility graph: convex corners of the blocked cells, joined where they see each
//! other along a line that grazes both corners.

use std::sync::OnceLock;

use glam::DVec2;
use rayon::prelude::*;

use super::raster::CellRaster;
use super::sight::segment_between_legal_ends_clear;
use super::{AnyAnglePlanner, Vertex};
use crate::spatial::obstacle_map::ObstacleMap;
use crate::{Error, Result};

/// Most corners a visibility graph holds. Linking a corner costs one line-of-sight test per
/// corner of the map, so a search that expands `k` corners costs `k` times that the first
/// time; a map with many more corners is refused rather than taking minutes a query. Point
/// robots' searches (Anya) link no corner: any number is accepted, and only should Anya fail
/// is a graph wanted, which above this many corners answers
/// [`NoPath::Undecided`](super::NoPath::Undecided).
pub const MAX_VERTICES: usize = 250_000;

/// Whether a line along `d` through a corner whose one blocked cell lies in `quadrant`
/// (0 south-west, 1 south-east, 2 north-west, 3 north-east) only grazes that cell: neither
/// `d` nor `-d` points into it. Shortest paths bend only at such corners and only along such
/// lines, so other pairs of corners need no edge.
#[inline]
pub(crate) fn grazes(quadrant: u8, d: DVec2) -> bool {
    let p = d.x * d.y;
    if quadrant == 0 || quadrant == 3 {
        p <= 0.0
    } else {
        p >= 0.0
    }
}

/// The visibility graph's corners and their links.
#[derive(Clone, Debug)]
pub(crate) struct Graph {
    pub(super) vertices: Vec<Vertex>,
    /// Each corner's neighbours, once linked.
    links: Vec<OnceLock<Box<[u32]>>>,
}

impl Graph {
    pub(crate) fn edge_count(&self) -> usize {
        self.links
            .iter()
            .filter_map(|l| l.get())
            .map(|l| l.len())
            .sum::<usize>()
            / 2
    }

    pub(crate) fn memory_bytes(&self) -> usize {
        self.vertices.capacity() * std::mem::size_of::<Vertex>()
            + self
                .links
                .iter()
                .map(|l| std::mem::size_of_val(l) + l.get().map_or(0, |n| n.len() * 4))
                .sum::<usize>()
    }
}

/// Whether lattice point `(x, y)` is a convex corner: exactly one of its four cells is
/// blocked (`quadrant` tells which).
fn convex_corner(raster: &CellRaster, x: i64, y: i64) -> Option<u8> {
    let around = raster.around(x, y);
    // One bit set: its index is below 4.
    #[allow(clippy::cast_possible_truncation)]
    around.is_power_of_two().then_some(around.trailing_zeros() as u8)
}

/// The corners a robot bends at, or `None` for more than [`MAX_VERTICES`]: the convex
/// corners, or with `grown` (the map and a radius in metres) those corners grown by the
/// radius where a robot fits.
fn graph_corners(raster: &CellRaster, grown: Option<(&ObstacleMap, f64)>) -> Option<Vec<Vertex>> {
    let radius_cells = grown.map_or(0.0, |(map, r)| r / map.grid().cell_m());
    let mut vertices = Vec::new();
    for y in 0..=raster.height() {
        for x in 0..=raster.width() {
            let Some(quadrant) = convex_corner(raster, x, y) else {
                continue;
            };
            // A robot bends round the corner of the cell grown by its radius (a square, so
            // the path keeps at least the radius clear and is at most slightly longer).
            let away = DVec2::new(
                if quadrant & 1 == 0 { 1.0 } else { -1.0 },
                if quadrant & 2 == 0 { 1.0 } else { -1.0 },
            );
            #[allow(clippy::cast_precision_loss)] // Lattice coordinates below 2^31.
            let pos = DVec2::new(x as f64, y as f64) + away * radius_cells;
            let fits = grown.is_none_or(|(map, r)| {
                let g = map.grid();
                map.is_disc_free(g.origin() + pos * g.cell_m(), r)
            });
            if fits {
                vertices.push(Vertex { pos, quadrant });
            }
        }
        if vertices.len() > MAX_VERTICES {
            return None;
        }
    }
    Some(vertices)
}

impl AnyAnglePlanner {
    /// The planner for `obstacles` and robots of `radius_m` (0 for points: the any-angle
    /// rules of the Moving AI benchmarks): the map's cells as bits, and for point robots the
    /// free space's connected regions, for robots with a radius the visibility graph's
    /// corners. Robots with a radius search that graph, linked as searches reach it (or all
    /// at once with [`link_all`](Self::link_all)); point robots' searches (Anya) need no
    /// graph and none is kept. Fails on a negative or non-finite radius, a map too large for
    /// one bit per cell, or, for a radius above 0, more than [`MAX_VERTICES`] corners.
    pub fn build(obstacles: &ObstacleMap, radius_m: f64) -> Result<Self> {
        if !(radius_m.is_finite() && radius_m >= 0.0) {
            return Err(Error::InvalidParameter(format!(
                "robot radius must be a non-negative number of metres, got {radius_m}"
            )));
        }
        let raster = CellRaster::from_obstacles(obstacles)?;
        let grid = *obstacles.grid();
        let graph = OnceLock::new();
        let (corners, regions, obstacles) = if radius_m == 0.0 {
            // Counted for statistics; a corner list would only serve the fallback.
            let corners = (0..=raster.height())
                .map(|y| {
                    (0..=raster.width())
                        .filter(|&x| convex_corner(&raster, x, y).is_some())
                        .count()
                })
                .sum();
            // A point robot's searches ask which region each end is in: worked out as part
            // of building, not of the first query.
            (corners, Some(super::regions::Regions::new(&raster)), None)
        } else {
            let Some(vertices) = graph_corners(&raster, Some((obstacles, radius_m))) else {
                return Err(Error::InvalidParameter(format!(
                    "any-angle paths link obstacle corners pairwise; this map has more than \
                     {MAX_VERTICES} corners (more than the planner handles)"
                )));
            };
            let corners = vertices.len();
            let links = (0..corners).map(|_| OnceLock::new()).collect();
            let _ = graph.set(Some(Graph { vertices, links }));
            (corners, None, Some(obstacles.clone()))
        };
        Ok(Self {
            grid,
            radius_m,
            raster,
            corners,
            graph,
            obstacles,
            regions,
        })
    }

    /// The visibility graph, built now for a point robot's planner (the corners as they
    /// are, not grown), or `None` if it would have more than [`MAX_VERTICES`] corners.
    pub(crate) fn graph(&self) -> Option<&Graph> {
        self.graph
            .get_or_init(|| {
                let vertices = graph_corners(&self.raster, None)?;
                let links = (0..vertices.len()).map(|_| OnceLock::new()).collect();
                Some(Graph { vertices, links })
            })
            .as_ref()
    }

    /// Whether corners `i` and `j` are linked: they see each other along a line grazing both.
    fn linked(&self, graph: &Graph, i: usize, j: usize) -> bool {
        let (u, v) = (graph.vertices[i], graph.vertices[j]);
        let d = v.pos - u.pos;
        i != j && grazes(u.quadrant, d) && grazes(v.quadrant, d) && self.clear(u.pos, v.pos)
    }

    /// The corners `u` is linked to, found on first use (one line-of-sight test per corner of
    /// the map) and kept.
    pub(crate) fn neighbours<'g>(&self, graph: &'g Graph, u: usize) -> &'g [u32] {
        graph.links[u].get_or_init(|| {
            (0..graph.vertices.len())
                .filter(|&j| self.linked(graph, u, j))
                .map(|j| u32::try_from(j).expect("at most MAX_VERTICES corners"))
                .collect()
        })
    }

    /// Link every corner now, on all threads, testing each pair once (otherwise corners are
    /// linked as searches reach them): the whole visibility graph, for figures and for
    /// planners of robots with a radius shared by many queries. A point robot's planner,
    /// whose queries (Anya) use no graph, builds it first, and links nothing if it would
    /// have more than [`MAX_VERTICES`] corners.
    pub fn link_all(&self) {
        let Some(graph) = self.graph() else {
            return;
        };
        let n = graph.vertices.len();
        let id = |i: usize| u32::try_from(i).expect("at most MAX_VERTICES corners");
        let upper: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|i| (i + 1..n).filter(|&j| self.linked(graph, i, j)).map(id).collect())
            .collect();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, list) in upper.iter().enumerate() {
            for &j in list {
                lists[j as usize].push(id(i));
            }
        }
        for (i, (mut list, upper)) in lists.into_iter().zip(upper).enumerate() {
            // Lower neighbours first, then upper: increasing, as `neighbours` lists them.
            list.extend(upper);
            // A corner a search linked already holds the same list.
            let _ = graph.links[i].set(list.into_boxed_slice());
        }
    }

    /// Whether the straight move `a → b` (cell units) is legal for the planner's robots,
    /// for ends where a robot may stand (corners of the graph, a query's checked ends).
    pub(crate) fn clear(&self, a: DVec2, b: DVec2) -> bool {
        if !segment_between_legal_ends_clear(&self.raster, a, b) {
            return false;
        }
        match &self.obstacles {
            None => true,
            Some(map) => map.is_swept_disc_free(self.to_world(a), self.to_world(b), self.radius_m),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_grazes_a_corner_unless_it_points_into_the_blocked_cell() {
        // Blocked cell to the north-east of the corner.
        assert!(grazes(3, DVec2::new(1.0, -2.0)));
        assert!(grazes(3, DVec2::new(0.0, 1.0)));
        assert!(!grazes(3, DVec2::new(1.0, 1.0)));
        assert!(!grazes(3, DVec2::new(-1.0, -0.5)));
        // Blocked cell to the north-west.
        assert!(grazes(2, DVec2::new(1.0, 1.0)));
        assert!(!grazes(2, DVec2::new(-1.0, 2.0)));
    }
}
