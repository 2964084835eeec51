//! Placement of the map's cell grid on the world plane.

use glam::DVec2;

use crate::spatial::geometry::Aabb;
use crate::{Error, Result};

/// Deepest quadtree supported: 2^24 cells a side (16,777 km at 1 m cells).
pub const MAX_DEPTH: u8 = 24;

/// The map's cell grid: `width_cells × height_cells` square cells of `cell_m` metres, with
/// cell (0, 0) at the lower-left corner `origin` (x right, y up). The quadtrees cover the
/// smallest power-of-two square of cells holding the grid; cells beyond the grid are padding.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Grid {
    origin: DVec2,
    cell_m: f64,
    width_cells: u32,
    height_cells: u32,
    depth: u8,
}

impl Grid {
    /// A grid of `width_cells × height_cells` cells of `cell_m` metres whose lower-left corner
    /// is at `origin`. Fails on empty or oversized grids and non-finite or non-positive sizes.
    pub fn new(origin: DVec2, cell_m: f64, width_cells: u32, height_cells: u32) -> Result<Self> {
        if !(cell_m.is_finite() && cell_m > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "cell size must be a positive number of metres, got {cell_m}"
            )));
        }
        if !origin.is_finite() {
            return Err(Error::InvalidParameter(format!(
                "map origin must be finite, got {origin}"
            )));
        }
        let max_side = 1u32 << MAX_DEPTH;
        if width_cells == 0 || height_cells == 0 || width_cells > max_side || height_cells > max_side {
            return Err(Error::InvalidParameter(format!(
                "map must be between 1 and {max_side} cells a side, got {width_cells} × {height_cells}"
            )));
        }
        let side = width_cells.max(height_cells).next_power_of_two();
        Ok(Self {
            origin,
            cell_m,
            width_cells,
            height_cells,
            depth: side.trailing_zeros() as u8,
        })
    }

    /// A grid covering `width_m × height_m` metres (rounded up to whole cells).
    pub fn from_size_m(origin: DVec2, cell_m: f64, width_m: f64, height_m: f64) -> Result<Self> {
        if !(width_m.is_finite() && height_m.is_finite() && width_m > 0.0 && height_m > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "map size must be positive, got {width_m} m × {height_m} m"
            )));
        }
        if !(cell_m.is_finite() && cell_m > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "cell size must be positive, got {cell_m} m"
            )));
        }
        let cells = |m: f64| -> Result<u32> {
            let c = (m / cell_m).ceil();
            if c.is_finite() && c >= 1.0 && c <= f64::from(1u32 << MAX_DEPTH) {
                Ok(c as u32)
            } else {
                Err(Error::InvalidParameter(format!(
                    "a map side of {m} m at {cell_m} m cells needs {c} cells, more than the {} supported",
                    1u32 << MAX_DEPTH
                )))
            }
        };
        Self::new(origin, cell_m, cells(width_m)?, cells(height_m)?)
    }

    /// World position of the map's lower-left corner.
    pub fn origin(&self) -> DVec2 {
        self.origin
    }
    /// Side of one cell in metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }
    /// Map width in cells.
    pub fn width_cells(&self) -> u32 {
        self.width_cells
    }
    /// Map height in cells.
    pub fn height_cells(&self) -> u32 {
        self.height_cells
    }
    /// Depth of the covering quadtree: its side is `2^depth` cells.
    pub fn depth(&self) -> u8 {
        self.depth
    }
    /// Side of the covering square in cells.
    pub fn side_cells(&self) -> u32 {
        1 << self.depth
    }
    /// Map width in metres.
    pub fn width_m(&self) -> f64 {
        f64::from(self.width_cells) * self.cell_m
    }
    /// Map height in metres.
    pub fn height_m(&self) -> f64 {
        f64::from(self.height_cells) * self.cell_m
    }
    /// The map's extent in world coordinates.
    pub fn extent(&self) -> Aabb {
        Aabb {
            min: self.origin,
            max: self.corner(self.width_cells, self.height_cells),
        }
    }

    /// World position of the corner between cells: `origin + (x, y) · cell_m`. Every box the
    /// grid hands out is made of such corners, computed this one way, so boxes that share an
    /// edge agree on it to the last bit.
    #[inline]
    pub fn corner(&self, x: u32, y: u32) -> DVec2 {
        self.origin + DVec2::new(f64::from(x), f64::from(y)) * self.cell_m
    }
    /// Area of one cell in m².
    pub fn cell_area_m2(&self) -> f64 {
        self.cell_m * self.cell_m
    }

    /// World box of the square of `2^level` cells whose lower-left cell is `(x, y)`.
    #[inline]
    pub fn square(&self, x: u32, y: u32, level: u8) -> Aabb {
        let size = 1u32 << level;
        Aabb {
            min: self.corner(x, y),
            max: self.corner(x + size, y + size),
        }
    }

    /// The cell holding world point `p` (cells are half-open: `[x, x+1)`), or `None` outside the
    /// covering square.
    pub fn cell_of(&self, p: DVec2) -> Option<(u32, u32)> {
        let c = (p - self.origin) / self.cell_m;
        let side = f64::from(self.side_cells());
        if c.x >= 0.0 && c.y >= 0.0 && c.x < side && c.y < side {
            Some((c.x as u32, c.y as u32))
        } else {
            None
        }
    }

    /// The cells of the covering square that the box touches, as the inclusive corners
    /// `((x0, y0), (x1, y1))` (a cell whose edge the box merely touches included, so none
    /// the box may overlap is left out), or `None` if the box misses the covering square.
    #[inline]
    pub(crate) fn cells_touching(&self, area: &Aabb) -> Option<((u32, u32), (u32, u32))> {
        let side = self.side_cells();
        let lo = (area.min - self.origin) / self.cell_m;
        let hi = (area.max - self.origin) / self.cell_m;
        if !(hi.x >= 0.0 && hi.y >= 0.0 && lo.x < f64::from(side) && lo.y < f64::from(side)) {
            return None;
        }
        // No coordinate is NaN past the test above. Clamped to the covering square first,
        // a coordinate is at least 0, where the cast's truncation is the floor, so no floor
        // is taken. Checked by `cells_touching_matches_a_scan`.
        let last = f64::from(side - 1);
        let cell = |v: f64| v.clamp(0.0, last) as u32;
        Some(((cell(lo.x), cell(lo.y)), (cell(hi.x), cell(hi.y))))
    }

    /// [`cells_touching`](Self::cells_touching) for the box widened by its rounding
    /// margin: every cell a test with the box's own arithmetic might find it meets.
    #[inline]
    pub(crate) fn cells_near(&self, area: &Aabb) -> Option<((u32, u32), (u32, u32))> {
        let eps = DVec2::splat(area.rounding_margin());
        self.cells_touching(&Aabb {
            min: area.min - eps,
            max: area.max + eps,
        })
    }

    /// Whether cell `(x, y)` lies inside the map (not in the padding).
    pub fn in_map(&self, x: u32, y: u32) -> bool {
        x < self.width_cells && y < self.height_cells
    }

    /// World centre of cell `(x, y)`.
    pub fn cell_center(&self, x: u32, y: u32) -> DVec2 {
        self.origin + (DVec2::new(f64::from(x), f64::from(y)) + 0.5) * self.cell_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_covers_the_map() {
        let g = Grid::new(DVec2::ZERO, 1.0, 100, 30).unwrap();
        assert_eq!(g.side_cells(), 128);
        let g = Grid::new(DVec2::ZERO, 1.0, 1, 1).unwrap();
        assert_eq!(g.depth(), 0);
        // 100 km at 1 m fits in depth 17 (131,072 cells).
        let g = Grid::from_size_m(DVec2::ZERO, 1.0, 100_000.0, 100_000.0).unwrap();
        assert_eq!(g.depth(), 17);
    }

    #[test]
    fn nonsense_is_refused() {
        assert!(Grid::new(DVec2::ZERO, 0.0, 10, 10).is_err());
        assert!(Grid::new(DVec2::ZERO, f64::NAN, 10, 10).is_err());
        assert!(Grid::new(DVec2::ZERO, 1.0, 0, 10).is_err());
        assert!(Grid::from_size_m(DVec2::ZERO, 1e-9, 1e9, 10.0).is_err());
        assert!(Grid::from_size_m(DVec2::ZERO, 1.0, -5.0, 10.0).is_err());
    }

    #[test]
    fn cells_are_half_open() {
        let g = Grid::new(DVec2::new(-10.0, 5.0), 0.5, 8, 8).unwrap();
        assert_eq!(g.cell_of(DVec2::new(-10.0, 5.0)), Some((0, 0)));
        assert_eq!(g.cell_of(DVec2::new(-9.5, 5.49)), Some((1, 0)));
        assert_eq!(g.cell_of(DVec2::new(-10.01, 5.0)), None);
        assert_eq!(g.cell_of(DVec2::new(-6.0, 5.0)), None);
    }

    /// The cells a box touches (clamped without a floor) are those a scan of the covering
    /// square finds: from the cell holding the box's low corner to the one holding its high
    /// corner (cells half-open), clamped to the square, or none if it misses. Coordinates
    /// on the half-cell lattice, where every product is exact, half of them on cell edges,
    /// and some infinite.
    #[test]
    fn cells_touching_matches_a_scan() {
        use rand::{Rng, SeedableRng};
        let grid = Grid::new(DVec2::new(-3.5, 7.0), 0.5, 20, 12).unwrap();
        let side = grid.side_cells();
        let edge = |k: u32, o: f64| o + 0.5 * f64::from(k);
        // The last cell whose low edge is at or below `v`, if any.
        let holding = |v: f64, o: f64| (0..side).filter(|&k| edge(k, o) <= v).max();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut coordinate = |o: f64| match rng.random_range(0..10) {
            0 => f64::NEG_INFINITY,
            1 => f64::INFINITY,
            2..=5 => o + 0.5 * f64::from(rng.random_range(-8i32..24)),
            _ => o + rng.random_range(-4.0..12.0),
        };
        let mut some = 0;
        for _ in 0..20_000 {
            let (x, y) = ((coordinate(-3.5), coordinate(-3.5)), (coordinate(7.0), coordinate(7.0)));
            let area = Aabb {
                min: DVec2::new(x.0.min(x.1), y.0.min(y.1)),
                max: DVec2::new(x.0.max(x.1), y.0.max(y.1)),
            };
            let square_end = |o: f64| edge(side, o);
            let misses = area.max.x < -3.5
                || area.max.y < 7.0
                || area.min.x >= square_end(-3.5)
                || area.min.y >= square_end(7.0);
            let want = (!misses).then(|| {
                let lo = (
                    holding(area.min.x, -3.5).unwrap_or(0),
                    holding(area.min.y, 7.0).unwrap_or(0),
                );
                let hi = (
                    holding(area.max.x, -3.5).unwrap_or(0),
                    holding(area.max.y, 7.0).unwrap_or(0),
                );
                (lo, hi)
            });
            some += usize::from(want.is_some());
            assert_eq!(grid.cells_touching(&area), want, "{area:?}");
        }
        assert!(some > 5_000, "{some} boxes touch the square");
    }
}
