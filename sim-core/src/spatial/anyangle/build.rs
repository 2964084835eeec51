//! The visibility graph: convex corners of the blocked cells, joined where they see each
//! other along a line that grazes both corners.

use glam::DVec2;
use rayon::prelude::*;

use super::raster::CellRaster;
use super::sight::segment_clear;
use super::{AnyAnglePlanner, Vertex};
use crate::spatial::obstacle_map::ObstacleMap;
use crate::{Error, Result};

/// Most corners the planner links all-pairs. Building costs one line-of-sight test per pair
/// of corners, so a map with many more would take minutes; it is refused with its count.
pub const MAX_VERTICES: usize = 60_000;

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
    /// rules of the Moving AI benchmarks). Fails on a negative or non-finite radius, a map too
    /// large for one bit per cell, or more than [`MAX_VERTICES`] corners.
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
            if vertices.len() > MAX_VERTICES {
                return Err(Error::InvalidParameter(format!(
                    "any-angle paths link every pair of obstacle corners; this map has more than \
                     {MAX_VERTICES} corners (more than the planner handles)"
                )));
            }
        }
        let mut planner = Self {
            grid,
            radius_m,
            raster,
            vertices,
            starts: Vec::new(),
            adjacent: Vec::new(),
            obstacles: (radius_m > 0.0).then(|| obstacles.clone()),
        };
        let upper: Vec<Vec<u32>> = (0..planner.vertices.len())
            .into_par_iter()
            .map(|i| {
                let u = planner.vertices[i];
                (i + 1..planner.vertices.len())
                    .filter(|&j| {
                        let v = planner.vertices[j];
                        let d = v.pos - u.pos;
                        grazes(u.quadrant, d) && grazes(v.quadrant, d) && planner.clear(u.pos, v.pos)
                    })
                    .map(|j| u32::try_from(j).expect("vertex count is bounded"))
                    .collect()
            })
            .collect();
        let mut degree = vec![0u32; planner.vertices.len()];
        for (i, list) in upper.iter().enumerate() {
            degree[i] += u32::try_from(list.len()).expect("vertex count is bounded");
            for &j in list {
                degree[j as usize] += 1;
            }
        }
        let mut starts = Vec::with_capacity(degree.len() + 1);
        let mut total = 0u32;
        starts.push(0);
        for d in &degree {
            total += d;
            starts.push(total);
        }
        let mut fill: Vec<u32> = starts[..degree.len()].to_vec();
        let mut adjacent = vec![0u32; total as usize];
        for (i, list) in upper.iter().enumerate() {
            for &j in list {
                adjacent[fill[i] as usize] = j;
                fill[i] += 1;
                adjacent[fill[j as usize] as usize] = u32::try_from(i).expect("vertex count is bounded");
                fill[j as usize] += 1;
            }
        }
        planner.starts = starts;
        planner.adjacent = adjacent;
        Ok(planner)
    }

    /// Whether the straight move `a → b` (cell units) is legal for the planner's robots.
    pub(crate) fn clear(&self, a: DVec2, b: DVec2) -> bool {
        if !segment_clear(&self.raster, a, b) {
            return false;
        }
        match &self.obstacles {
            None => true,
            Some(map) => {
                let g = self.grid;
                map.is_swept_disc_free(g.origin() + a * g.cell_m(), g.origin() + b * g.cell_m(), self.radius_m)
            }
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
