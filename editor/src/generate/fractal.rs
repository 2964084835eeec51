//! Fractal terrain: fBm of Perlin noise (4 octaves, lacunarity 2, persistence 0.5) with base
//! wavelength `scale_m`, thresholded so that a `density` fraction of cells is blocked.
//!
//! The terrain value of a cell is the bilinear interpolation of the fBm sampled on a lattice
//! every `s` cells (`s` a power of two, at most a quarter of the finest octave's wavelength,
//! so the lattice resolves every octave). A bilinear interpolant lies between the values at
//! the lattice points around it, so a square whose lattice values are all above (or all below)
//! the threshold is full (or empty) without looking at its cells: the quadtree is built top-down,
//! one block of 256 × 256 cells at a time, with no raster of the map.

use noise::{Fbm, MultiFractal, NoiseFn, Perlin};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::spatial::ObstacleMap;
use sim_core::spatial::Region;
use sim_core::spatial::Square;

use super::GenerateOptions;
use crate::Result;
use crate::progress::Progress;

const OCTAVES: usize = 4;
const BLOCK_LEVEL: u8 = 8;

/// The terrain field of a fractal map.
pub struct Field {
    fbm: Fbm<Perlin>,
    cell_m: f64,
    /// Lattice spacing in cells.
    s: u32,
}

impl Field {
    /// The field for `seed`, base wavelength `scale_m` and cells of `cell_m`.
    pub fn new(seed: u64, scale_m: f64, cell_m: f64) -> Self {
        let fbm = Fbm::<Perlin>::new((seed ^ (seed >> 32)) as u32)
            .set_octaves(OCTAVES)
            .set_frequency(1.0 / scale_m)
            .set_lacunarity(2.0)
            .set_persistence(0.5);
        let finest_m = scale_m / f64::from(1u32 << (OCTAVES - 1));
        let ideal = (finest_m / 4.0 / cell_m).floor().clamp(1.0, 16.0) as u32;
        let s = 1u32 << ideal.ilog2(); // largest power of two ≤ ideal
        Self { fbm, cell_m, s }
    }

    /// Lattice spacing in cells.
    pub fn spacing(&self) -> u32 {
        self.s
    }

    /// The fBm at lattice point `(i, j)`.
    #[inline]
    pub fn lattice(&self, i: u64, j: u64) -> f64 {
        let s = f64::from(self.s);
        self.fbm
            .get([(i as f64 * s + 0.5) * self.cell_m, (j as f64 * s + 0.5) * self.cell_m])
    }

    /// The terrain value of cell `(x, y)` (computed from scratch).
    pub fn cell(&self, x: u32, y: u32) -> f64 {
        let s = self.s;
        let (i, j) = (u64::from(x / s), u64::from(y / s));
        let (fx, fy) = (f64::from(x % s) / f64::from(s), f64::from(y % s) / f64::from(s));
        let v00 = self.lattice(i, j);
        if s == 1 {
            return v00;
        }
        let (v10, v01, v11) = (
            self.lattice(i + 1, j),
            self.lattice(i, j + 1),
            self.lattice(i + 1, j + 1),
        );
        bilerp(v00, v10, v01, v11, fx, fy)
    }
}

#[inline]
fn bilerp(v00: f64, v10: f64, v01: f64, v11: f64, fx: f64, fy: f64) -> f64 {
    let a = v00 + (v10 - v00) * fx;
    let b = v01 + (v11 - v01) * fx;
    a + (b - a) * fy
}

/// The lattice values of one block, cached while the tree builder works inside it.
struct Block {
    key: (u32, u32),
    n: u32,
    values: Vec<f64>,
}

impl Block {
    fn load(field: &Field, bx: u32, by: u32, level: u8) -> Self {
        let n = (1u32 << level).div_ceil(field.s);
        let (i0, j0) = (u64::from(bx) * u64::from(n), u64::from(by) * u64::from(n));
        let mut values = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
        for j in 0..=u64::from(n) {
            for i in 0..=u64::from(n) {
                values.push(field.lattice(i0 + i, j0 + j));
            }
        }
        Self {
            key: (bx, by),
            n,
            values,
        }
    }
    #[inline]
    fn at(&self, i: u32, j: u32) -> f64 {
        self.values[(j * (self.n + 1) + i) as usize]
    }
}

