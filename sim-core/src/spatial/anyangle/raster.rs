//! One bit per cell of the map, the form in which line-of-sight tests are cheapest.

use crate::spatial::obstacle_map::ObstacleMap;
use crate::{Error, Result};

/// Largest raster the planner allocates: 2^31 cells (256 MiB of bits). Larger maps are
/// refused with an error naming their size rather than exhausting memory.
pub const MAX_RASTER_CELLS: u64 = 1 << 31;

/// The map's cells as bits (1 = blocked), row 0 at the bottom. Cells outside the map read as
/// blocked, as the any-angle rules require.
///
/// Not a [`BitGrid`](crate::spatial::BitGrid): this is the line-of-sight hot path, and
/// `BitGrid`'s bounds-checked, 64-bit indexing would repeat the range check done here.
#[derive(Clone, Debug)]
pub(crate) struct CellRaster {
    width: i64,
    height: i64,
    /// Words per row.
    stride: usize,
    words: Vec<u64>,
}

impl CellRaster {
    /// The cells of an obstacle map. Fails on maps of more than [`MAX_RASTER_CELLS`] cells.
    pub(crate) fn from_obstacles(map: &ObstacleMap) -> Result<Self> {
        let g = map.grid();
        let (w, h) = (g.width_cells(), g.height_cells());
        let cells = u64::from(w) * u64::from(h);
        if cells > MAX_RASTER_CELLS {
            return Err(Error::InvalidParameter(format!(
                "any-angle paths need one bit per cell; this map has {w} × {h} = {cells} cells, \
                 more than the {MAX_RASTER_CELLS} the planner accepts"
            )));
        }
        let mut r = Self::empty(w, h);
        map.tree().for_each_leaf(|sq, blocked| {
            if !blocked || sq.x >= w || sq.y >= h {
                return;
            }
            let x_end = (sq.x + sq.side_cells()).min(w);
            let y_end = (sq.y + sq.side_cells()).min(h);
            for y in sq.y..y_end {
                for x in sq.x..x_end {
                    r.set(x, y);
                }
            }
        });
        Ok(r)
    }

    fn empty(width: u32, height: u32) -> Self {
        let stride = (width as usize).div_ceil(64);
        Self {
            width: i64::from(width),
            height: i64::from(height),
            stride,
            words: vec![0; stride * height as usize],
        }
    }

    fn set(&mut self, x: u32, y: u32) {
        let i = y as usize * self.stride + x as usize / 64;
        self.words[i] |= 1 << (x % 64);
    }

    /// Width in cells.
    pub(crate) fn width(&self) -> i64 {
        self.width
    }

    /// Height in cells.
    pub(crate) fn height(&self) -> i64 {
        self.height
    }

    /// Whether cell `(x, y)` is blocked; every cell outside the map is.
    #[inline]
    pub(crate) fn blocked(&self, x: i64, y: i64) -> bool {
        if x < 0 || y < 0 || x >= self.width || y >= self.height {
            return true;
        }
        // In range: both are non-negative and below u32::MAX.
        let (x, y) = (x as usize, y as usize);
        self.words[y * self.stride + x / 64] >> (x % 64) & 1 != 0
    }

    /// The blocked flags of the four cells around lattice point `(x, y)`, as bits
    /// 0: south-west, 1: south-east, 2: north-west, 3: north-east.
    #[inline]
    pub(crate) fn around(&self, x: i64, y: i64) -> u8 {
        self.pair(x, y - 1) | self.pair(x, y) << 2
    }

    /// The blocked flags of cells `x - 1` (bit 0) and `x` (bit 1) of row `y`: one word read
    /// where both are inside the map.
    #[inline]
    fn pair(&self, x: i64, y: i64) -> u8 {
        if y < 0 || y >= self.height || x < 1 || x >= self.width {
            return u8::from(self.blocked(x - 1, y)) | u8::from(self.blocked(x, y)) << 1;
        }
        // In range: non-negative and below u32::MAX.
        let (x, row) = (x as usize, y as usize * self.stride);
        let left = x - 1;
        let bits = if left % 64 == 63 {
            (self.words[row + left / 64] >> 63) | (self.words[row + x / 64] & 1) << 1
        } else {
            self.words[row + left / 64] >> (left % 64) & 3
        };
        // Two bits.
        bits as u8
    }

