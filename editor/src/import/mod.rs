//! Importers: bitmaps (PNG, PGM, JPEG, BMP), ROS `map_server` YAML + image, Moving AI `.map`.
//!
//! The format is chosen by the file extension: `.yaml`/`.yml` is ROS, `.map` is Moving AI,
//! anything else is decoded as an image (its format guessed from the content).

pub mod bitmap;
pub mod movingai;
pub mod ros;

use std::path::Path;

use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;

use crate::{EditorError, Result};

/// How unknown cells of a ROS map are treated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Unknown {
    /// Unknown is blocked (the safe default).
    #[default]
    Blocked,
    /// Unknown is free.
    Free,
}

/// Options of `import`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// Metres per pixel for bitmaps (ROS and Moving AI files state their own). Default 1.
    pub resolution_m: Option<f64>,
    /// Bitmaps: a pixel whose grey value (0–255) is below this is blocked. Default 128.
    pub threshold: u8,
    /// Bitmaps: swap blocked and free.
    pub invert: bool,
    /// ROS: what unknown cells become.
    pub unknown: Unknown,
    /// World position of the map's lower-left corner (bitmaps and Moving AI; ROS states its own).
    pub origin: DVec2,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            resolution_m: None,
            threshold: 128,
            invert: false,
            unknown: Unknown::Blocked,
            origin: DVec2::ZERO,
        }
    }
}

/// The kind of file, from its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A bitmap image.
    Bitmap,
    /// ROS `map_server` YAML.
    Ros,
    /// Moving AI `.map`.
    MovingAi,
}

impl Format {
    /// Guess the format from `path`'s extension.
    pub fn of(path: &Path) -> Format {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("yaml" | "yml") => Format::Ros,
            Some("map") => Format::MovingAi,
            _ => Format::Bitmap,
        }
    }
}

/// Import the obstacles of `path`.
pub fn import(path: &Path, opts: &ImportOptions) -> Result<ObstacleMap> {
    if let Some(r) = opts.resolution_m
        && !(r.is_finite() && r > 0.0)
    {
        return Err(EditorError::InvalidParameter(format!(
            "--resolution-m must be a positive number of metres, got {r}"
        )));
    }
    match Format::of(path) {
        Format::Ros => ros::import(path, opts),
        Format::MovingAi => movingai::import(path, opts),
        Format::Bitmap => bitmap::import(path, opts),
    }
}

/// Read a whole file, naming it on failure.
pub(crate) fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(EditorError::io(path))
}
