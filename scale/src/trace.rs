//! Pictures of explorers' walks: where each robot went until 90 % of the free area was
//! explored, where it went from there to 98 %, what was still unseen at 90 % (and seen on
//! the way on), and what it left unseen. Side by side, they show why one explorer walks
//! farther than another (pockets and strips left behind, goals that switch back and
//! forth).
//!
//! ```
//! use scale::exploration::{GREEDY_REFERENCE, explore_traced, indoor_maps};
//! use sim_core::agent::Params;
//!
//! let (_, map) = indoor_maps()?.remove(2); // the loop
//! let (run, walks) = explore_traced(&map, GREEDY_REFERENCE, &Params::default(), 1, 40)?;
//! let picture = scale::trace::picture(&map, &[(&run, &walks)]);
//! assert_eq!(picture.width(), 400); // 200 cells a side, 2 px a cell
//! # Ok::<(), anyhow::Error>(())
//! ```

use image::{Rgb, RgbImage};
use sim_core::glam::DVec2;
use sim_core::world::MapData;

use crate::exploration::{Exploration, Walks};

/// Blocked cells.
pub const BLOCKED: Rgb<u8> = Rgb([0, 0, 0]);
/// Free cells the run explored (by the round it reached 90 %, if it did).
pub const EXPLORED: Rgb<u8> = Rgb([232, 232, 232]);
/// Free cells the run first saw after 90 % of the free area was explored.
pub const SEEN_FROM_90: Rgb<u8> = Rgb([255, 220, 140]);
/// Free cells the run left unseen.
pub const UNSEEN: Rgb<u8> = Rgb([255, 190, 190]);
/// The walk until 90 % was explored.
pub const TO_90: Rgb<u8> = Rgb([30, 60, 255]);
/// The walk from 90 % on (to 98 %, or to the end of the run).
pub const FROM_90: Rgb<u8> = Rgb([230, 0, 0]);
/// Where each robot started.
pub const START: Rgb<u8> = Rgb([0, 170, 0]);
/// Between panels.
const GAP: Rgb<u8> = Rgb([255, 255, 255]);

/// Pixels between panels.
pub const GAP_PX: u32 = 8;

/// The picture of runs on `map`, one panel each, left to right: the map (blocked, explored
/// by 90 %, explored after, unseen), each robot's walk from one position to the next ([`TO_90`], then [`FROM_90`])
/// and its start. A panel is the map at a whole number of pixels a cell, at least 400 px on
/// its longer side; a map of more than 1,024 cells a side is sampled, 1,024 px at most.
pub fn picture(map: &MapData, runs: &[(&Exploration, &Walks)]) -> RgbImage {
    let frame = Frame::of(map);
    let count = u32::try_from(runs.len()).expect("fewer panels than pixels");
    let width = count * frame.width + count.saturating_sub(1) * GAP_PX;
    let mut image = RgbImage::from_pixel(width.max(1), frame.height, GAP);
    for (k, (run, walks)) in (0..).zip(runs) {
        let left = k * (frame.width + GAP_PX);
        frame.draw_map(&mut image, left, map, walks);
        frame.draw_walks(&mut image, left, run, walks);
    }
    image
}

/// How a map's metres fall on a panel's pixels.
struct Frame {
    origin: DVec2,
    /// Metres a pixel.
    pixel_m: f64,
    width: u32,
    height: u32,
}

impl Frame {
    fn of(map: &MapData) -> Self {
        let grid = map.obstacles.grid();
        let cells = grid.width_cells().max(grid.height_cells()).max(1);
        let pixel_m = if cells > 1024 {
            grid.cell_m() * f64::from(cells) / 1024.0
        } else {
            grid.cell_m() / f64::from(400_u32.div_ceil(cells))
        };
        let px = |m: f64| (m / pixel_m).round().max(1.0) as u32;
        Self {
            origin: grid.origin(),
            pixel_m,
            width: px(grid.width_m()),
            height: px(grid.height_m()),
        }
    }

    /// The centre of pixel `(x, y)` of a panel (y down) on the map (y up).
    fn point(&self, x: u32, y: u32) -> DVec2 {
        let row_from_bottom = f64::from(self.height - 1 - y);
        self.origin + DVec2::new(f64::from(x) + 0.5, row_from_bottom + 0.5) * self.pixel_m
    }

    /// The pixel of a panel holding `p`, if inside.
    fn pixel(&self, p: DVec2) -> Option<(u32, u32)> {
        let q = (p - self.origin) / self.pixel_m;
        let (x, y) = (q.x.floor(), f64::from(self.height) - 1.0 - q.y.floor());
        let inside = x >= 0.0 && y >= 0.0 && x < f64::from(self.width) && y < f64::from(self.height);
        inside.then_some((x as u32, y as u32))
    }

    fn draw_map(&self, image: &mut RgbImage, left: u32, map: &MapData, walks: &Walks) {
        for y in 0..self.height {
            for x in 0..self.width {
                let p = self.point(x, y);
                let colour = if !map.obstacles.is_point_free(p) {
                    BLOCKED
                } else if !walks.explored.is_known(p) {
                    UNSEEN
                } else if walks.explored_at_90.as_ref().is_some_and(|k| !k.is_known(p)) {
                    SEEN_FROM_90
                } else {
                    EXPLORED
                };
                image.put_pixel(left + x, y, colour);
            }
        }
    }

