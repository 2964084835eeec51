//! The cells a view of one radius holds, worked out once for every place of its centre in a
//! cell, so that marking a robot's view each round need not work them out again.
//!
//! A view holds the cells lying wholly inside its disc ([`Disc::contained_rows`]). Which
//! those are depends on where the centre lies within its cell. The stencil splits a cell
//! into [`BINS`] × [`BINS`] bins and holds, for a centre anywhere in each bin, the cells
//! surely inside the disc (with a margin far wider than any rounding) and the cells that
//! may be. A view takes the first and tests only the few in between (the *ring*) exactly as
//! [`Disc::contained_rows`] does, so its cells are the same to the last bit. Checked by
//! `stencil_rows_are_the_direct_rows` and `stencil_at_the_edges`.

use glam::DVec2;

use crate::spatial::geometry::{Aabb, CellRows, Disc, Shape, cell_within, floor, line_distances};
use crate::spatial::grid::Grid;

/// Bins per cell side.
pub(crate) const BINS: usize = 16;

/// The stencil's margin, in cells: a cell is surely inside when its farthest corner lies
/// this much within the rim from every point of the bin, and may be inside when each of its
/// corners lies no more than this beyond the rim from some point of the bin. Rounding in
/// the exact test, and in placing the centre in its bin, is kept far below it (see
/// [`ViewStencil::rows_into`]).
const MARGIN_CELLS: f64 = 1e-6;

/// The stencil of views of one radius on grids of one cell size.
#[derive(Clone, Debug)]
pub(crate) struct ViewStencil {
    radius_m: f64,
    cell_m: f64,
    /// Cells each way from the centre's cell to the stencil's edge.
    reach: u32,
    /// Per bin (`by * BINS + bx`), per stencil row from `reach` rows below the centre's:
    /// (cells surely inside, cells possibly inside), bit `i` the column `i - reach` from
    /// the centre's.
    rows: Vec<(u64, u64)>,
}

impl ViewStencil {
    /// The stencil of views of `radius_m` on cells of `cell_m`, or `None` for a view more
    /// than 60 cells across (its rows, with a cell of reach each way, are words) or
    /// sizes that are not lengths.
    pub(crate) fn new(radius_m: f64, cell_m: f64) -> Option<Self> {
        if !(radius_m.is_finite() && radius_m >= 0.0 && cell_m.is_finite() && cell_m > 0.0) {
            return None;
        }
        let rho = radius_m / cell_m;
        if rho > 30.0 {
            return None;
        }
        // A contained cell lies within the disc, so within `ceil(rho)` cells of the
        // centre's cell on the far side and `ceil(rho) + 1` on the near side.
        let reach = rho.ceil() as u32 + 1;
        let side = 2 * reach as usize + 1;
        let (inner, outer) = ((rho - MARGIN_CELLS).max(0.0), rho + MARGIN_CELLS);
        let (inner2, outer2) = (inner * inner, outer * outer);
        let mut rows = Vec::with_capacity(BINS * BINS * side);
        let bin = 1.0 / BINS as f64;
        for by in 0..BINS {
            for bx in 0..BINS {
                // The bin's square of centres, in cells from the centre cell's corner.
                let (x0, y0) = (bx as f64 * bin, by as f64 * bin);
                let (x1, y1) = (x0 + bin, y0 + bin);
                for j in 0..side {
                    let (mut sure, mut maybe) = (0u64, 0u64);
                    let v0 = j as f64 - f64::from(reach);
                    for i in 0..side {
                        let u0 = i as f64 - f64::from(reach);
                        let corners = [(u0, v0), (u0 + 1.0, v0), (u0, v0 + 1.0), (u0 + 1.0, v0 + 1.0)];
                        // Farthest from any centre in the bin: a corner of the bin.
                        let farthest = corners
                            .iter()
                            .map(|&(u, v)| {
                                (u - x0).abs().max((u - x1).abs()).powi(2) + (v - y0).abs().max((v - y1).abs()).powi(2)
                            })
                            .fold(0.0, f64::max);
                        // Each corner's nearest centre in the bin.
                        let each_near = corners.iter().all(|&(u, v)| {
                            let dx = (x0 - u).max(u - x1).max(0.0);
                            let dy = (y0 - v).max(v - y1).max(0.0);
                            dx * dx + dy * dy <= outer2
                        });
                        sure |= u64::from(farthest <= inner2 && inner > 0.0) << i;
                        maybe |= u64::from(each_near) << i;
                    }
                    rows.push((sure, maybe | sure));
                }
            }
        }
        Some(Self {
            radius_m,
            cell_m,
            reach,
            rows,
        })
    }

