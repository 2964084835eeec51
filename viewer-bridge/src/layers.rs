//! Turning sim-core's spatial structures into things Rerun draws well: rasters of quadtrees,
//! coarse known regions, obstacle boxes, and the static map layers shared by `smartteams run`
//! and `smartteams view`.
//!
//! Coordinates: Rerun's 2D views put +y downwards (image convention) while the simulation's
//! +y is north. Every 2D entity is therefore logged at `(x, -y)` ([`to_2d`]) so that north is
//! up on screen; the 3D view (`world3d/…`) uses the simulation's coordinates unchanged.

use sim_core::glam::DVec2;
use sim_core::spatial::Aabb;
use sim_core::spatial::Grid;
use sim_core::spatial::ObstacleMap;
use sim_core::spatial::RegionQuadtree;
use sim_core::world::HomeBase;
use sim_core::world::MapData;

/// Largest number of blocked leaves logged as exact `Boxes2D`. Above it only the raster is
/// logged: the viewer's memory grows with every box, and far beyond this it turns sluggish.
pub const MAX_EXACT_BOXES: usize = 50_000;
/// Longest side in pixels of the obstacle raster (the overview layer).
pub const MAX_RASTER_PX: u32 = 2048;
/// Longest side in pixels of the collective explored-region raster (re-logged during the run,
/// so kept smaller than the static obstacle raster).
pub const MAX_EXPLORED_PX: u32 = 512;
/// Coarse cells per side of the covering square for per-robot known regions (64 → at most
/// 4,096 cells, merged into row runs).
pub const KNOWN_COARSE_CELLS: u32 = 64;
/// Longest side in boxes of the 3D obstacle layer when the exact leaves are too many.
pub const MAX_3D_BOXES_SIDE: u32 = 200;

/// Colour of blocked terrain (Mars-like rock).
pub const ROCK_RGB: [u8; 3] = [176, 120, 86];
/// Colour of free terrain.
pub const GROUND_RGB: [u8; 3] = [38, 34, 38];

/// A 2D view position for a world point (see the module docs for the flip).
#[inline]
pub fn to_2d(p: DVec2) -> [f32; 2] {
    [p.x as f32, -p.y as f32]
}

/// A raster of the map area: `width × height` pixels of `px_m` metres, row 0 at the north
/// edge. Each pixel holds the covered fraction (0–1) of the quantity rasterised.
#[derive(Clone, Debug)]
pub struct Raster {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Side of a pixel in metres.
    pub px_m: f64,
    /// Cells of the grid per pixel side (a power of two).
    pub cells_per_px: u32,
    /// World position of the map's north-west corner.
    pub north_west: DVec2,
    /// Covered fraction per pixel, row-major from the north.
    pub coverage: Vec<f32>,
}

impl Raster {
    /// An empty raster of `grid`'s map area with at most `max_px` pixels a side. Pixels are a
    /// power of two of cells, so quadtree squares never straddle pixels unevenly.
    pub fn for_grid(grid: &Grid, max_px: u32) -> Self {
        let longest = grid.width_cells().max(grid.height_cells()).max(1);
        let mut cells_per_px = 1u32;
        while longest.div_ceil(cells_per_px) > max_px {
            cells_per_px *= 2;
        }
        let width = grid.width_cells().div_ceil(cells_per_px).max(1);
        let height = grid.height_cells().div_ceil(cells_per_px).max(1);
        Self {
            width,
            height,
            px_m: grid.cell_m() * f64::from(cells_per_px),
            cells_per_px,
            north_west: grid.origin() + DVec2::new(0.0, f64::from(height * cells_per_px) * grid.cell_m()),
            coverage: vec![0.0; width as usize * height as usize],
        }
    }

