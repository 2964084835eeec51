//! Small helpers for maps built from a full raster (imports, caves, mazes, rooms).

use sim_core::glam::DVec2;
use sim_core::spatial::BitGrid;
use sim_core::spatial::{Grid, ObstacleMap};

use crate::{EditorError, Result};

/// Largest raster the editor allocates: 2^34 cells (2 GiB of bits). Bigger maps must be
/// built block by block (`generate fractal`, `generate mesas`).
pub const MAX_RASTER_CELLS: u64 = 1 << 34;

/// Refuse rasters that would not fit in a few GB.
pub fn check_raster_size(width: u32, height: u32, what: &str) -> Result<()> {
    let cells = u64::from(width) * u64::from(height);
    if cells > MAX_RASTER_CELLS {
        return Err(EditorError::InvalidParameter(format!(
            "{what} needs a full raster of {width} × {height} cells, more than the {MAX_RASTER_CELLS} allowed; \
             use a coarser --cell-m or a block-wise generator (fractal, mesas)"
        )));
    }
    Ok(())
}

/// Smallest cell side accepted, relative to the largest coordinate of the map: below it the
/// corners of neighbouring cells are no longer (reliably) different numbers.
pub const MIN_RELATIVE_CELL: f64 = 1e-9;

/// A grid of `width × height` cells whose lower-left corner is `origin`. Besides
/// [`Grid::new`]'s checks, refuses grids whose coordinates or areas cannot be computed with:
/// a corner or the map's area that overflows, a cell area that underflows, or cells too small
/// for the magnitude of their coordinates (e.g. 5 cm cells at x = 10²⁰ m).
pub fn grid(origin: DVec2, cell_m: f64, width: u32, height: u32) -> Result<Grid> {
    let g = Grid::new(origin, cell_m, width, height)?;
    let far = g.corner(g.side_cells(), g.side_cells());
    let largest = origin.abs().max(far.abs()).max_element();
    let usable = far.is_finite()
        && (g.width_m() * g.height_m()).is_finite()
        && (cell_m * cell_m).is_normal()
        && cell_m >= largest * MIN_RELATIVE_CELL;
    if usable {
        Ok(g)
    } else {
        Err(EditorError::InvalidParameter(format!(
            "{width} × {height} cells of {cell_m} m with the lower-left corner at ({}, {}) cannot be computed with \
             (coordinates or areas overflow, or the cells are too small for coordinates of that size); \
             choose another resolution or origin",
            origin.x, origin.y
        )))
    }
}

/// Build an obstacle map from a raster whose row 0 is the **top** row (image order):
/// `blocked(col, row)` is asked once per cell.
pub fn map_from_top_rows(grid: Grid, mut blocked: impl FnMut(u32, u32) -> bool) -> Result<ObstacleMap> {
    let (w, h) = (grid.width_cells(), grid.height_cells());
    let mut bits = BitGrid::new(w, h);
    for row in 0..h {
        let y = h - 1 - row;
        for col in 0..w {
            if blocked(col, row) {
                bits.set(col, y, true);
            }
        }
    }
    Ok(ObstacleMap::from_bitgrid(grid, &bits)?)
}

/// A byte raster (one byte per cell, row 0 at the bottom) used by the raster generators.
#[derive(Clone, Debug)]
pub struct Cells {
    /// Width in cells.
    pub width: u32,
    /// Height in cells.
    pub height: u32,
    /// `width × height` values, row-major, row 0 at the bottom; non-zero = blocked.
    pub data: Vec<u8>,
}

impl Cells {
    /// A raster of `width × height` cells, all set to `value`.
    pub fn new(width: u32, height: u32, value: u8) -> Self {
        Self {
            width,
            height,
            data: vec![value; (u64::from(width) * u64::from(height)) as usize],
        }
    }
    /// Index of cell `(x, y)`.
    #[inline]
    pub fn idx(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }
    /// Value of `(x, y)`.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> u8 {
        self.data[self.idx(x, y)]
    }
    /// Set `(x, y)`.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: u8) {
        let i = self.idx(x, y);
        self.data[i] = v;
    }
    /// The obstacle map of the non-zero cells.
    pub fn to_map(&self, grid: Grid) -> ObstacleMap {
        ObstacleMap::from_fn(grid, |x, y| self.get(x, y) != 0)
    }
}