    /// Whether this is the stencil of views of `radius_m` on cells of `cell_m`.
    #[inline]
    pub(crate) fn is_for(&self, radius_m: f64, cell_m: f64) -> bool {
        self.radius_m.to_bits() == radius_m.to_bits() && self.cell_m.to_bits() == cell_m.to_bits()
    }

    /// [`Disc::contained_rows_into`] for a disc of this stencil's radius on `grid` (of its
    /// cell size), when the disc's box of cells lies within `clip` and the grid: the same
    /// rows, `x0`, `y0` and length. Returns `false`, having written nothing, otherwise (the
    /// caller works the rows out directly), and for centres so far from the origin that
    /// rounding could reach the margin.
    pub(crate) fn rows_into(&self, disc: &Disc, grid: &Grid, clip: &Aabb, out: &mut CellRows) -> bool {
        self.place(disc, grid, clip)
            .is_some_and(|view| view.rows_except_into(grid, None, out))
    }

    /// The stencil placed for a view `disc` of its radius on `grid` (of its cell size): its
    /// box of cells and the bin's rows over it, or `None` where [`rows_into`](Self::rows_into)
    /// declines (a box not within `clip` and the grid, or centres so far from the origin
    /// that rounding could reach the margin).
    pub(crate) fn place<'a>(&'a self, disc: &Disc, grid: &Grid, clip: &Aabb) -> Option<PlacedView<'a>> {
        debug_assert!(self.is_for(disc.radius, grid.cell_m()));
        let (lo, hi) = grid.cells_touching(&disc.bounds())?;
        let within = clip.contains_box(&Aabb {
            min: grid.corner(lo.0, lo.1),
            max: grid.corner(hi.0 + 1, hi.1 + 1),
        });
        let c = disc.center;
        // Rounding in the coordinates is a few units in the last place of the largest of
        // them: far below the margin while they are under a million cells.
        let scale = c.x.abs().max(c.y.abs()) + grid.origin().x.abs().max(grid.origin().y.abs()) + disc.radius;
        if !within || hi.0 - lo.0 >= 64 || hi.1 - lo.1 >= 64 || scale * 1e-12 > MARGIN_CELLS * self.cell_m {
            return None;
        }
        // The centre's cell and its place in it, in bins (clamped: rounding may put it a
        // hair outside the cell, which the margin covers).
        let rel = (c - grid.origin()) / self.cell_m;
        let (ix, iy) = (floor(rel.x), floor(rel.y));
        let bin_of = |f: f64| ((f * BINS as f64) as usize).min(BINS - 1);
        let bin = bin_of(rel.y - iy) * BINS + bin_of(rel.x - ix);
        let side = 2 * self.reach as usize + 1;
        // Stencil column 0 and row 0 as grid cells (`ix`, `iy` are within the box).
        let (sx, sy) = (ix as i64 - i64::from(self.reach), iy as i64 - i64::from(self.reach));
        let len = (hi.1 - lo.1 + 1) as usize;
        // The box's rows of the stencil (all of them lie in it: a cell touching the disc's
        // box lies within `ceil(rho) + 1` cells of the centre's).
        let rows = usize::try_from(i64::from(lo.1) - sy)
            .ok()
            .and_then(|t0| self.rows[bin * side..(bin + 1) * side].get(t0..t0 + len))?;
        // The box's columns, as stencil bits (cells beyond it, off the map, are not
        // the view's: the direct rows hold the box's cells only).
        let (first, last) = (i64::from(lo.0) - sx, i64::from(hi.0) - sx);
        let cols = if first > 63 || last < 0 {
            0
        } else {
            (u64::MAX >> (63 - last.min(63))) & (u64::MAX << first.max(0))
        };
        Some(PlacedView {
            center: c,
            r2: disc.radius * disc.radius,
            lo,
            hi,
            sx,
            rows,
            cols,
        })
    }
}