/// The threshold above which a cell is blocked, for a blocked fraction `density`: exact over
/// all cells on maps of up to 2^20 cells, else from 2^20 random cells.
pub fn threshold(field: &Field, width: u32, height: u32, density: f64, seed: u64) -> f64 {
    let cells = u64::from(width) * u64::from(height);
    let mut values: Vec<f64> = if cells <= 1 << 20 {
        (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| field.cell(x, y))
            .collect()
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED);
        (0..1 << 20)
            .map(|_| field.cell(rng.random_range(0..width), rng.random_range(0..height)))
            .collect()
    };
    let n = values.len();
    let blocked = ((density * n as f64).round() as usize).min(n);
    if blocked == 0 {
        return f64::INFINITY;
    }
    if blocked == n {
        return f64::NEG_INFINITY;
    }
    let k = n - blocked - 1;
    let (_, t, _) = values.select_nth_unstable_by(k, f64::total_cmp);
    *t
}

/// Generate a fractal map (default density 0.3; default scale: 64 m, or 1 % of the map's
/// shorter side if larger).
pub fn fractal(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    let d = opts.density_or(0.3)?;
    let scale = opts.scale_or((grid.width_m().min(grid.height_m()) / 100.0).max(64.0))?;
    let field = Field::new(opts.seed, scale, opts.cell_m);
    let (w, h) = (grid.width_cells(), grid.height_cells());
    let t = threshold(&field, w, h, d, opts.seed);
    let level = BLOCK_LEVEL.min(grid.depth());
    let s = field.s;
    let mut block: Option<Block> = None;
    let mut progress = Progress::new(u64::from(w) * u64::from(h), "fractal", opts.progress);
    let map = ObstacleMap::from_regions(grid, |sq: Square| {
        if sq.level > level {
            return Region::Mixed;
        }
        let key = (sq.x >> level, sq.y >> level);
        if block.as_ref().is_none_or(|b| b.key != key) {
            block = Some(Block::load(&field, key.0, key.1, level));
        }
        let b = block.as_ref().expect("loaded");
        let (lx, ly) = (sq.x - (key.0 << level), sq.y - (key.1 << level));
        let r = if sq.level == 0 {
            let (i, j) = (lx / s, ly / s);
            let v = if s == 1 {
                b.at(i, j)
            } else {
                let (fx, fy) = (f64::from(lx % s) / f64::from(s), f64::from(ly % s) / f64::from(s));
                bilerp(b.at(i, j), b.at(i + 1, j), b.at(i, j + 1), b.at(i + 1, j + 1), fx, fy)
            };
            if v > t { Region::Full } else { Region::Empty }
        } else {
            let side = sq.side_cells();
            let (i0, j0) = (lx / s, ly / s);
            let (i1, j1) = (((lx + side - 1) / s + 1).min(b.n), ((ly + side - 1) / s + 1).min(b.n));
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let v = b.at(i, j);
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            if lo > t {
                Region::Full
            } else if hi <= t {
                Region::Empty
            } else {
                Region::Mixed
            }
        };
        if r != Region::Mixed {
            progress.inc(sq.cells());
        }
        r
    });
    progress.finish();
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim_core::glam::DVec2;

    #[test]
    fn tree_matches_the_cell_field() {
        for (scale, cell) in [(40.0, 1.0), (200.0, 1.0), (64.0, 0.5)] {
            let opts = GenerateOptions {
                width_m: 300.0 * cell,
                height_m: 170.0 * cell,
                cell_m: cell,
                seed: 7,
                density: Some(0.35),
                scale_m: Some(scale),
                ..GenerateOptions::default()
            };
            let map = fractal(&opts).unwrap();
            let field = Field::new(7, scale, cell);
            let t = threshold(&field, 300, 170, 0.35, 7);
            let mut blocked = 0u64;
            for y in 0..170 {
                for x in 0..300 {
                    let b = field.cell(x, y) > t;
                    blocked += u64::from(b);
                    assert_eq!(map.tree().cell_value(x, y), b, "cell ({x}, {y}) scale {scale}");
                }
            }
            // All cells are used for the threshold on small maps: the density is exact.
            assert_eq!(blocked, (0.35f64 * 300.0 * 170.0).round() as u64);
            assert!(map.is_point_free(DVec2::ZERO) || map.tree().cell_value(0, 0));
        }
    }
}