    /// Row `y`'s words, or `None` for a row outside the map (all blocked).
    #[inline]
    fn row(&self, y: i64) -> Option<&[u64]> {
        if y < 0 || y >= self.height {
            return None;
        }
        // In range: non-negative and below u32::MAX.
        let start = y as usize * self.stride;
        Some(&self.words[start..start + self.stride])
    }

    /// The first cell at or after `x` in row `y` whose bit equals `want_blocked` (cells
    /// past the right edge are blocked), scanning a word at a time.
    #[inline]
    fn next_with(&self, y: i64, x: i64, want_blocked: bool) -> Option<i64> {
        if x < 0 {
            return if want_blocked {
                Some(x)
            } else {
                self.next_with(y, 0, false)
            };
        }
        let Some(row) = self.row(y) else {
            return want_blocked.then_some(x);
        };
        if x >= self.width {
            return want_blocked.then_some(x);
        }
        // x is in 0..width here.
        let (mut i, bit) = (x as usize / 64, x as u32 % 64);
        let flip = if want_blocked { 0 } else { !0 };
        let mut w = (row[i] ^ flip) & (!0u64 << bit);
        loop {
            if w != 0 {
                let k = (i * 64) as i64 + i64::from(w.trailing_zeros());
                // Bits past the edge are 0 in storage: free ones there are not cells.
                return if k < self.width {
                    Some(k)
                } else {
                    want_blocked.then_some(self.width)
                };
            }
            i += 1;
            if i == row.len() {
                return want_blocked.then_some(self.width);
            }
            w = row[i] ^ flip;
        }
    }

    /// The last cell at or before `x` in row `y` whose bit equals `want_blocked` (cells left
    /// of the map are blocked).
    #[inline]
    fn prev_with(&self, y: i64, x: i64, want_blocked: bool) -> Option<i64> {
        let Some(row) = self.row(y) else {
            return want_blocked.then_some(x);
        };
        if x >= self.width {
            if want_blocked {
                return Some(x);
            }
            return self.prev_with(y, self.width - 1, false);
        }
        if x < 0 {
            return want_blocked.then_some(x);
        }
        let (mut i, bit) = (x as usize / 64, x as u32 % 64);
        let flip = if want_blocked { 0 } else { !0 };
        let mut w = (row[i] ^ flip) & (!0u64 >> (63 - bit));
        loop {
            if w != 0 {
                return Some((i * 64) as i64 + 63 - i64::from(w.leading_zeros()));
            }
            if i == 0 {
                return want_blocked.then_some(-1);
            }
            i -= 1;
            w = row[i] ^ flip;
        }
    }

    /// The first blocked cell at or after `x` in row `y` (the map's width if none inside).
    #[inline]
    pub(crate) fn next_blocked(&self, y: i64, x: i64) -> i64 {
        self.next_with(y, x, true).unwrap_or(self.width)
    }

    /// The last blocked cell at or before `x` in row `y` (-1 if none inside).
    #[inline]
    pub(crate) fn prev_blocked(&self, y: i64, x: i64) -> i64 {
        self.prev_with(y, x, true).unwrap_or(-1)
    }

    /// The first free cell at or after `x` in row `y`, if any.
    #[inline]
    pub(crate) fn next_free(&self, y: i64, x: i64) -> Option<i64> {
        self.next_with(y, x, false)
    }

    /// The last free cell at or before `x` in row `y`, if any.
    #[inline]
    pub(crate) fn prev_free(&self, y: i64, x: i64) -> Option<i64> {
        self.prev_with(y, x, false)
    }

    /// Heap bytes.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.words.len() * 8
    }
}
