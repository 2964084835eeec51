//! ROS `map_server` maps: a YAML file naming an image plus `resolution`, `origin` (pose of the
//! lower-left pixel), `negate`, `occupied_thresh`, `free_thresh` and optionally `mode`.
//!
//! With `negate: 0` a pixel's occupancy is `p = (255 − v) / 255` (v = mean of the colour
//! channels); with `negate: 1` it is `v / 255`. In `trinary` and `scale` modes the pixel is
//! occupied when `p > occupied_thresh`, free when `p < free_thresh` and unknown otherwise (a
//! binary obstacle map has no "partly occupied", so scale's intermediate values count as
//! unknown; in scale mode a pixel that is not fully opaque is unknown too). In `raw` mode
//! the value itself is the occupancy in percent (`p = v / 100` with the same thresholds)
//! and values above 100 are unknown. Unknown cells are blocked unless `--unknown free`.

use std::path::Path;

use serde::Deserialize;
use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;

use super::bitmap::load_image;
use super::{ImportOptions, Unknown, read};
use crate::raster::{check_raster_size, grid, map_from_top_rows};
use crate::{EditorError, Result};

/// How pixel values map to occupancy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Occupied / free / unknown by thresholds.
    Trinary,
    /// Like trinary; intermediate values (partly occupied) count as unknown.
    Scale,
    /// The value is the occupancy in percent.
    Raw,
}

/// A cell's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Occupancy {
    /// Occupied.
    Occupied,
    /// Free.
    Free,
    /// Unknown.
    Unknown,
}

/// The parameters of a ROS map YAML.
#[derive(Clone, Debug, PartialEq)]
pub struct RosMap {
    /// The image file, relative to the YAML's folder.
    pub image: String,
    /// Metres per pixel.
    pub resolution: f64,
    /// Position of the lower-left pixel's corner.
    pub origin: DVec2,
    /// Whether dark means free.
    pub negate: bool,
    /// Occupancy above which a pixel is occupied.
    pub occupied_thresh: f64,
    /// Occupancy below which a pixel is free.
    pub free_thresh: f64,
    /// The mode.
    pub mode: Mode,
}

#[derive(Deserialize)]
struct RawYaml {
    image: String,
    resolution: f64,
    origin: Vec<f64>,
    #[serde(default)]
    negate: serde_norway::Value,
    occupied_thresh: f64,
    free_thresh: f64,
    mode: Option<String>,
}

/// Parse the YAML text of a ROS map.
pub fn parse(text: &str) -> Result<RosMap, String> {
    let raw: RawYaml = serde_norway::from_str(text).map_err(|e| format!("malformed ROS map YAML: {e}"))?;
    if !(raw.resolution.is_finite() && raw.resolution > 0.0) {
        return Err(format!("resolution must be positive, got {}", raw.resolution));
    }
    let origin = match raw.origin[..] {
        [x, y] | [x, y, _] if x.is_finite() && y.is_finite() => DVec2::new(x, y),
        _ => return Err(format!("origin must be [x, y, yaw], got {:?}", raw.origin)),
    };
    if let Some(&yaw) = raw.origin.get(2)
        && yaw != 0.0
    {
        return Err(format!(
            "origin yaw is {yaw}: rotated maps are not supported (the map's axes must be the world's)"
        ));
    }
    let negate = match &raw.negate {
        serde_norway::Value::Null => false,
        serde_norway::Value::Bool(b) => *b,
        serde_norway::Value::Number(n) if n.as_i64() == Some(0) => false,
        serde_norway::Value::Number(n) if n.as_i64() == Some(1) => true,
        other => return Err(format!("negate must be 0 or 1, got {other:?}")),
    };
    for (name, t) in [
        ("occupied_thresh", raw.occupied_thresh),
        ("free_thresh", raw.free_thresh),
    ] {
        if !(0.0..=1.0).contains(&t) {
            return Err(format!("{name} must lie in [0, 1], got {t}"));
        }
    }
    if raw.free_thresh > raw.occupied_thresh {
        return Err(format!(
            "free_thresh {} exceeds occupied_thresh {}",
            raw.free_thresh, raw.occupied_thresh
        ));
    }
    let mode = match raw.mode.as_deref() {
        None | Some("trinary") => Mode::Trinary,
        Some("scale") => Mode::Scale,
        Some("raw") => Mode::Raw,
        Some(m) => return Err(format!("mode must be trinary, scale or raw, got {m:?}")),
    };
    Ok(RosMap {
        image: raw.image,
        resolution: raw.resolution,
        origin,
        negate,
        occupied_thresh: raw.occupied_thresh,
        free_thresh: raw.free_thresh,
        mode,
    })
}