    /// Rasterise the leaves of `tree` holding `value`: each pixel gets the fraction of its
    /// cells covered. Runs in O(leaves + covered pixels).
    pub fn fill_from(&mut self, tree: &RegionQuadtree, value: bool) {
        self.coverage.fill(0.0);
        let cpp = u64::from(self.cells_per_px);
        let px_cells = (cpp * cpp) as f32;
        let (w, h) = (self.width, self.height);
        tree.for_each_leaf(|sq, v| {
            if v != value {
                return;
            }
            let side = u64::from(sq.side_cells());
            if side <= cpp {
                // The leaf lies inside one pixel (pixels are aligned powers of two).
                let (px, py) = (sq.x / self.cells_per_px, sq.y / self.cells_per_px);
                if px < w && py < h {
                    let i = (h - 1 - py) as usize * w as usize + px as usize;
                    self.coverage[i] += (side * side) as f32 / px_cells;
                }
            } else {
                let n = (side / cpp) as u32;
                let (x0, y0) = (sq.x / self.cells_per_px, sq.y / self.cells_per_px);
                for py in y0..(y0 + n).min(h) {
                    let row = (h - 1 - py) as usize * w as usize;
                    for px in x0..(x0 + n).min(w) {
                        self.coverage[row + px as usize] = 1.0;
                    }
                }
            }
        });
    }

    /// The raster as 8-bit luminance (coverage × 255).
    pub fn to_l8(&self) -> Vec<u8> {
        self.coverage
            .iter()
            // Adding a half and truncating rounds these non-negative values as `round` does,
            // without its library call per pixel.
            .map(|&c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
            .collect()
    }

    /// The raster as RGB, blending `empty` towards `full` by coverage.
    pub fn to_rgb(&self, empty: [u8; 3], full: [u8; 3]) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.coverage.len() * 3);
        for &c in &self.coverage {
            // Most pixels are wholly free or wholly blocked: their colour needs no blend.
            if c <= 0.0 {
                out.extend_from_slice(&empty);
                continue;
            }
            if c >= 1.0 {
                out.extend_from_slice(&full);
                continue;
            }
            for k in 0..3 {
                out.push((f32::from(empty[k]) * (1.0 - c) + f32::from(full[k]) * c + 0.5) as u8);
            }
        }
        out
    }

    /// The transform that places this raster's pixels on the 2D view's world coordinates.
    pub fn transform_2d(&self) -> rerun::Transform3D {
        let nw = to_2d(self.north_west);
        rerun::Transform3D::from_translation_scale([nw[0], nw[1], 0.0], [self.px_m as f32, self.px_m as f32, 1.0])
    }
}

/// Boxes (min corner, size) of a per-robot known region at a coarse level: each coarse cell
/// touched by a known leaf counts as known (an over-approximation), and known cells are merged
/// into runs along rows so a region costs a few dozen boxes, not thousands of leaves.
pub fn coarse_known_boxes(tree: &RegionQuadtree) -> Vec<Aabb> {
    let grid = *tree.grid();
    let depth = grid.depth();
    let coarse_level = depth.saturating_sub(KNOWN_COARSE_CELLS.trailing_zeros() as u8);
    let n = 1u32 << (depth - coarse_level);
    // A row of coarse cells is a word (n ≤ 64): bit x is cell x.
    let mut rows = [0u64; KNOWN_COARSE_CELLS as usize];
    // The walk stops at the coarse level: its cost follows the coarse cells, not the leaves.
    tree.for_each_square_holding(true, coarse_level, |sq| {
        let k = 1u32 << (sq.level - coarse_level);
        let (x0, y0) = (sq.x >> coarse_level, sq.y >> coarse_level);
        let bits = if k >= 64 { u64::MAX } else { ((1u64 << k) - 1) << x0 };
        for row in &mut rows[y0 as usize..(y0 + k) as usize] {
            *row |= bits;
        }
    });
    let mut boxes = Vec::new();
    for (y, &row) in rows.iter().enumerate().take(n as usize) {
        let y = y as u32;
        let mut bits = row;
        while bits != 0 {
            let start = bits.trailing_zeros();
            let len = (bits >> start).trailing_ones();
            let a = grid.square(start << coarse_level, y << coarse_level, coarse_level);
            let b = grid.square((start + len - 1) << coarse_level, y << coarse_level, coarse_level);
            boxes.push(Aabb { min: a.min, max: b.max });
            bits &= if start + len >= 64 { 0 } else { !0u64 << (start + len) };
        }
    }
    boxes
}

/// `Boxes2D` of world boxes (flipped to the 2D view).
pub fn boxes_2d(boxes: &[Aabb]) -> rerun::Boxes2D {
    rerun::Boxes2D::from_mins_and_sizes(
        boxes.iter().map(|b| [b.min.x as f32, -b.max.y as f32]),
        boxes
            .iter()
            .map(|b| [(b.max.x - b.min.x) as f32, (b.max.y - b.min.y) as f32]),
    )
}