    /// Each robot's steps as straight lines, sampled every half pixel; the starts on top.
    fn draw_walks(&self, image: &mut RgbImage, left: u32, run: &Exploration, walks: &Walks) {
        let at_90 = run.at_90.map_or(u64::MAX, |(round, _)| round);
        for (round, pair) in (1..).zip(walks.positions.windows(2)) {
            let colour = if round <= at_90 { TO_90 } else { FROM_90 };
            for (&a, &b) in pair[0].iter().zip(&pair[1]) {
                let steps = (a.distance(b) / (0.5 * self.pixel_m)).ceil().max(1.0) as u32;
                for i in 0..=steps {
                    let p = a.lerp(b, f64::from(i) / f64::from(steps));
                    if let Some((x, y)) = self.pixel(p) {
                        image.put_pixel(left + x, y, colour);
                    }
                }
            }
        }
        for &p in walks.positions.first().into_iter().flatten() {
            let Some((x, y)) = self.pixel(p) else { continue };
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                if x + dx < self.width && y + dy < self.height {
                    image.put_pixel(left + x + dx, y + dy, START);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use sim_core::glam::DVec2;
    use sim_core::spatial::{Grid, KnownMap, ObstacleMap};
    use sim_core::world::{HomeBase, MapData};

    use super::*;

    /// A 10 m × 5 m map of 0.5 m cells (20 × 10 cells: 20 px a cell, 400 × 200 px) whose
    /// left half is blocked; the run explored the free cells of x 5–6.5 m by the end of its
    /// first round, when 90 % was reached, and of x 5–7.5 m by the end, walking from
    /// (5.25, 2.5) to (7.25, 2.5) in two rounds.
    fn half_blocked() -> (MapData, Exploration, Walks) {
        let grid = Grid::new(DVec2::ZERO, 0.5, 20, 10).unwrap();
        let obstacles = ObstacleMap::from_fn(grid, |x, _| x < 10);
        let known_to = |x_m| {
            let mut known = KnownMap::new(grid);
            known.mark(&sim_core::spatial::Aabb::from_corners(
                DVec2::new(5.0, 0.0),
                DVec2::new(x_m, 5.0),
            ));
            known
        };
        let map = MapData {
            obstacles,
            home: HomeBase::Disc {
                center: DVec2::new(5.25, 2.5),
                radius_m: 0.2,
            },
            treasures: Vec::new(),
        };
        let run = Exploration {
            rounds: 2,
            explored: 0.5,
            at_90: Some((1, 1.0)),
            at_98: None,
            distance_m: 2.0,
            overlap_m: 0.0,
        };
        let at = |x| vec![DVec2::new(x, 2.5)];
        let walks = Walks {
            positions: vec![at(5.25), at(6.25), at(7.25)],
            explored: known_to(7.5),
            explored_at_90: Some(known_to(6.5)),
        };
        (map, run, walks)
    }

    /// Pixels whose colours were worked out from the map by hand: blocked left of x = 5 m
    /// (200 px), explored by 90 % to 6.5 m (260 px), after it to 7.5 m (300 px), unseen
    /// beyond; the walk's row, 2.5 m up, is pixel row 99 (rows counted down from 5 m, the
    /// 100th); the start's pixel at x 210.
    #[test]
    fn a_panel_draws_the_map_the_walk_by_phase_and_the_start() {
        let (map, run, walks) = half_blocked();
        let image = picture(&map, &[(&run, &walks)]);
        assert_eq!(image.dimensions(), (400, 200));
        assert_eq!(*image.get_pixel(100, 20), BLOCKED);
        assert_eq!(*image.get_pixel(250, 20), EXPLORED);
        assert_eq!(*image.get_pixel(259, 20), EXPLORED);
        assert_eq!(*image.get_pixel(260, 20), SEEN_FROM_90);
        assert_eq!(*image.get_pixel(299, 20), SEEN_FROM_90);
        assert_eq!(*image.get_pixel(350, 20), UNSEEN);
        assert_eq!(*image.get_pixel(210, 99), START);
        assert_eq!(*image.get_pixel(230, 99), TO_90, "round 1: 5.25 to 6.25 m");
        assert_eq!(*image.get_pixel(270, 99), FROM_90, "round 2: 6.25 to 7.25 m");
        assert_eq!(*image.get_pixel(295, 99), SEEN_FROM_90, "past the walk's end");
        assert_eq!(*image.get_pixel(230, 150), EXPLORED, "off the walk's row");
    }

    /// A run that never reached 90 % shows everything it explored alike.
    #[test]
    fn a_run_short_of_90_percent_draws_no_cells_seen_after_it() {
        let (map, run, walks) = half_blocked();
        let short = Walks {
            explored_at_90: None,
            ..walks
        };
        let image = picture(&map, &[(&run, &short)]);
        assert_eq!(*image.get_pixel(280, 20), EXPLORED);
        assert_eq!(*image.get_pixel(350, 20), UNSEEN);
    }

    /// Panels stand side by side, [`GAP_PX`] apart, each drawing its own run.
    #[test]
    fn panels_stand_side_by_side() {
        let (map, run, walks) = half_blocked();
        let unexplored = Walks {
            explored: KnownMap::new(*map.obstacles.grid()),
            ..walks.clone()
        };
        let image = picture(&Arc::new(map), &[(&run, &walks), (&run, &unexplored)]);
        assert_eq!(image.dimensions(), (2 * 400 + GAP_PX, 200));
        assert_eq!(*image.get_pixel(250, 20), EXPLORED);
        assert_eq!(*image.get_pixel(400 + GAP_PX + 250, 20), UNSEEN);
        assert_eq!(*image.get_pixel(400 + GAP_PX + 230, 99), TO_90);
    }
}
