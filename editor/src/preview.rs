//! `preview`: a picture of a map. Obstacles are black on white (grey where a pixel covers
//! both), the home base is blue and treasures are red dots; image row 0 is the map's top.

use std::io::Cursor;
use std::path::Path;

use image::{ImageFormat, Rgb, RgbImage};
use sim_core::glam::DVec2;
use sim_core::spatial::Grid;
use sim_core::world::{HomeBase, MapData, TreasureSpec};

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
    let frame = Frame::new(*map.obstacles.grid(), opts.px)?;
    let mut img = draw_obstacles(map, &frame);
    if opts.overlays {
        draw_home(&mut img, &frame, &map.home);
        draw_treasures(&mut img, &frame, &map.treasures);
    }
    Ok(img)
}

/// Where a map's cells fall in its picture.
#[derive(Clone, Copy)]
struct Frame {
    /// The map's grid.
    grid: Grid,
    /// Pixels along the map's longer side.
    px: u32,
    /// Picture width, pixels.
    w: u32,
    /// Picture height, pixels.
    h: u32,
    /// Pixels per cell along x.
    sx: f64,
    /// Pixels per cell along y.
    sy: f64,
}

impl Frame {
    /// The picture of `grid` with `px` pixels along its longer side (`None`: one per cell, at
    /// most 4096); an error for no pixels or a picture over [`MAX_PIXELS`].
    fn new(grid: Grid, px: Option<u32>) -> Result<Self> {
        let (wc, hc) = (grid.width_cells(), grid.height_cells());
        let longer = wc.max(hc);
        let px = px.unwrap_or(longer.min(4096));
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
        Ok(Self { grid, px, w, h, sx, sy })
    }

    /// The pixel position (y down) of the world point `p`.
    fn pixel_of(&self, p: DVec2) -> (f64, f64) {
        let c = (p - self.grid.origin()) / self.grid.cell_m();
        (c.x * self.sx, f64::from(self.h) - c.y * self.sy)
    }

    /// The world position of the centre of pixel `(i, j)`.
    fn pixel_center(&self, i: u32, j: u32) -> DVec2 {
        let origin = self.grid.origin();
        DVec2::new(
            origin.x + (f64::from(i) + 0.5) / self.sx * self.grid.cell_m(),
            origin.y + (f64::from(self.h - j) - 0.5) / self.sy * self.grid.cell_m(),
        )
    }
}

/// The obstacles in grey: each pixel darker by the share of it that blocked cells cover.
fn draw_obstacles(map: &MapData, frame: &Frame) -> RgbImage {
    let Frame { w, h, sx, sy, .. } = *frame;
    let (wc, hc) = (frame.grid.width_cells(), frame.grid.height_cells());
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
    RgbImage::from_fn(w, h, |i, j| {
        let c = cover[j as usize * w as usize + i as usize].clamp(0.0, 1.0);
        let v = (255.0 * (1.0 - c)).round() as u8;
        Rgb([v, v, v])
    })
}

/// The home base in blue: blended into every pixel whose centre lies inside it, or a dot at
/// its centre when it holds no pixel centre.
fn draw_home(img: &mut RgbImage, frame: &Frame, home: &HomeBase) {
    let blend = |img: &mut RgbImage, i: u32, j: u32, col: [u8; 3]| {
        let p = img.get_pixel_mut(i, j);
        for (c, &k) in p.0.iter_mut().zip(&col) {
            *c = u16::midpoint(u16::from(*c), u16::from(k)) as u8;
        }
    };
    let b = home.bounds();
    let (a0, a1) = (frame.pixel_of(b.min), frame.pixel_of(b.max));
    let (i0, i1) = (a0.0.floor().max(0.0) as u32, (a1.0.ceil().max(0.0) as u32).min(frame.w));
    let (j0, j1) = (a1.1.floor().max(0.0) as u32, (a0.1.ceil().max(0.0) as u32).min(frame.h));
    let mut any = false;
    for j in j0..j1 {
        for i in i0..i1 {
            if home.contains(frame.pixel_center(i, j)) {
                blend(img, i, j, [0, 90, 255]);
                any = true;
            }
        }
    }
    if !any {
        mark(img, frame.pixel_of(home.center()), 2.0, Rgb([0, 90, 255]));
    }
}

/// The treasures as red dots, sized to the picture.
fn draw_treasures(img: &mut RgbImage, frame: &Frame, treasures: &[TreasureSpec]) {
    let r = (f64::from(frame.px) / 150.0).clamp(1.5, 6.0);
    for t in treasures {
        mark(img, frame.pixel_of(t.position), r, Rgb([230, 20, 20]));
    }
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
    sim_core::write_atomically(path, &bytes)?;
    Ok(())
}