/// Static 3D obstacle boxes ("mesas"): exact blocked leaves when few enough, else the cells of
/// a coarse raster at least half blocked. Heights grow with the leaf size so the inside of a
/// big obstacle rises above its fringe, capped to keep the scene flat-ish.
pub fn obstacle_boxes_3d(obstacles: &ObstacleMap) -> rerun::Boxes3D {
    let grid = obstacles.grid();
    let cap = (grid.width_m().max(grid.height_m()) / 25.0).max(grid.cell_m());
    let height = |side_m: f64| (0.5 * side_m).clamp(grid.cell_m().min(1.0), cap) as f32;
    let mut centers = Vec::new();
    let mut sizes = Vec::new();
    if obstacles.blocked_leaf_count() <= MAX_EXACT_BOXES {
        obstacles.tree().for_each_leaf(|sq, blocked| {
            if blocked && grid.in_map(sq.x, sq.y) {
                let b = grid.square(sq.x, sq.y, sq.level);
                let side = (b.max.x - b.min.x) as f32;
                let h = height(f64::from(side));
                let c = b.center();
                centers.push([c.x as f32, c.y as f32, h / 2.0]);
                sizes.push([side, side, h]);
            }
        });
    } else {
        let mut r = Raster::for_grid(grid, MAX_3D_BOXES_SIDE);
        r.fill_from(obstacles.tree(), true);
        let h = height(r.px_m * 4.0);
        for row in 0..r.height {
            for col in 0..r.width {
                if r.coverage[(row * r.width + col) as usize] >= 0.5 {
                    let x = r.north_west.x + (f64::from(col) + 0.5) * r.px_m;
                    let y = r.north_west.y - (f64::from(row) + 0.5) * r.px_m;
                    centers.push([x as f32, y as f32, h / 2.0]);
                    sizes.push([r.px_m as f32, r.px_m as f32, h]);
                }
            }
        }
    }
    rerun::Boxes3D::from_centers_and_sizes(centers, sizes)
        .with_colors([rerun::Color::from_rgb(ROCK_RGB[0], ROCK_RGB[1], ROCK_RGB[2])])
        .with_fill_mode(rerun::components::FillMode::Solid)
}

/// What [`log_static_map`] logged, for the report and for tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StaticMapSummary {
    /// Blocked leaves of the map.
    pub blocked_leaves: usize,
    /// Whether exact obstacle boxes were logged.
    pub exact_boxes: bool,
    /// Obstacle raster size in pixels.
    pub raster_px: (u32, u32),
}

/// Draw orders of the 2D layers (higher on top).
pub mod draw_order {
    /// Obstacle raster.
    pub const OBSTACLES: f32 = -30.0;
    /// Collective explored region.
    pub const EXPLORED: f32 = -20.0;
    /// Home base.
    pub const HOME: f32 = -10.0;
    /// Exact obstacle outlines.
    pub const OBSTACLE_BOXES: f32 = -5.0;
    /// Per-robot known regions.
    pub const KNOWN: f32 = 0.0;
    /// Planned paths.
    pub const PATHS: f32 = 10.0;
    /// Communication links.
    pub const LINKS: f32 = 15.0;
    /// Treasures.
    pub const TREASURES: f32 = 20.0;
    /// Robots.
    pub const ROBOTS: f32 = 30.0;
}