/// A [`ViewStencil`] placed for one view (see [`ViewStencil::place`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlacedView<'a> {
    center: DVec2,
    r2: f64,
    /// The view's box of cells.
    lo: (u32, u32),
    hi: (u32, u32),
    /// Stencil column 0 as a grid column.
    sx: i64,
    /// The bin's (surely inside, possibly inside) rows over the box's rows.
    rows: &'a [(u64, u64)],
    /// The box's columns, as stencil bits.
    cols: u64,
}

impl PlacedView<'_> {
    /// The view's box of cells, `lo ..= hi`.
    #[inline]
    pub(crate) fn cells(&self) -> ((u32, u32), (u32, u32)) {
        (self.lo, self.hi)
    }

    /// The view's cells (see [`ViewStencil::rows_into`]) without those of `known`, which
    /// must cover the view's box of cells: a view's cells not known yet. The cells on the
    /// view's rim that `known` holds are not tested. Returns `false`, leaving `out` as it
    /// was, where `known` holds every cell the view may hold (nothing is new).
    pub(crate) fn rows_except_into(&self, grid: &Grid, known: Option<KnownRows>, out: &mut CellRows) -> bool {
        /// What no cell being known looks like.
        const NOTHING_KNOWN: [u64; 64] = [0; 64];
        let (lo, c, sx, cols, r2) = (self.lo, self.center, self.sx, self.cols, self.r2);
        let len = self.rows.len();
        // Stencil columns to the box's (the output's), and the known rows' columns to the
        // stencil's, each as a left and a right shift, so that rows take no branch.
        let split = |d: i64| (d.max(0) as u32, (-d).max(0) as u32);
        let (out_left, out_right) = split(sx - i64::from(lo.0));
        let (known_rows, (known_left, known_right)) = match known {
            Some(k) => (&k.rows[(lo.1 - k.y0) as usize..][..len], split(i64::from(k.x0) - sx)),
            None => (&NOTHING_KNOWN[..len], (0, 0)),
        };
        // A known row in the stencil's columns.
        let aligned = |known: u64| (known << known_left) >> known_right;
        // Most views of a walker hold only known cells: a word operation a row tells,
        // before any rim cell is tested or row written.
        if known.is_some()
            && self
                .rows
                .iter()
                .zip(known_rows)
                .all(|(&(_, maybe), &known)| maybe & cols & !aligned(known) == 0)
        {
            return false;
        }
        let old_len = out.len;
        let rows = self.rows.iter().zip(known_rows);
        for (j, (o, (&(sure, maybe), &known))) in out.rows[..len].iter_mut().zip(rows).enumerate() {
            let known = aligned(known);
            let mut row = sure & !known;
            let mut ring = maybe & !sure & cols & !known;
            if ring != 0 {
                let y = lo.1 + j as u32;
                let (ny, fy) = distances(c.y, grid.corner(0, y).y, grid.corner(0, y + 1).y);
                while ring != 0 {
                    let i = ring.trailing_zeros();
                    ring &= ring - 1;
                    let x = u32::try_from(sx + i64::from(i)).expect("the box's cells are the grid's");
                    let (nx, fx) = distances(c.x, grid.corner(x, 0).x, grid.corner(x + 1, 0).x);
                    if cell_within(fx + fy, nx + ny, r2) {
                        row |= 1 << i;
                    }
                }
            }
            *o = ((row & cols) >> out_right) << out_left;
        }
        if len < old_len {
            out.rows[len..old_len].fill(0);
        }
        (out.x0, out.y0, out.len) = (lo.0, lo.1, len);
        true
    }
}

