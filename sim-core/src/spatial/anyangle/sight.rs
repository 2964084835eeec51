//! Line of sight under the any-angle rules: a path may run along the edge of a blocked cell
//! but not along an edge two blocked cells share, nor through a point where two blocked cells
//! touch diagonally, and everything outside the map is blocked. Coordinates are in cells.

// Exact comparisons are the point here: they detect lattice points and coincident crossings.
#![allow(clippy::float_cmp)]

use glam::DVec2;

use super::raster::CellRaster;

/// Whether the cells around a lattice point (bits as [`CellRaster::around`]) let a path
/// touch it: not all four blocked, and not two blocked cells touching diagonally between two
/// free ones (a pinch). With three blocked the point is a corner of the one free cell; a
/// segment can only end there, since every way through enters a blocked cell.
#[inline]
pub(crate) fn corner_passable(around: u8) -> bool {
    !matches!(around, 0b1111 | 0b1001 | 0b0110)
}

/// Cell index of a coordinate: its floor where that is a cell of the map or beside it; any
/// negative coordinate gives -1 (outside, like its floor). A truncating cast instead of
/// `floor`, which is a library call on the baseline x86-64 target.
#[inline]
#[allow(clippy::cast_possible_truncation)] // Saturating casts: far-away points read as outside.
fn cell(v: f64) -> i64 {
    if v >= 0.0 { v as i64 } else { -1 }
}

/// `p` as a lattice point, if both coordinates are integers small enough for exact integer
/// line walks.
#[inline]
#[allow(clippy::cast_possible_truncation)] // Checked: integral and below 2^31 in magnitude.
fn as_lattice(p: DVec2) -> Option<(i64, i64)> {
    // A cast back and forth instead of `trunc`, a library call on the baseline target.
    let ok = |v: f64| v.abs() < 2_147_483_648.0 && v == (v as i64) as f64;
    (ok(p.x) && ok(p.y)).then_some((p.x as i64, p.y as i64))
}

/// Whether a path may touch point `p`: it lies in the closure of a free cell and is not a
/// point where two blocked cells touch diagonally.
pub(crate) fn point_clear(r: &CellRaster, p: DVec2) -> bool {
    if !p.is_finite() {
        return false;
    }
    let (ix, iy) = (cell(p.x), cell(p.y));
    #[allow(clippy::cast_precision_loss)] // Cell indices are below 2^31: exact in f64.
    let (on_x, on_y) = (p.x == ix as f64, p.y == iy as f64);
    match (on_x, on_y) {
        (false, false) => !r.blocked(ix, iy),
        (true, false) => !(r.blocked(ix - 1, iy) && r.blocked(ix, iy)),
        (false, true) => !(r.blocked(ix, iy - 1) && r.blocked(ix, iy)),
        (true, true) => corner_passable(r.around(ix, iy)),
    }
}

/// The integers strictly between `from` and `to`, in the order a segment meets them.
struct Crossings {
    next: f64,
    last: f64,
    step: f64,
}

impl Crossings {
    fn new(from: f64, to: f64) -> Self {
        if to > from {
            Self {
                next: from.floor() + 1.0,
                last: to.ceil() - 1.0,
                step: 1.0,
            }
        } else if to < from {
            Self {
                next: from.ceil() - 1.0,
                last: to.floor() + 1.0,
                step: -1.0,
            }
        } else {
            Self {
                next: 1.0,
                last: 0.0,
                step: 1.0,
            }
        }
    }

    fn peek(&self) -> Option<f64> {
        let more = if self.step > 0.0 {
            self.next <= self.last
        } else {
            self.next >= self.last
        };
        more.then_some(self.next)
    }
}