/// Log the static map layers: the obstacle raster (always), exact obstacle outlines (when at
/// most [`MAX_EXACT_BOXES`]), the home base, the 3D obstacles and ground. Treasures are not
/// static in a run, so the caller logs them.
pub fn log_static_map(rec: &rerun::RecordingStream, map: &MapData) -> rerun::RecordingStreamResult<StaticMapSummary> {
    let obstacles = &map.obstacles;
    let grid = obstacles.grid();
    let mut raster = Raster::for_grid(grid, MAX_RASTER_PX);
    raster.fill_from(obstacles.tree(), true);
    rec.log_static(
        "world/obstacles/raster",
        &[
            &raster.transform_2d() as &dyn rerun::AsComponents,
            &rerun::Image::from_rgb24(raster.to_rgb(GROUND_RGB, ROCK_RGB), [raster.width, raster.height])
                .with_draw_order(draw_order::OBSTACLES),
        ],
    )?;
    let blocked_leaves = obstacles.blocked_leaf_count();
    let exact_boxes = blocked_leaves <= MAX_EXACT_BOXES;
    if exact_boxes {
        let mut boxes = Vec::with_capacity(blocked_leaves);
        obstacles.tree().for_each_leaf(|sq, blocked| {
            if blocked && grid.in_map(sq.x, sq.y) {
                boxes.push(grid.square(sq.x, sq.y, sq.level));
            }
        });
        rec.log_static(
            "world/obstacles/boxes",
            &boxes_2d(&boxes)
                .with_colors([rerun::Color::from_unmultiplied_rgba(230, 170, 130, 90)])
                .with_radii([rerun::Radius::new_ui_points(0.5)])
                .with_draw_order(draw_order::OBSTACLE_BOXES),
        )?;
    }
    let home_color = rerun::Color::from_unmultiplied_rgba(80, 160, 255, 110);
    match map.home {
        HomeBase::Disc { center, radius_m } => rec.log_static(
            "world/home",
            &rerun::Points2D::new([to_2d(center)])
                .with_radii([radius_m as f32])
                .with_colors([home_color])
                .with_labels(["home"])
                .with_draw_order(draw_order::HOME),
        )?,
        HomeBase::Rect(r) => rec.log_static(
            "world/home",
            &boxes_2d(&[r])
                .with_colors([home_color])
                .with_labels(["home"])
                .with_draw_order(draw_order::HOME),
        )?,
    }
    let e = grid.extent();
    rec.log_static(
        "world3d/ground",
        &rerun::Boxes3D::from_mins_and_sizes(
            [[e.min.x as f32, e.min.y as f32, -0.05]],
            [[(e.max.x - e.min.x) as f32, (e.max.y - e.min.y) as f32, 0.05]],
        )
        .with_colors([rerun::Color::from_rgb(GROUND_RGB[0], GROUND_RGB[1], GROUND_RGB[2])])
        .with_fill_mode(rerun::components::FillMode::Solid),
    )?;
    rec.log_static("world3d/obstacles", &obstacle_boxes_3d(obstacles))?;
    let hc = map.home.center();
    rec.log_static(
        "world3d/home",
        &rerun::Points3D::new([[hc.x as f32, hc.y as f32, 0.1]])
            .with_radii([home_radius(&map.home) as f32])
            .with_colors([home_color]),
    )?;
    Ok(StaticMapSummary {
        blocked_leaves,
        exact_boxes,
        raster_px: (raster.width, raster.height),
    })
}

/// Log a map's treasures as a static layer (for a map shown alone; a run logs them per round).
pub fn log_static_treasures(rec: &rerun::RecordingStream, map: &MapData) -> rerun::RecordingStreamResult<()> {
    let cell_m = map.obstacles.grid().cell_m();
    rec.log_static(
        "world/treasures",
        &rerun::Points2D::new(map.treasures.iter().map(|t| to_2d(t.position)))
            .with_radii(map.treasures.iter().map(|t| treasure_radius(t.quantity, cell_m)))
            .with_colors([rerun::Color::from_rgb(255, 215, 0)])
            .with_labels(map.treasures.iter().map(|t| t.quantity.to_string()))
            .with_draw_order(draw_order::TREASURES),
    )
}

fn home_radius(home: &HomeBase) -> f64 {
    match *home {
        HomeBase::Disc { radius_m, .. } => radius_m,
        HomeBase::Rect(r) => 0.5 * (r.max - r.min).min_element(),
    }
}

/// Display radius of a treasure with `remaining` units: area grows with the quantity.
pub fn treasure_radius(remaining: u32, cell_m: f64) -> f32 {
    ((0.35 + 0.3 * f64::from(remaining).sqrt()) * cell_m.max(0.5)) as f32
}

#[cfg(test)]
mod tests {

    use sim_core::spatial::Grid;
    use sim_core::spatial::RegionQuadtree;

    use super::*;

