//! Generators: white noise, fractal (fBm) noise, caves, mazes, rooms, and the paper's mesas.
//!
//! `fractal` and `mesas` build the quadtree top-down, block by block, and never hold a raster
//! of the map, so they reach 100 km × 100 km at 1 m cells; the others use a raster (refused
//! beyond [`crate::raster::MAX_RASTER_CELLS`]; white noise needs none but visits every cell).

pub mod fractal;
pub mod mesas;
pub mod raster_gens;

use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};

use crate::{EditorError, Result};

/// Which generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// White noise: each cell blocked with probability `density`.
    Noise,
    /// Fractal Brownian motion of Perlin noise thresholded to `density`.
    Fractal,
    /// Cellular-automaton caves.
    Caves,
    /// A perfect maze.
    Maze,
    /// Rooms separated by walls with doors.
    Rooms,
    /// Mars / Monument Valley: random rocks (discs) and mesas (polygons).
    Mesas,
}

/// Options common to all generators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GenerateOptions {
    /// Width in metres.
    pub width_m: f64,
    /// Height in metres.
    pub height_m: f64,
    /// Cell side in metres.
    pub cell_m: f64,
    /// Random seed.
    pub seed: u64,
    /// Target blocked fraction (`None`: the generator's default).
    pub density: Option<f64>,
    /// Feature size in metres (fractal: base wavelength; maze: corridor width; rooms:
    /// smallest room side; mesas: largest mesa radius).
    pub scale_m: Option<f64>,
    /// Mesas: number of obstacles (`None`: enough for the density).
    pub count: Option<u64>,
    /// Show a progress bar on stderr.
    pub progress: bool,
}

impl Default for GenerateOptions {
    fn default() -> Self {
        Self {
            width_m: 128.0,
            height_m: 128.0,
            cell_m: 1.0,
            seed: 1,
            density: None,
            scale_m: None,
            count: None,
            progress: false,
        }
    }
}

impl GenerateOptions {
    /// The map's grid (origin at 0, 0).
    pub fn grid(&self) -> Result<Grid> {
        Ok(Grid::from_size_m(
            DVec2::ZERO,
            self.cell_m,
            self.width_m,
            self.height_m,
        )?)
    }

    /// The density, or `default`, checked to lie in [0, 1].
    pub fn density_or(&self, default: f64) -> Result<f64> {
        let d = self.density.unwrap_or(default);
        if (0.0..=1.0).contains(&d) {
            Ok(d)
        } else {
            Err(EditorError::InvalidParameter(format!(
                "--density must lie in [0, 1], got {d}"
            )))
        }
    }

    /// The feature scale, or `default`, checked to be positive.
    pub fn scale_or(&self, default: f64) -> Result<f64> {
        let s = self.scale_m.unwrap_or(default);
        if s.is_finite() && s > 0.0 {
            Ok(s)
        } else {
            Err(EditorError::InvalidParameter(format!(
                "--scale-m must be a positive number of metres, got {s}"
            )))
        }
    }
}

/// Run generator `kind`. An option it does not use (`density` for a maze or rooms,
/// `scale_m` for noise or caves, `count` for any but mesas) is refused rather than ignored.
pub fn generate(kind: Kind, opts: &GenerateOptions) -> Result<ObstacleMap> {
    refuse_unused(kind, opts)?;
    match kind {
        Kind::Noise => raster_gens::white_noise(opts),
        Kind::Fractal => fractal::fractal(opts),
        Kind::Caves => raster_gens::caves(opts),
        Kind::Maze => raster_gens::maze(opts),
        Kind::Rooms => raster_gens::rooms(opts),
        Kind::Mesas => mesas::mesas(opts),
    }
}

/// Refuse the options of `opts` that generator `kind` does not use.
fn refuse_unused(kind: Kind, opts: &GenerateOptions) -> Result<()> {
    let (density, scale, count) = match kind {
        Kind::Noise | Kind::Caves => (true, false, false),
        Kind::Fractal => (true, true, false),
        Kind::Maze | Kind::Rooms => (false, true, false),
        Kind::Mesas => (true, true, true),
    };
    let given = [
        (opts.density.is_some() && !density, "--density"),
        (opts.scale_m.is_some() && !scale, "--scale-m"),
        (opts.count.is_some() && !count, "--count"),
    ];
    match given.iter().find(|(unused, _)| *unused) {
        Some((_, option)) => Err(EditorError::InvalidParameter(format!(
            "{option} does not apply to the {} generator",
            format!("{kind:?}").to_lowercase()
        ))),
        None => Ok(()),
    }
}

/// A well-mixed 64-bit hash of a cell and a seed (`SplitMix64` finaliser).
#[inline]
pub fn cell_hash(x: u32, y: u32, seed: u64) -> u64 {
    let mut v = (u64::from(x) << 32 | u64::from(y)) ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    v ^ (v >> 31)
}

/// A uniform number in `[0, 1)` from a hash.
#[inline]
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}
