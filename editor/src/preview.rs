//! `preview`: a picture of a map. Obstacles are black on white (grey where a pixel covers
//! both), the home base is blue and treasures are red dots; image row 0 is the map's top.

use std::io::Cursor;
use std::path::Path;

use image::{ImageFormat, Rgb, RgbImage};
use sim_core::glam::DVec2;
use sim_core::world::MapData;

use crate::{EditorError, Result};

/// Largest picture drawn, in pixels.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Options of `preview`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PreviewOptions {
    /// Pixels along the map's longer side (`None`: one pixel per cell, at most 4096).
    pub px: Option<u32>,
    /// Draw the home base and treasures.
    pub overlays: bool,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        Self {
            px: None,
            overlays: true,
        }
    }
}

/// Draw `map`.
pub fn render(map: &MapData, opts: &PreviewOptions) -> Result<RgbImage> {
    let g = *map.obstacles.grid();
    let (wc, hc) = (g.width_cells(), g.height_cells());
    let longer = wc.max(hc);
    let px = opts.px.unwrap_or(longer.min(4096));
    if px == 0 {
        return Err(EditorError::InvalidParameter("--px must be at least 1".into()));
    }
    let scale = f64::from(px) / f64::from(longer); // pixels per cell
    let w = ((f64::from(wc) * scale).round() as u32).max(1);
    let h = ((f64::from(hc) * scale).round() as u32).max(1);
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(EditorError::InvalidParameter(format!(
            "a {w} × {h} picture is too large; ask for a smaller --px"
        )));
    }
    let (sx, sy) = (f64::from(w) / f64::from(wc), f64::from(h) / f64::from(hc));
    let mut cover = vec![0f32; w as usize * h as usize];
    map.obstacles.tree().for_each_leaf(|sq, blocked| {
        if !blocked || sq.x >= wc || sq.y >= hc {
            return;
        }
        let side = sq.side_cells();
        let (x1, y1) = ((sq.x + side).min(wc), (sq.y + side).min(hc));
        let (px0, px1) = (f64::from(sq.x) * sx, f64::from(x1) * sx);
        let (py0, py1) = (f64::from(sq.y) * sy, f64::from(y1) * sy);
        let (i0, i1) = (px0.floor() as u32, (px1.ceil() as u32).min(w));
        let (j0, j1) = (py0.floor() as u32, (py1.ceil() as u32).min(h));
        for j in j0..j1 {
            let oy = (py1.min(f64::from(j + 1)) - py0.max(f64::from(j))).max(0.0);
            let row = (h - 1 - j) as usize * w as usize;
            for i in i0..i1 {
                let ox = (px1.min(f64::from(i + 1)) - px0.max(f64::from(i))).max(0.0);
                cover[row + i as usize] += (ox * oy) as f32;
            }
        }
    });
    let mut img = RgbImage::from_fn(w, h, |i, j| {
        let c = cover[j as usize * w as usize + i as usize].clamp(0.0, 1.0);
        let v = (255.0 * (1.0 - c)).round() as u8;
        Rgb([v, v, v])
    });
    if opts.overlays {
        let origin = g.origin();
        let to_px = |p: DVec2| {
            let c = (p - origin) / g.cell_m();
            (c.x * sx, f64::from(h) - c.y * sy)
        };
        let blend = |img: &mut RgbImage, i: u32, j: u32, col: [u8; 3]| {
            let p = img.get_pixel_mut(i, j);
            for (c, &k) in p.0.iter_mut().zip(&col) {
                *c = u16::midpoint(u16::from(*c), u16::from(k)) as u8;
            }
        };
        // Home base: blend blue into every pixel whose centre lies inside it.
        let b = map.home.bounds();
        let (a0, a1) = (to_px(b.min), to_px(b.max));
        let (i0, i1) = (a0.0.floor().max(0.0) as u32, (a1.0.ceil().max(0.0) as u32).min(w));
        let (j0, j1) = (a1.1.floor().max(0.0) as u32, (a0.1.ceil().max(0.0) as u32).min(h));
        let mut any = false;
        for j in j0..j1 {
            for i in i0..i1 {
                let c = DVec2::new(
                    origin.x + (f64::from(i) + 0.5) / sx * g.cell_m(),
                    origin.y + (f64::from(h - j) - 0.5) / sy * g.cell_m(),
                );
                if map.home.contains(c) {
                    blend(&mut img, i, j, [0, 90, 255]);
                    any = true;
                }
            }
        }
        if !any {
            mark(&mut img, to_px(map.home.center()), 2.0, Rgb([0, 90, 255]));
        }
        let r = (f64::from(px) / 150.0).clamp(1.5, 6.0);
        for t in &map.treasures {
            mark(&mut img, to_px(t.position), r, Rgb([230, 20, 20]));
        }
    }
    Ok(img)
}

/// A filled dot of radius `r` pixels at pixel position `(x, y)` (y down).
fn mark(img: &mut RgbImage, (x, y): (f64, f64), r: f64, col: Rgb<u8>) {
    let (w, h) = img.dimensions();
    let (i0, i1) = ((x - r).floor().max(0.0) as u32, ((x + r).ceil().max(0.0) as u32).min(w));
    let (j0, j1) = ((y - r).floor().max(0.0) as u32, ((y + r).ceil().max(0.0) as u32).min(h));
    for j in j0..j1 {
        for i in i0..i1 {
            let (dx, dy) = (f64::from(i) + 0.5 - x, f64::from(j) + 0.5 - y);
            if dx * dx + dy * dy <= r * r || (i == x as u32 && j == y as u32) {
                img.put_pixel(i, j, col);
            }
        }
    }
}

/// Encode `img` as PNG and write it atomically to `path`.
pub fn write_png(img: &RgbImage, path: &Path) -> Result<()> {
    let mut bytes = Vec::new();
    img.write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
        .map_err(|cause| EditorError::Image {
            path: path.to_path_buf(),
            cause,
        })?;
    sim_core::world::write_atomically(path, &bytes)?;
    Ok(())
}