/// Cells known already, which [`PlacedView::rows_except_into`] leaves out of a view: bit
/// `i` of `rows[j]` is cell `(x0 + i, y0 + j)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct KnownRows<'a> {
    /// Column of bit 0.
    pub(crate) x0: u32,
    /// Row of `rows[0]`.
    pub(crate) y0: u32,
    /// The rows, south to north.
    pub(crate) rows: &'a [u64],
}

/// Squared distances from `c` to the nearest point and to the farther line of the span
/// `a..b`, with the arithmetic of the direct rows (the same bits).
#[inline]
fn distances(c: f64, a: f64, b: f64) -> (f64, f64) {
    line_distances(c, (a, (a - c) * (a - c)), (b, (b - c) * (b - c)))
}

/// The stencils a thread has built, and the key it was last asked for: a stencil is built
/// on the second request in a row for the same radius and cell size (a robot's views, one
/// after another), not for one-off discs.
#[derive(Debug, Default)]
pub(crate) struct Stencils {
    built: Vec<ViewStencil>,
    last_asked: Option<(u64, u64)>,
}

/// Stencils kept per thread (a run has a view radius per robot type).
const KEPT: usize = 8;

impl Stencils {
    /// The stencil for views of `radius_m` on cells of `cell_m`, built when asked twice in
    /// a row, or `None` (then the rows are worked out directly).
    pub(crate) fn get(&mut self, radius_m: f64, cell_m: f64) -> Option<&ViewStencil> {
        if let Some(k) = self.built.iter().position(|s| s.is_for(radius_m, cell_m)) {
            return Some(&self.built[k]);
        }
        let key = (radius_m.to_bits(), cell_m.to_bits());
        if self.last_asked.replace(key) != Some(key) {
            return None;
        }
        let stencil = ViewStencil::new(radius_m, cell_m)?;
        if self.built.len() == KEPT {
            self.built.remove(0);
        }
        self.built.push(stencil);
        self.built.last()
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec2;
    use rand::{Rng, SeedableRng};

    use super::{BINS, KnownRows, ViewStencil};
    use crate::spatial::geometry::{CellRows, Disc};
    use crate::spatial::grid::Grid;

    /// The corner of bin `bin` (0 ..= BINS: the last is the next cell's edge) of `cell`.
    fn bin_corner(grid: &Grid, cell: (u32, u32), bin: (usize, usize)) -> DVec2 {
        grid.corner(cell.0, cell.1) + DVec2::new(bin.0 as f64, bin.1 as f64) * (grid.cell_m() / BINS as f64)
    }

    /// The direct rows of a disc (the reference).
    fn direct(disc: &Disc, grid: &Grid) -> CellRows {
        let mut rows = CellRows::empty();
        assert!(disc.contained_rows_into(grid, &grid.extent(), &mut rows));
        rows
    }

    /// The stencil's rows are the direct rows, bit for bit, for centres anywhere (at
    /// random, on bin edges, on grid lines and corners, where rims pass through grid
    /// corners), several radii and cell sizes, on grids whose origin is off zero.
    #[test]
    fn stencil_rows_are_the_direct_rows() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (cell_m, origin) in [
            (1.0, DVec2::ZERO),
            (0.5, DVec2::new(-37.25, 12.5)),
            (0.3, DVec2::new(1e4, -2e4)),
        ] {
            let grid = Grid::new(origin, cell_m, 200, 200).unwrap();
            for radius_cells in [0.4, 1.0, 2.5, 5.0, 5.0 + 1e-12, 7.3, 13.0, 29.9] {
                let radius = radius_cells * cell_m;
                let stencil = ViewStencil::new(radius, cell_m).expect("at most 30 cells");
                let mut centres = Vec::new();
                for _ in 0..400 {
                    let cell = (rng.random_range(40..160), rng.random_range(40..160));
                    let bin = (rng.random_range(0..=BINS), rng.random_range(0..=BINS));
                    centres.push(bin_corner(&grid, cell, bin));
                    let f = DVec2::new(rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
                    centres.push(grid.corner(cell.0, cell.1) + f * cell_m);
                    centres.push(grid.corner(cell.0, cell.1) + DVec2::new(0.5, 0.5) * cell_m);
                }
                for center in centres {
                    let disc = Disc { center, radius };
                    let mut got = CellRows::empty();
                    assert!(stencil.rows_into(&disc, &grid, &grid.extent(), &mut got));
                    let want = direct(&disc, &grid);
                    assert_eq!(got, want, "centre {center}, radius {radius}");
                    // Leaving out known cells, given over 64 columns and more rows that
                    // cover the view's box (as a known-cell window does): exactly the rest.
                    let view = stencil.place(&disc, &grid, &grid.extent()).expect("inside the map");
                    let (lo, hi) = view.cells();
                    assert_eq!((lo.0, lo.1, (hi.1 - lo.1 + 1) as usize), (want.x0, want.y0, want.len));
                    let spare = 63 - (hi.0 - lo.0);
                    let x0 = want.x0 - rng.random_range(0..=spare.min(want.x0));
                    let y0 = want.y0 - rng.random_range(0..=want.y0.min(3));
                    // A quarter of the cells known, or the view's own cells and a few
                    // more (those that decide whether anything is new), or every cell.
                    let mode = rng.random_range(0..3);
                    let offset = (want.y0 - y0) as usize;
                    let rows: Vec<u64> = (0..70usize)
                        .map(|j| match (mode, j.checked_sub(offset).filter(|&j| j < want.len)) {
                            (0, _) => rng.random::<u64>() & rng.random::<u64>(),
                            (1, Some(j)) => {
                                want.rows[j] << (want.x0 - x0) | (rng.random::<u64>() & rng.random::<u64>())
                            }
                            (1, None) => rng.random(),
                            _ => u64::MAX,
                        })
                        .collect();
                    let known = KnownRows { x0, y0, rows: &rows };
                    let nothing_new = !view.rows_except_into(&grid, Some(known), &mut got);
                    if nothing_new {
                        got = CellRows::empty();
                        (got.x0, got.y0, got.len) = (want.x0, want.y0, want.len);
                    }
                    let all_known = mode == 2;
                    assert!(nothing_new || !all_known, "every cell known, yet rows were made");
                    for j in 0..want.len {
                        let known = rows[j + (want.y0 - y0) as usize] >> (want.x0 - x0);
                        assert_eq!(
                            got.rows[j],
                            want.rows[j] & !known,
                            "centre {center}, radius {radius}, row {j}"
                        );
                    }
                }
            }
        }
    }

    /// Views at the map's edges: where their box is clamped to the grid the stencil gives
    /// the direct rows; where it crosses the map's extent (a grid narrower than its
    /// covering square) it declines, writing nothing, and the direct rows are taken.
    #[test]
    fn stencil_at_the_edges() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 64, 40).unwrap();
        let stencil = ViewStencil::new(5.0, 1.0).unwrap();
        for center in [
            DVec2::new(3.0, 30.0),
            DVec2::new(0.2, 0.7),
            DVec2::new(63.9, 20.5),
            DVec2::new(30.0, 2.0),
        ] {
            let disc = Disc { center, radius: 5.0 };
            let mut rows = CellRows::empty();
            assert!(stencil.rows_into(&disc, &grid, &grid.extent(), &mut rows));
            assert_eq!(rows, direct(&disc, &grid), "centre {center}");
        }
        let mut rows = CellRows::empty();
        let disc = Disc {
            center: DVec2::new(30.0, 37.0),
            radius: 5.0,
        };
        assert!(!stencil.rows_into(&disc, &grid, &grid.extent(), &mut rows));
        assert_eq!(rows, CellRows::empty());
        assert!(ViewStencil::new(31.0, 1.0).is_none(), "a view 63 cells across");
    }
}
