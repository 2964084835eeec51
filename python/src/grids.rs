//! Windows of a map's cells as arrays: what a robot knows (0 unknown, 1 free, 2 blocked) and
//! where the obstacles are (0 free, 1 blocked). Row `j`, column `i` of a window is the cell
//! `(x0 + i, y0 + j)`: row 0 is the southern edge (`imshow(..., origin="lower")` draws it
//! the right way up).

use pyo3::prelude::*;
use sim_core::spatial::{Grid, KnownMap, ObstacleMap};

/// Unknown cell.
pub(crate) const UNKNOWN: u8 = 0;
/// Known free cell.
pub(crate) const FREE: u8 = 1;
/// Known blocked cell (or beyond the map's edge).
pub(crate) const BLOCKED: u8 = 2;

/// A rectangle of cells of a map: `width × height` cells from cell `(x0, y0)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Window {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl Window {
    /// The cells of `grid` that the rectangle `x0, y0, width_m, height_m` (metres; the whole
    /// map for what is not given) overlaps, clipped to the map.
    pub fn of(
        grid: &Grid,
        x0: Option<f64>,
        y0: Option<f64>,
        width_m: Option<f64>,
        height_m: Option<f64>,
    ) -> PyResult<Self> {
        let ext = grid.extent();
        let (x0, y0) = (x0.unwrap_or(ext.min.x), y0.unwrap_or(ext.min.y));
        let width_m = width_m.unwrap_or(ext.max.x - x0);
        let height_m = height_m.unwrap_or(ext.max.y - y0);
        if ![x0, y0, width_m, height_m].iter().all(|v| v.is_finite()) || width_m < 0.0 || height_m < 0.0 {
            return Err(crate::to_py(format!(
                "a window needs finite x0, y0 and width_m, height_m ≥ 0; got {x0}, {y0}, {width_m}, {height_m}"
            )));
        }
        // The cells the rectangle overlaps: from the one holding its near corner to the one
        // holding its far corner (exclusive when it lies on a cell's edge), within the map.
        let cell = grid.cell_m();
        let span = |from: f64, len: f64, origin: f64, limit: u32| {
            let lo = ((from - origin) / cell).floor().clamp(0.0, f64::from(limit)) as u32;
            let hi = ((from + len - origin) / cell)
                .ceil()
                .clamp(f64::from(lo), f64::from(limit)) as u32;
            (lo, hi - lo)
        };
        let (x, width) = span(x0, width_m, ext.min.x, grid.width_cells());
        let (y, height) = span(y0, height_m, ext.min.y, grid.height_cells());
        Ok(Self {
            x0: x,
            y0: y,
            width,
            height,
        })
    }

    /// `cells × cells` cells centred on the cell holding `p` (which may run off the map).
    pub fn around(grid: &Grid, p: sim_core::glam::DVec2, cells: u32) -> (i64, i64) {
        let rel = (p - grid.origin()) / grid.cell_m();
        let half = i64::from(cells / 2);
        (rel.x.floor() as i64 - half, rel.y.floor() as i64 - half)
    }
}

/// Writes the obstacle cells of `w` (0 free, 1 blocked), row by row from the south.
pub(crate) fn obstacle_cells(obstacles: &ObstacleMap, w: Window, out: &mut Vec<u8>) {
    let tree = obstacles.tree();
    out.clear();
    out.reserve((w.width as usize) * (w.height as usize));
    for y in w.y0..w.y0 + w.height {
        out.extend((w.x0..w.x0 + w.width).map(|x| u8::from(tree.cell_value(x, y))));
    }
}

/// Writes what `known` holds of `w` (0 unknown, 1 free, 2 blocked), row by row from the south.
pub(crate) fn known_cells(known: &KnownMap, obstacles: &ObstacleMap, w: Window, out: &mut Vec<u8>) {
    out.clear();
    out.reserve((w.width as usize) * (w.height as usize));
    for y in w.y0..w.y0 + w.height {
        out.extend((w.x0..w.x0 + w.width).map(|x| known_cell(known, obstacles, i64::from(x), i64::from(y))));
    }
}

/// What `known` holds of cell `(x, y)`; cells off the map are walls.
#[inline]
pub(crate) fn known_cell(known: &KnownMap, obstacles: &ObstacleMap, x: i64, y: i64) -> u8 {
    let grid = obstacles.grid();
    let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y)) else {
        return BLOCKED;
    };
    if x >= grid.width_cells() || y >= grid.height_cells() {
        BLOCKED
    } else if !known.tree().cell_value(x, y) {
        UNKNOWN
    } else if obstacles.tree().cell_value(x, y) {
        BLOCKED
    } else {
        FREE
    }
}

/// The `cells × cells` patch of `known` centred on `p`, into `out` (appended), row by row
/// from the south.
pub(crate) fn patch(
    known: &KnownMap,
    obstacles: &ObstacleMap,
    p: sim_core::glam::DVec2,
    cells: u32,
    out: &mut Vec<u8>,
) {
    let (x0, y0) = Window::around(obstacles.grid(), p, cells);
    let n = i64::from(cells);
    for y in y0..y0 + n {
        out.extend((x0..x0 + n).map(|x| known_cell(known, obstacles, x, y)));
    }
}
