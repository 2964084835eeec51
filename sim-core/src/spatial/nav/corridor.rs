//! A disc's way through a route's corridor of pieces on the cell grid: the fallback when the
//! string pulled through the portals cannot keep the robot's clearance (on maps of cells
//! smaller than the robot, pieces are a few cells across and their portals too short).

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::DVec2;

use super::pieces::Piece;
use crate::spatial::grid::Grid;

/// Most cells a corridor search looks at: a route's pieces and the ring round them stay far
/// below this; a huge corridor is left to the cheaper crossing points instead.
const MAX_CELLS: usize = 1 << 16;

/// The shortest 8-connected chain of cell centres from `from`'s cell to `goal`'s through the
/// cells of `pieces` and the ring of cells round each, using only cells whose centre passes
/// `free` (the start and goal cells excepted: the robot stands where it stands, and a
/// frontier goal may lie by a wall); a diagonal step needs both cells beside it free, so the
/// chain cuts no corner. Returns the centres after the start's, the last replaced by
/// `goal`; `None` if no chain exists or the corridor holds more than [`MAX_CELLS`] cells.
/// A* on cell centres, ties broken by cell order: deterministic. Cost O(c log c) for c
/// cells, each tested with `free` at most once.
pub(super) fn corridor_path(
    grid: &Grid,
    pieces: &[Piece],
    from: DVec2,
    goal: DVec2,
    free: impl Fn(DVec2) -> bool,
) -> Option<Vec<DVec2>> {
    let start = grid.cell_of(from)?;
    let end = grid.cell_of(goal)?;
    let cells = corridor_cells(grid, pieces)?;
    let index: HashMap<(u32, u32), u32> = cells.iter().enumerate().map(|(i, &c)| (c, i as u32)).collect();
    let (&s, &e) = (index.get(&start)?, index.get(&end)?);
    // Per cell: 0 unknown, 1 free, 2 blocked.
    let mut state = vec![0u8; cells.len()];
    let mut is_free = |i: u32| -> bool {
        if i == s || i == e {
            return true;
        }
        let slot = &mut state[i as usize];
        if *slot == 0 {
            let (x, y) = cells[i as usize];
            *slot = if free(grid.cell_center(x, y)) { 1 } else { 2 };
        }
        *slot == 1
    };
    let cell_m = grid.cell_m();
    let target = grid.cell_center(end.0, end.1);
    let h = |i: u32| {
        let (x, y) = cells[i as usize];
        grid.cell_center(x, y).distance(target)
    };
    let mut dist = vec![f64::INFINITY; cells.len()];
    let mut came = vec![u32::MAX; cells.len()];
    let mut heap = BinaryHeap::new();
    dist[s as usize] = 0.0;
    heap.push(Reverse((h(s).to_bits(), s)));
    while let Some(Reverse((_, i))) = heap.pop() {
        if i == e {
            break;
        }
        let (x, y) = cells[i as usize];
        for (dx, dy) in NEIGHBOURS {
            let Some(j) = step(&index, x, y, dx, dy) else { continue };
            if !is_free(j) {
                continue;
            }
            let diagonal = dx != 0 && dy != 0;
            if diagonal
                && !(step(&index, x, y, dx, 0).is_some_and(&mut is_free)
                    && step(&index, x, y, 0, dy).is_some_and(&mut is_free))
            {
                continue;
            }
            let d = dist[i as usize] + if diagonal { std::f64::consts::SQRT_2 } else { 1.0 } * cell_m;
            if d < dist[j as usize] {
                dist[j as usize] = d;
                came[j as usize] = i;
                // Non-negative floats order as their bits do.
                heap.push(Reverse(((d + h(j)).to_bits(), j)));
            }
        }
    }
    if dist[e as usize].is_infinite() {
        return None;
    }
    Some(chain_back(grid, &cells, &came, (s, e), goal))
}

/// The centres of the cells from start `s` (excluded) to end `e`, following `came` back
/// from `e`, with the last one replaced by `goal` (just `goal` when `s` is `e`).
fn chain_back(grid: &Grid, cells: &[(u32, u32)], came: &[u32], (s, e): (u32, u32), goal: DVec2) -> Vec<DVec2> {
    let mut chain = Vec::new();
    let mut i = e;
    while i != s {
        let (x, y) = cells[i as usize];
        chain.push(grid.cell_center(x, y));
        i = came[i as usize];
    }
    chain.reverse();
    if let Some(last) = chain.last_mut() {
        *last = goal;
    } else {
        chain.push(goal);
    }
    chain
}

/// The eight steps to a cell's neighbours, straight ones first.
const NEIGHBOURS: [(i32, i32); 8] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)];