impl RosMap {
    /// Classify a pixel by its mean channel value `v` (0–255) and alpha (255 = opaque).
    pub fn classify(&self, v: f64, alpha: u8) -> Occupancy {
        let p = match self.mode {
            Mode::Raw => {
                if v > 100.0 {
                    return Occupancy::Unknown;
                }
                v / 100.0
            }
            Mode::Scale if alpha < 255 => return Occupancy::Unknown,
            Mode::Trinary | Mode::Scale => {
                if self.negate {
                    v / 255.0
                } else {
                    (255.0 - v) / 255.0
                }
            }
        };
        if p > self.occupied_thresh {
            Occupancy::Occupied
        } else if p < self.free_thresh {
            Occupancy::Free
        } else {
            Occupancy::Unknown
        }
    }
}

/// Import a ROS map (YAML + image).
pub fn import(path: &Path, opts: &ImportOptions) -> Result<ObstacleMap> {
    let text = read(path)?;
    let text = String::from_utf8(text).map_err(|_| EditorError::bad_input(path, "ROS map YAML is not UTF-8 text"))?;
    let ros = parse(&text).map_err(|p| EditorError::bad_input(path, p))?;
    let image_path = path.parent().unwrap_or(Path::new("")).join(&ros.image);
    // The image's own errors name it; say which YAML asked for it too.
    let img = load_image(&image_path)
        .map_err(|e| EditorError::bad_input(path, format!("its image '{}': {e}", ros.image)))?
        .into_rgba8();
    let (w, h) = img.dimensions();
    // Size problems come from the image: name it beside the YAML.
    let sized =
        |e: EditorError| EditorError::bad_input(path, format!("its image '{}' ({w} × {h} pixels): {e}", ros.image));
    check_raster_size(w, h, "this image").map_err(sized)?;
    let g = grid(ros.origin, opts.resolution_m.unwrap_or(ros.resolution), w, h).map_err(sized)?;
    map_from_top_rows(g, |col, row| {
        let [r, gr, b, a] = img.get_pixel(col, row).0;
        let v = (f64::from(r) + f64::from(gr) + f64::from(b)) / 3.0;
        match ros.classify(v, a) {
            Occupancy::Occupied => true,
            Occupancy::Free => false,
            Occupancy::Unknown => opts.unknown == Unknown::Blocked,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_turtlebot_header() {
        let m = parse(
            "image: map.pgm\nresolution: 0.050000\norigin: [-10.000000, -10.000000, 0.000000]\nnegate: 0\n\
             occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        )
        .unwrap();
        assert_eq!(m.origin, DVec2::new(-10.0, -10.0));
        assert_eq!(m.mode, Mode::Trinary);
        assert_eq!(m.classify(254.0, 255), Occupancy::Free);
        assert_eq!(m.classify(0.0, 255), Occupancy::Occupied);
        assert_eq!(m.classify(205.0, 255), Occupancy::Unknown);
    }

    #[test]
    fn rejects_nonsense() {
        assert!(parse("image: [unclosed").unwrap_err().contains("line"));
        assert!(parse("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0.5]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n")
            .unwrap_err()
            .contains("yaw"));
        assert!(parse("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\nmode: fancy\n")
            .unwrap_err()
            .contains("mode"));
        assert!(
            parse("image: a.pgm\norigin: [0, 0, 0]\n")
                .unwrap_err()
                .contains("resolution")
        );
    }
}
