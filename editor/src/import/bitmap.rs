//! Bitmaps: a pixel darker than the threshold is blocked (or lighter, with `invert`).

use std::io::Cursor;
use std::path::Path;

use image::{DynamicImage, ImageReader};
use sim_core::spatial::ObstacleMap;

use super::{ImportOptions, read};
use crate::raster::{check_raster_size, grid, map_from_top_rows};
use crate::{EditorError, Result};

/// Decode an image file (format guessed from its bytes).
pub fn load_image(path: &Path) -> Result<DynamicImage> {
    let bytes = read(path)?;
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(EditorError::io(path))?;
    if reader.format().is_none() {
        return Err(EditorError::bad_input(
            path,
            "not an image in a supported format (PNG, PGM/PPM/PBM, JPEG, BMP)",
        ));
    }
    reader.decode().map_err(|cause| match &cause {
        // The decoder's words for a file that ends before its pixels do.
        image::ImageError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            EditorError::bad_input(path, "the image is cut short: its pixel data ends early")
        }
        _ => EditorError::Image {
            path: path.to_path_buf(),
            cause,
        },
    })
}

/// Import a bitmap.
pub fn import(path: &Path, opts: &ImportOptions) -> Result<ObstacleMap> {
    let img = load_image(path)?.into_luma8();
    let (w, h) = img.dimensions();
    check_raster_size(w, h, "this image").map_err(|e| EditorError::bad_input(path, e.to_string()))?;
    let g = grid(opts.origin, opts.resolution_m.unwrap_or(1.0), w, h)
        .map_err(|e| EditorError::bad_input(path, e.to_string()))?;
    map_from_top_rows(g, |col, row| {
        let dark = img.get_pixel(col, row).0[0] < opts.threshold;
        dark != opts.invert
    })
}