/// The corridor's cell next to `(x, y)` by `(dx, dy)`, if there is one.
fn step(index: &HashMap<(u32, u32), u32>, x: u32, y: u32, dx: i32, dy: i32) -> Option<u32> {
    let nx = x.checked_add_signed(dx)?;
    let ny = y.checked_add_signed(dy)?;
    index.get(&(nx, ny)).copied()
}

/// The cells of `pieces` and the ring round each, within the grid, sorted and distinct;
/// `None` beyond [`MAX_CELLS`].
fn corridor_cells(grid: &Grid, pieces: &[Piece]) -> Option<Vec<(u32, u32)>> {
    let mut cells = Vec::new();
    for p in pieces {
        let (x0, y0) = (p.x.saturating_sub(1), p.y.saturating_sub(1));
        let x1 = (p.x + p.w + 1).min(grid.width_cells());
        let y1 = (p.y + p.h + 1).min(grid.height_cells());
        let area = u64::from(x1 - x0) * u64::from(y1 - y0);
        if cells.len() as u64 + area > 4 * MAX_CELLS as u64 {
            return None;
        }
        for y in y0..y1 {
            cells.extend((x0..x1).map(|x| (x, y)));
        }
    }
    cells.sort_unstable();
    cells.dedup();
    (cells.len() <= MAX_CELLS).then_some(cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 12 × 5 grid of 0.1 m cells: a wall along row 2 with a gap of `gap` cells at columns
    /// 5.., everything else open.
    fn wall_with_gap(gap: u32) -> (Grid, impl Fn(DVec2) -> bool, Vec<Piece>) {
        let grid = Grid::new(DVec2::ZERO, 0.1, 12, 5).unwrap();
        let blocked = move |x: u32, y: u32| y == 2 && !(5..5 + gap).contains(&x);
        let radius_m = 0.125;
        let free = move |c: DVec2| {
            // Brute force: no blocked cell's square within the radius of `c`.
            (0..12u32).all(|x| {
                (0..5u32).all(|y| {
                    !blocked(x, y) || {
                        let lo = grid.corner(x, y);
                        let hi = grid.corner(x + 1, y + 1);
                        c.clamp(lo, hi).distance(c) >= radius_m
                    }
                })
            })
        };
        let pieces = vec![Piece {
            x: 0,
            y: 0,
            w: 12,
            h: 5,
        }];
        (grid, free, pieces)
    }

    #[test]
    fn a_gap_narrower_than_the_disc_has_no_way_through() {
        // Two free cells (0.2 m) for a 0.25 m disc.
        let (grid, free, pieces) = wall_with_gap(2);
        let (from, goal) = (DVec2::new(0.55, 0.05), DVec2::new(0.55, 0.45));
        assert_eq!(corridor_path(&grid, &pieces, from, goal, &free), None);
    }

    #[test]
    fn a_wide_enough_gap_is_passed_with_every_centre_clear() {
        // Four free cells (0.4 m): centres 0.15 m from the gap's sides pass a 0.125 m disc.
        let (grid, free, pieces) = wall_with_gap(4);
        let (from, goal) = (DVec2::new(0.15, 0.05), DVec2::new(0.15, 0.45));
        let chain = corridor_path(&grid, &pieces, from, goal, &free).expect("a way through the gap");
        assert_eq!(chain.last(), Some(&goal));
        for c in &chain[..chain.len() - 1] {
            assert!(free(*c), "{c} is too close to the wall");
        }
        // Through the middle of the gap (columns 5..9, centres 0.55–0.85): the wall's row.
        assert!(
            chain
                .iter()
                .any(|c| (c.y - 0.25).abs() < 1e-9 && (0.6..0.8).contains(&c.x))
        );
    }

    #[test]
    fn a_corridor_beyond_the_cell_budget_is_left_to_the_crossings() {
        let grid = Grid::new(DVec2::ZERO, 0.1, 300, 300).unwrap();
        let hall = [Piece {
            x: 0,
            y: 0,
            w: 300,
            h: 300,
        }];
        let (from, goal) = (DVec2::new(0.05, 0.05), DVec2::new(29.95, 29.95));
        assert_eq!(corridor_path(&grid, &hall, from, goal, |_| true), None);
        let room = [Piece {
            x: 0,
            y: 0,
            w: 20,
            h: 20,
        }];
        let (from, goal) = (DVec2::new(0.05, 0.05), DVec2::new(1.95, 1.95));
        let chain = corridor_path(&grid, &room, from, goal, |_| true).unwrap();
        // Open ground: the diagonal, one cell a step.
        assert_eq!(chain.len(), 19);
    }
}