    #[test]
    fn pixels_are_the_coverage_rounded() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 8, 8).unwrap();
        let mut r = Raster::for_grid(&grid, 4);
        // Every coverage a pixel can hold, in steps finer than a grey level, and out of range.
        r.coverage = (-100..=10_100).map(|i| i as f32 / 10_000.0).collect();
        let rounded = |v: f32| v.clamp(0.0, 255.0).round() as u8;
        let l8: Vec<u8> = r.coverage.iter().map(|&c| rounded(c.clamp(0.0, 1.0) * 255.0)).collect();
        assert_eq!(r.to_l8(), l8);
        let (empty, full) = ([38u8, 34, 38], [200u8, 140, 90]);
        let rgb: Vec<u8> = r
            .coverage
            .iter()
            .flat_map(|&c| {
                let c = c.clamp(0.0, 1.0);
                (0..3).map(move |k| rounded(f32::from(empty[k]) * (1.0 - c) + f32::from(full[k]) * c))
            })
            .collect();
        assert_eq!(r.to_rgb(empty, full), rgb);
    }

    #[test]
    #[expect(clippy::float_cmp, reason = "whole cells give exact fractions")]
    fn raster_coverage_matches_cells() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 8, 8).unwrap();
        let map = ObstacleMap::from_fn(grid, |x, y| x < 2 && y >= 6);
        let mut r = Raster::for_grid(&grid, 4);
        assert_eq!((r.width, r.height, r.cells_per_px), (4, 4, 2));
        r.fill_from(map.tree(), true);
        // Blocked cells x 0..2, y 6..8: the north-west pixel, row 0.
        assert_eq!(r.coverage[0], 1.0);
        assert_eq!(r.coverage.iter().sum::<f32>(), 1.0);
        assert_eq!(r.north_west, DVec2::new(0.0, 8.0));
    }

    #[test]
    fn coarse_known_boxes_cover_the_known_cells() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 256, 256).unwrap();
        let mut tree = RegionQuadtree::uniform(grid, false);
        tree.set_cell(10, 10, true);
        tree.set_cell(11, 10, true);
        let boxes = coarse_known_boxes(&tree);
        // 256 cells / 64 coarse cells = 4 m per coarse cell: both cells lie in (2, 2).
        assert_eq!(boxes.len(), 1);
        assert_eq!(boxes[0].min, DVec2::new(8.0, 8.0));
        assert_eq!(boxes[0].max, DVec2::new(12.0, 12.0));
    }

    /// The coarse boxes are the runs of coarse cells holding a known cell, row by row:
    /// checked against a cell-by-cell scan on random maps of several sizes.
    #[test]
    fn coarse_known_boxes_are_the_runs_of_a_cell_scan() {
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for side in [16u32, 64, 100, 256, 1000] {
            for _ in 0..5 {
                let grid = Grid::new(DVec2::ZERO, 0.5, side, side).unwrap();
                let mut tree = RegionQuadtree::uniform(grid, false);
                for _ in 0..(next() % 40) {
                    let (x, y) = ((next() % u64::from(side)) as u32, (next() % u64::from(side)) as u32);
                    let r = 0.5 * (next() % 12) as f64;
                    let c = grid.cell_center(x, y);
                    tree.fill(
                        &sim_core::spatial::Disc { center: c, radius: r },
                        true,
                        sim_core::spatial::PartialCells::Include,
                    );
                }
                let depth = grid.depth();
                let coarse = depth.saturating_sub(6);
                let n = 1u32 << (depth - coarse);
                let mut want = Vec::new();
                for cy in 0..n {
                    let known = |cx: u32| {
                        (0..1u32 << coarse).any(|dy| {
                            (0..1u32 << coarse).any(|dx| tree.cell_value((cx << coarse) + dx, (cy << coarse) + dy))
                        })
                    };
                    let mut cx = 0;
                    while cx < n {
                        if known(cx) {
                            let start = cx;
                            while cx < n && known(cx) {
                                cx += 1;
                            }
                            let a = grid.square(start << coarse, cy << coarse, coarse);
                            let b = grid.square((cx - 1) << coarse, cy << coarse, coarse);
                            want.push(Aabb { min: a.min, max: b.max });
                        } else {
                            cx += 1;
                        }
                    }
                }
                assert_eq!(coarse_known_boxes(&tree), want, "side {side}");
            }
        }
    }
}
