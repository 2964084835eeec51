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

/// Most corners a planner for robots with a radius accepts. Linking a corner costs one
/// line-of-sight test per corner of the map, so a search that expands `k` corners costs `k`
/// times that the first time; a map with many more corners is refused rather than taking
/// minutes a query. Point robots' searches (Anya) link no corner: any number is accepted.
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

impl AnyAnglePlanner {
    /// The planner for `obstacles` and robots of `radius_m` (0 for points: the any-angle
    /// rules of the Moving AI benchmarks): the map's cells as bits and its corners, and for
    /// point robots the free space's connected regions. Robots with a radius search the
    /// visibility graph of the corners, linked as searches reach them (or all at once with
    /// [`link_all`](Self::link_all)); point robots' searches (Anya) link none. Fails on a
    /// negative or non-finite radius, a map too large for one bit per cell, or, for a radius
    /// above 0, more than [`MAX_VERTICES`] corners.
    pub fn build(obstacles: &ObstacleMap, radius_m: f64) -> Result<Self> {
        if !(radius_m.is_finite() && radius_m >= 0.0) {
            return Err(Error::InvalidParameter(format!(
                "robot radius must be a non-negative number of metres, got {radius_m}"
            )));
        }
        let raster = CellRaster::from_obstacles(obstacles)?;
        let grid = *obstacles.grid();
        let radius_cells = radius_m / grid.cell_m();
        let mut vertices = Vec::new();
        for y in 0..=raster.height() {
            for x in 0..=raster.width() {
                let around = raster.around(x, y);
                if around.count_ones() != 1 {
                    continue;
                }
                let quadrant = around.trailing_zeros() as u8;
                // A robot bends round the corner of the cell grown by its radius (a square, so
                // the path keeps at least the radius clear and is at most slightly longer).
                let away = DVec2::new(
                    if quadrant & 1 == 0 { 1.0 } else { -1.0 },
                    if quadrant & 2 == 0 { 1.0 } else { -1.0 },
                );
                #[allow(clippy::cast_precision_loss)] // Lattice coordinates below 2^31.
                let pos = DVec2::new(x as f64, y as f64) + away * radius_cells;
                let v = Vertex { pos, quadrant };
                if radius_m == 0.0 || obstacles.is_disc_free(grid.origin() + pos * grid.cell_m(), radius_m) {
                    vertices.push(v);
                }
            }
            if radius_m > 0.0 && vertices.len() > MAX_VERTICES {
                return Err(Error::InvalidParameter(format!(
                    "any-angle paths link obstacle corners pairwise; this map has more than \
                     {MAX_VERTICES} corners (more than the planner handles)"
                )));
            }
        }
        let links = (0..vertices.len()).map(|_| OnceLock::new()).collect();
        // A point robot's searches ask which region each end is in (a few milliseconds on a
        // 768² map: part of building, not of the first query).
        let regions = OnceLock::new();
        if radius_m == 0.0 {
            let _ = regions.set(super::regions::Regions::new(&raster));
        }
        Ok(Self {
            grid,
            radius_m,
            raster,
            vertices,
            links,
            obstacles: (radius_m > 0.0).then(|| obstacles.clone()),
            regions,
        })
    }

    /// Whether corners `i` and `j` are linked: they see each other along a line grazing both.
    fn linked(&self, i: usize, j: usize) -> bool {
        let (u, v) = (self.vertices[i], self.vertices[j]);
        let d = v.pos - u.pos;
        i != j && grazes(u.quadrant, d) && grazes(v.quadrant, d) && self.clear(u.pos, v.pos)
    }

    /// The corners `u` is linked to, found on first use (one line-of-sight test per corner of
    /// the map) and kept.
    pub(crate) fn neighbours(&self, u: usize) -> &[u32] {
        self.links[u].get_or_init(|| {
            (0..self.vertices.len())
                .filter(|&j| self.linked(u, j))
                .map(|j| u32::try_from(j).expect("vertex count is bounded"))
                .collect()
        })
    }

    /// Link every corner now, on all threads, testing each pair once (otherwise corners are
    /// linked as searches reach them): the whole visibility graph, for figures and for
    /// planners of robots with a radius shared by many queries (point robots' queries do
    /// not use it).
    pub fn link_all(&self) {
        let n = self.vertices.len();
        let upper: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|i| {
                (i + 1..n)
                    .filter(|&j| self.linked(i, j))
                    .map(|j| u32::try_from(j).expect("vertex count is bounded"))
                    .collect()
            })
            .collect();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, list) in upper.iter().enumerate() {
            for &j in list {
                lists[j as usize].push(u32::try_from(i).expect("vertex count is bounded"));
            }
        }
        for (i, (mut list, upper)) in lists.into_iter().zip(upper).enumerate() {
            // Lower neighbours first, then upper: increasing, as `neighbours` lists them.
            list.extend(upper);
            // A corner a search linked already holds the same list.
            let _ = self.links[i].set(list.into_boxed_slice());
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