/// Whether the straight segment `a → b` is a legal path piece.
///
/// The segment is cut where it crosses grid lines; each piece between two crossings lies in
/// one cell (which must be free) or runs along a grid line (one of the two cells beside it
/// must be free), and each crossing that is a lattice point must not be a diagonal touch of
/// two blocked cells. For lattice endpoints every crossing parameter is a correctly rounded
/// quotient of small integers, so coincident crossings compare equal exactly.
///
/// The ends must already pass [`point_clear`] (corners of the graph, a query's checked start
/// and goal): they are not tested again.
pub(crate) fn segment_between_legal_ends_clear(r: &CellRaster, a: DVec2, b: DVec2) -> bool {
    if let (Some(a), Some(b)) = (as_lattice(a), as_lattice(b)) {
        return lattice_segment_clear(r, a, b);
    }
    let d = b - a;
    if d == DVec2::ZERO {
        return true;
    }
    let along_x = d.y == 0.0 && a.y == a.y.floor();
    let along_y = d.x == 0.0 && a.x == a.x.floor();
    let mut xs = Crossings::new(a.x, b.x);
    let mut ys = Crossings::new(a.y, b.y);
    let mut t_prev = 0.0;
    loop {
        let tx = xs.peek().map_or(f64::INFINITY, |k| (k - a.x) / d.x);
        let ty = ys.peek().map_or(f64::INFINITY, |k| (k - a.y) / d.y);
        let t = tx.min(ty);
        let t_next = t.min(1.0);
        // The piece (t_prev, t_next).
        let mid = a + d * (0.5 * (t_prev + t_next));
        let piece_clear = if along_y {
            !(r.blocked(cell(a.x) - 1, cell(mid.y)) && r.blocked(cell(a.x), cell(mid.y)))
        } else if along_x {
            !(r.blocked(cell(mid.x), cell(a.y) - 1) && r.blocked(cell(mid.x), cell(a.y)))
        } else {
            !r.blocked(cell(mid.x), cell(mid.y))
        };
        if !piece_clear {
            return false;
        }
        if t >= 1.0 {
            return true;
        }
        // The crossing at t: a lattice point when both coordinates are integers there.
        let corner = match (tx == t, ty == t) {
            (true, true) => Some((xs.next, ys.next)),
            (true, false) if along_x => Some((xs.next, a.y)),
            (false, true) if along_y => Some((a.x, ys.next)),
            _ => None,
        };
        if let Some((cx, cy)) = corner
            && !corner_passable(r.around(cell(cx), cell(cy)))
        {
            return false;
        }
        if tx == t {
            xs.next += xs.step;
        }
        if ty == t {
            ys.next += ys.step;
        }
        t_prev = t;
    }
}

/// [`segment_between_legal_ends_clear`] between lattice points, in integers: the next
/// grid line the segment meets is found by comparing `i / |dx|` with `j / |dy|` exactly.
fn lattice_segment_clear(r: &CellRaster, a: (i64, i64), b: (i64, i64)) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (nx, ny) = (dx.abs(), dy.abs());
    let (sx, sy) = (dx.signum(), dy.signum());
    let (mut i, mut j) = (0, 0);
    if nx == 0 && ny == 0 {
        return true;
    }
    loop {
        // The piece after `i` vertical and `j` horizontal grid lines: the column and row it
        // lies in (one side of the line it runs along, when it runs along one).
        let col = if sx >= 0 { a.0 + i } else { a.0 - 1 - i };
        let row = if sy >= 0 { a.1 + j } else { a.1 - 1 - j };
        let piece_clear = match (sx, sy) {
            (0, _) => !(r.blocked(a.0 - 1, row) && r.blocked(a.0, row)),
            (_, 0) => !(r.blocked(col, a.1 - 1) && r.blocked(col, a.1)),
            _ => !r.blocked(col, row),
        };
        if !piece_clear {
            return false;
        }
        let next = if i == nx {
            std::cmp::Ordering::Greater
        } else if j == ny {
            std::cmp::Ordering::Less
        } else {
            ((i + 1) * ny).cmp(&((j + 1) * nx))
        };
        match next {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
        if i == nx && j == ny {
            return true;
        }
        // A lattice point: both lines at once, or one line while running along the other.
        let lattice = match next {
            std::cmp::Ordering::Equal => true,
            std::cmp::Ordering::Less => sy == 0,
            std::cmp::Ordering::Greater => sx == 0,
        };
        if lattice && !corner_passable(r.around(a.0 + sx * i, a.1 + sy * j)) {
            return false;
        }
    }
}
