//! Generators that work on a raster: white noise (no raster, but per cell), caves, maze, rooms.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::spatial::ObstacleMap;

use super::{GenerateOptions, cell_hash, unit};
use crate::raster::{Cells, check_raster_size};
use crate::{EditorError, Result};

/// White noise: every cell is blocked independently with probability `density` (default 0.1).
pub fn white_noise(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    check_raster_size(grid.width_cells(), grid.height_cells(), "white noise")?;
    let d = opts.density_or(0.1)?;
    let seed = opts.seed;
    Ok(ObstacleMap::from_fn(grid, |x, y| unit(cell_hash(x, y, seed)) < d))
}

/// Caves: random fill at `density` (default 0.45), then five rounds of the 4-5 rule (a cell
/// becomes rock with ≥ 5 rock neighbours of 8, stays rock with ≥ 4; outside counts as rock).
pub fn caves(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    let (w, h) = (grid.width_cells(), grid.height_cells());
    check_raster_size(w, h, "caves")?;
    let d = opts.density_or(0.45)?;
    let mut cells = Cells::new(w, h, 0);
    for y in 0..h {
        for x in 0..w {
            cells.set(x, y, u8::from(unit(cell_hash(x, y, opts.seed)) < d));
        }
    }
    let mut next = cells.clone();
    for _ in 0..5 {
        for y in 0..h {
            for x in 0..w {
                let mut n = 0;
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
                        let rock = nx < 0
                            || ny < 0
                            || nx >= i64::from(w)
                            || ny >= i64::from(h)
                            || cells.get(nx as u32, ny as u32) != 0;
                        n += u32::from(rock);
                    }
                }
                let was = cells.get(x, y) != 0;
                next.set(x, y, u8::from(n >= 5 || (was && n >= 4)));
            }
        }
        std::mem::swap(&mut cells, &mut next);
    }
    Ok(cells.to_map(grid))
}

/// A perfect maze (randomised depth-first search): corridors `scale_m` wide (default 2 m),
/// walls one cell thick; every corridor cell is reachable from every other.
pub fn maze(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    let (w, h) = (grid.width_cells(), grid.height_cells());
    check_raster_size(w, h, "maze")?;
    let corridor = ((opts.scale_or(2.0)? / opts.cell_m).round() as u32).max(1);
    let pitch = corridor + 1;
    let (mw, mh) = ((w.saturating_sub(1)) / pitch, (h.saturating_sub(1)) / pitch);
    if mw == 0 || mh == 0 {
        return Err(EditorError::InvalidParameter(format!(
            "the map is too small for a maze with {corridor}-cell corridors"
        )));
    }
    let mut cells = Cells::new(w, h, 1);
    let carve = |cells: &mut Cells, x0: u32, y0: u32, cw: u32, ch: u32| {
        for y in y0..y0 + ch {
            for x in x0..x0 + cw {
                cells.set(x, y, 0);
            }
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let mut seen = vec![false; (mw * mh) as usize];
    let start = (rng.random_range(0..mw), rng.random_range(0..mh));
    let mut stack = vec![start];
    seen[(start.1 * mw + start.0) as usize] = true;
    carve(&mut cells, 1 + start.0 * pitch, 1 + start.1 * pitch, corridor, corridor);
    while let Some(&(cx, cy)) = stack.last() {
        let mut nbs: Vec<(u32, u32)> = [(0i64, 1i64), (1, 0), (0, -1), (-1, 0)]
            .iter()
            .map(|&(dx, dy)| (i64::from(cx) + dx, i64::from(cy) + dy))
            .filter(|&(x, y)| x >= 0 && y >= 0 && x < i64::from(mw) && y < i64::from(mh))
            .map(|(x, y)| (x as u32, y as u32))
            .filter(|&(x, y)| !seen[(y * mw + x) as usize])
            .collect();
        if nbs.is_empty() {
            stack.pop();
            continue;
        }
        nbs.shuffle(&mut rng);
        let (nx, ny) = nbs[0];
        seen[(ny * mw + nx) as usize] = true;
        let (x0, y0) = (1 + cx.min(nx) * pitch, 1 + cy.min(ny) * pitch);
        if nx == cx {
            carve(&mut cells, x0, y0, corridor, 2 * corridor + 1);
        } else {
            carve(&mut cells, x0, y0, 2 * corridor + 1, corridor);
        }
        stack.push((nx, ny));
    }
    Ok(cells.to_map(grid))
}

/// Rooms by recursive division: an outer wall, then walls one cell thick splitting the space
/// until rooms are smaller than twice `scale_m` (default 8 m), each wall with one door of
/// `max(2 m, 2 cells)`; a wall never ends at a door of an earlier wall.
pub fn rooms(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    let (w, h) = (grid.width_cells(), grid.height_cells());
    check_raster_size(w, h, "rooms")?;
    let min_room = ((opts.scale_or(8.0)? / opts.cell_m).round() as u32).max(2);
    let door = ((2.0 / opts.cell_m).ceil() as u32).max(2);
    if w < 3 || h < 3 {
        return Err(EditorError::InvalidParameter("the map is too small for rooms".into()));
    }
    let mut cells = Cells::new(w, h, 0);
    for x in 0..w {
        cells.set(x, 0, 1);
        cells.set(x, h - 1, 1);
    }
    for y in 0..h {
        cells.set(0, y, 1);
        cells.set(w - 1, y, 1);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    // Door cells: 2 marks a door, which no later wall may end against.
    let mut stack = vec![(1u32, 1u32, w - 1, h - 1)]; // interior [x0, x1) × [y0, y1)
    while let Some((x0, y0, x1, y1)) = stack.pop() {
        let (rw, rh) = (x1 - x0, y1 - y0);
        let vertical = match rw.cmp(&rh) {
            std::cmp::Ordering::Greater => true,
            std::cmp::Ordering::Less => false,
            std::cmp::Ordering::Equal => rng.random(),
        };
        let span = if vertical { rw } else { rh };
        let len = if vertical { rh } else { rw };
        if span < 2 * min_room + 1 || len < door + 1 {
            continue;
        }
        // Wall position: leaves at least min_room on both sides; its ends must not sit on doors.
        let mut pos = None;
        for _ in 0..32 {
            let p = rng.random_range(min_room..=span - min_room - 1);
            let ok = if vertical {
                let x = x0 + p;
                cells.get(x, y0 - 1) != 2 && cells.get(x, y1) != 2
            } else {
                let y = y0 + p;
                cells.get(x0 - 1, y) != 2 && cells.get(x1, y) != 2
            };
            if ok {
                pos = Some(p);
                break;
            }
        }
        let Some(p) = pos else { continue };
        let d0 = rng.random_range(0..=len - door);
        for k in 0..len {
            let v = if (d0..d0 + door).contains(&k) { 2 } else { 1 };
            if vertical {
                cells.set(x0 + p, y0 + k, v);
            } else {
                cells.set(x0 + k, y0 + p, v);
            }
        }
        if vertical {
            stack.push((x0, y0, x0 + p, y1));
            stack.push((x0 + p + 1, y0, x1, y1));
        } else {
            stack.push((x0, y0, x1, y0 + p));
            stack.push((x0, y0 + p + 1, x1, y1));
        }
    }
    Ok(ObstacleMap::from_fn(grid, |x, y| cells.get(x, y) == 1))
}
