//! Plane geometry shared by the spatial structures: axis-aligned boxes, discs, capsules
//! (swept discs) and the overlap tests the quadtrees prune with.
//!
//! Conventions: boxes are closed, discs and capsules are open. A robot that *touches* a wall
//! is therefore legal, and a shape "intersects" a box only when it overlaps the box's area.

use glam::DVec2;

/// An axis-aligned box `[min, max]` in world (or cell) coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower-left corner.
    pub min: DVec2,
    /// Upper-right corner.
    pub max: DVec2,
}

impl Aabb {
    /// A distance far larger than any rounding in box and distance arithmetic at this box's
    /// coordinates: boxes farther apart than this are apart whatever the rounding.
    pub(crate) fn rounding_margin(&self) -> f64 {
        let scale = self.min.abs().max_element().max(self.max.abs().max_element());
        1e-9 * (1.0 + scale)
    }

    /// A box from its two corners (in any order).
    pub fn from_corners(a: DVec2, b: DVec2) -> Self {
        Self {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// Width times height.
    pub fn area(&self) -> f64 {
        let d = self.max - self.min;
        d.x * d.y
    }

    /// Centre point.
    pub fn center(&self) -> DVec2 {
        (self.min + self.max) * 0.5
    }

    /// Of the 64 cells of a block, those that share area with this box (as
    /// [`overlaps_open`](Self::overlaps_open)) and whose part in it lies within squared
    /// distance `max_d2` of `p`, the part's [`distance_squared_to`](Self::distance_squared_to)
    /// worked out with the same operations, so to the last bit; bit `8 j + i` is cell
    /// `(i, j)`. Per column and row once, then combined. Checked by
    /// `cells_with_part_near_match_the_tests_cell_by_cell`.
    pub fn cells_with_part_near(&self, cells: &BlockCells, p: DVec2, max_d2: f64) -> u64 {
        // Along an axis: the cell's part in the box, `p` clamped into it, the gap squared.
        let gaps = |edges: &[f64; 9], c: f64, min: f64, max: f64| -> [f64; 8] {
            std::array::from_fn(|i| {
                let d = c.max(edges[i].max(min)).min(edges[i + 1].min(max)) - c;
                d * d
            })
        };
        let dx = gaps(&cells.xs, p.x, self.min.x, self.max.x);
        let dy = gaps(&cells.ys, p.y, self.min.y, self.max.y);
        self.overlap_cells(cells) & cell_mask(&dx, &dy, |x, y| x + y <= max_d2)
    }

    /// The cells of a block sharing area with this box ([`overlaps_open`](Self::overlaps_open)),
    /// by column and row: a cell passes when its column and its row do.
    fn overlap_cells(&self, cells: &BlockCells) -> u64 {
        let cols = axis_mask(&cells.xs, |lo, hi| self.min.x < hi && lo < self.max.x);
        let rows = axis_mask(&cells.ys, |lo, hi| self.min.y < hi && lo < self.max.y);
        outer_mask(cols, rows)
    }

    /// Squared distance from `p` to the closed box (0 inside).
    pub fn distance_squared_to(&self, p: DVec2) -> f64 {
        let q = p.clamp(self.min, self.max);
        q.distance_squared(p)
    }

    /// Whether `p` lies strictly inside.
    pub fn contains_strictly(&self, p: DVec2) -> bool {
        p.x > self.min.x && p.x < self.max.x && p.y > self.min.y && p.y < self.max.y
    }

    /// The squared distance from `p` to the farthest corner.
    pub fn farthest_corner_distance_squared(&self, p: DVec2) -> f64 {
        let dx = above((p.x - self.min.x).abs(), (p.x - self.max.x).abs());
        let dy = above((p.y - self.min.y).abs(), (p.y - self.max.y).abs());
        dx * dx + dy * dy
    }

    /// The four corners, counter-clockwise from `min`.
    pub fn corners(&self) -> [DVec2; 4] {
        [
            self.min,
            DVec2::new(self.max.x, self.min.y),
            self.max,
            DVec2::new(self.min.x, self.max.y),
        ]
    }

    /// Whether the open interiors of two boxes overlap.
    pub fn overlaps_open(&self, other: &Aabb) -> bool {
        self.min.x < other.max.x && other.min.x < self.max.x && self.min.y < other.max.y && other.min.y < self.max.y
    }

    /// Whether `other` lies inside `self` (closed).
    pub fn contains_box(&self, other: &Aabb) -> bool {
        self.min.x <= other.min.x && self.min.y <= other.min.y && other.max.x <= self.max.x && other.max.y <= self.max.y
    }
}

/// How a shape relates to a box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Overlap {
    /// No common area.
    Disjoint,
    /// Some common area, but the box is not inside the shape.
    Partial,
    /// The whole box lies inside the shape.
    Contains,
}

/// A region of the plane the quadtrees can test boxes against.
pub trait Shape {
    /// How the shape relates to the closed box `b`.
    fn classify(&self, b: &Aabb) -> Overlap;
    /// Whether the shape and the box share some area (the cheap half of `classify`).
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        self.classify(b) != Overlap::Disjoint
    }
    /// A box enclosing the shape.
    fn bounds(&self) -> Aabb;
    /// [`classify`](Self::classify) for each of the 64 cells of an 8 × 8 block at once, or
    /// `None` (the default) to have them classified one square at a time. The quadtree's
    /// packed bottom asks this; an answer must agree with `classify` cell by cell (checked
    /// by `classify_cells_agrees_with_classify_cell_by_cell`).
    #[inline]
    fn classify_cells(&self, _cells: &BlockCells) -> Option<CellMasks> {
        None
    }
    /// The `intersects` half of [`classify_cells`](Self::classify_cells), all a query
    /// needs.
    #[inline]
    fn intersects_cells(&self, cells: &BlockCells) -> Option<u64> {
        self.classify_cells(cells).map(|m| m.intersects)
    }
    /// Whether a walk that learnt a block's cells from
    /// [`intersects_cells`](Self::intersects_cells) may visit the block's leaves in Z order
    /// (default), or must keep its own order (leaf children last to first, then the mixed
    /// ones first to last, as without the cells' answers): for a visitor that depends on
    /// the order, as a nearest-point search breaking ties by it does.
    #[inline]
    fn cells_in_z_order(&self) -> bool {
        true
    }
}

/// The cells of an 8 × 8 block: the x of its 9 column edges and the y of its 9 row edges
/// (cell `(i, j)` spans `xs[i]..xs[i + 1]` × `ys[j]..ys[j + 1]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockCells {
    /// Column edges, west to east.
    pub xs: [f64; 9],
    /// Row edges, south to north.
    pub ys: [f64; 9],
}

/// How a shape relates to each cell of a [`BlockCells`]: bit `8 j + i` is cell `(i, j)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellMasks {
    /// Cells the shape wholly contains ([`Overlap::Contains`]).
    pub contains: u64,
    /// Cells the shape overlaps at all (not [`Overlap::Disjoint`]); a superset of `contains`.
    pub intersects: u64,
}

impl CellMasks {
    /// The cells both `self` and `other` contain or overlap (an intersection of shapes).
    #[must_use]
    pub fn and(self, other: CellMasks) -> CellMasks {
        CellMasks {
            contains: self.contains & other.contains,
            intersects: self.intersects & other.intersects,
        }
    }
}

/// Per-cell squared distances from `c` along one axis of a block: (to the nearest point, to
/// the farthest edge), computed as [`Aabb::distance_squared_to`] and
/// [`Aabb::farthest_corner_distance_squared`] do, so the sums are bit for bit theirs.
#[inline]
fn axis_distances(edges: &[f64; 9], c: f64) -> ([f64; 8], [f64; 8]) {
    let mut near = [0.0; 8];
    let mut far = [0.0; 8];
    for i in 0..8 {
        (near[i], far[i]) = edge_distances(c, edges[i], edges[i + 1]);
    }
    (near, far)
}

/// Squared distances from `c` to the nearest point of `lo..hi` and to its farther end: one
/// axis of [`Aabb::distance_squared_to`] and [`Aabb::farthest_corner_distance_squared`].
#[inline]
fn edge_distances(c: f64, lo: f64, hi: f64) -> (f64, f64) {
    let d = below(above(c, lo), hi) - c;
    let f = above((c - lo).abs(), (c - hi).abs());
    (d * d, f * f)
}

/// [`edge_distances`] of `c` and `lo..hi` from the lines' squared distances `(lo, (lo -
/// c)²)` and `(hi, (hi - c)²)`, to the same bits: `c` clamped to the span is `lo` when `c`
/// is not above it, `hi` when it is not below it, else `c` itself (distance 0); and the
/// square of the larger distance is the larger square, squaring being monotone.
#[inline]
pub(crate) fn line_distances(c: f64, (lo, d_lo): (f64, f64), (hi, d_hi): (f64, f64)) -> (f64, f64) {
    let near = if c > lo { if c < hi { 0.0 } else { d_hi } } else { d_lo };
    (near, above(d_lo, d_hi))
}

/// Whether a cell lies wholly inside an open disc of squared radius `r2`, from the squared
/// distances of its farthest corner and its nearest point (as [`line_distances`] sums them
/// per axis): `near <= far` always (term by term, and rounding keeps the order of sums), so
/// the nearer point's test matters only when the farther corner lies exactly on the rim.
/// The one test of a view's cells, worked out directly or by a stencil.
#[inline]
pub(crate) fn cell_within(far: f64, near: f64, r2: f64) -> bool {
    far <= r2 && (far < r2 || near < r2)
}

/// The larger of two numbers, by one comparison, as glam's vector `max` selects: `f64::max`
/// for numbers (zeros aside, whose sign the squares taken here drop) without its NaN
/// handling, for the per-row and per-column sums of view marking.
#[inline]
fn above(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// The smaller of two numbers (see [`above`]).
#[inline]
fn below(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// The cells `(i, j)` of a block for which `test(along_x[i], along_y[j])` holds, as a row-major
/// mask; branch-free, as cells on a shape's rim are as likely in as out.
#[inline]
fn cell_mask(along_x: &[f64; 8], along_y: &[f64; 8], test: impl Fn(f64, f64) -> bool) -> u64 {
    let mut mask = 0u64;
    for (j, &y) in along_y.iter().enumerate() {
        // A row's eight tests into a byte first: the compiler makes them vector compares.
        let mut row = 0u64;
        for (i, &x) in along_x.iter().enumerate() {
            row |= u64::from(test(x, y)) << i;
        }
        mask |= row << (8 * j);
    }
    mask
}

/// Per-cell tests along one axis of a block, as a row mask (bit `i`: column `i`).
#[inline]
fn axis_mask(edges: &[f64; 9], test: impl Fn(f64, f64) -> bool) -> u64 {
    (0..8).fold(0, |m, i| m | u64::from(test(edges[i], edges[i + 1])) << i)
}

/// The cells in rows where `rows` is set and columns where `cols` is set.
#[inline]
fn outer_mask(cols: u64, rows: u64) -> u64 {
    (0..8).fold(0, |m, j| if rows >> j & 1 != 0 { m | cols << (8 * j) } else { m })
}

impl<S: Shape + ?Sized> Shape for &S {
    fn classify(&self, b: &Aabb) -> Overlap {
        (**self).classify(b)
    }
    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        (**self).classify_cells(cells)
    }
    fn intersects_cells(&self, cells: &BlockCells) -> Option<u64> {
        (**self).intersects_cells(cells)
    }
    fn cells_in_z_order(&self) -> bool {
        (**self).cells_in_z_order()
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn intersects(&self, b: &Aabb) -> bool {
        (**self).intersects(b)
    }
}

/// An open disc.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Disc {
    /// Centre.
    pub center: DVec2,
    /// Radius (≥ 0).
    pub radius: f64,
}

/// A rectangle of grid cells as row masks: bit `i` of `rows[j]` is cell `(x0 + i, y0 + j)`
/// (at most 64 columns and 64 rows).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct CellRows {
    /// Column of bit 0.
    pub x0: u32,
    /// Row of `rows[0]`.
    pub y0: u32,
    /// Number of rows in use.
    pub len: usize,
    /// The rows, south to north.
    #[serde(with = "rows_serde")]
    pub rows: [u64; 64],
}

/// `[u64; 64]` as a sequence (serde derives arrays up to 32 only).
mod rows_serde {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(super) fn serialize<S: Serializer>(rows: &[u64; 64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(rows)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[u64; 64], D::Error> {
        let v = Vec::<u64>::deserialize(d)?;
        v.try_into()
            .map_err(|v: Vec<u64>| serde::de::Error::invalid_length(v.len(), &"64 rows"))
    }
}

impl CellRows {
    /// No rows.
    pub fn empty() -> Self {
        Self {
            x0: 0,
            y0: 0,
            len: 0,
            rows: [0; 64],
        }
    }

    /// Make these rows a copy of `other`, writing only the rows in use.
    pub fn assign(&mut self, other: &CellRows) {
        if self.len > other.len {
            self.rows[other.len..self.len].fill(0);
        }
        (self.x0, self.y0, self.len) = (other.x0, other.y0, other.len);
        self.rows[..other.len].copy_from_slice(&other.rows[..other.len]);
    }

    /// Row `y`'s cells with bit `i` for column `x0 + i` (none outside the rows).
    #[inline]
    pub fn row_from(&self, y: u32, x0: u32) -> u64 {
        let Some(j) = y.checked_sub(self.y0).filter(|&j| (j as usize) < self.len) else {
            return 0;
        };
        let row = self.rows[j as usize];
        // Bit `i` here is column `self.x0 + i`.
        match i64::from(self.x0) - i64::from(x0) {
            d @ 0..=63 => row << d,
            d @ -63..=-1 => row >> -d,
            _ => 0,
        }
    }
}

impl Disc {
    /// The cells of `grid` that lie wholly inside the disc and inside `clip`, as row masks,
    /// if the disc's bounds span at most 64 cells a side of the covering square (else
    /// `None`). Exactly the cells that [`Shape::classify_cells`] of the disc (clipped by
    /// `clip`) reports contained, worked out once for the whole disc: each row's run of
    /// contained cells found from the last row's by a few tests of its ends. O(rows).
    /// Checked by `view_rows_are_the_cells_wholly_inside` and
    /// `view_rows_keep_cells_whose_corner_is_on_the_rim`.
    pub fn contained_rows(&self, grid: &crate::spatial::grid::Grid, clip: &Aabb) -> Option<CellRows> {
        let mut out = CellRows::empty();
        self.contained_rows_into(grid, clip, &mut out).then_some(out)
    }

    /// [`contained_rows`](Self::contained_rows) into `out` (its rows past the new length
    /// cleared), returning `false` for a disc too wide (then `out` holds no rows). Nothing
    /// is allocated and only the rows in use are written.
    pub fn contained_rows_into(&self, grid: &crate::spatial::grid::Grid, clip: &Aabb, out: &mut CellRows) -> bool {
        let old_len = out.len;
        (out.x0, out.y0, out.len) = (0, 0, 0);
        let fits = match grid.cells_touching(&self.bounds()) {
            None => true,
            Some((lo, hi)) if hi.0 - lo.0 >= 64 || hi.1 - lo.1 >= 64 => false,
            // Column tables as wide as the disc needs, so that a narrow view does not
            // zero 64-wide ones.
            Some((lo, hi)) if hi.0 - lo.0 < 16 => {
                self.contained_rows_unclean::<16>(grid, clip, lo, hi, out);
                true
            }
            Some((lo, hi)) => {
                self.contained_rows_unclean::<64>(grid, clip, lo, hi, out);
                true
            }
        };
        if out.len < old_len {
            out.rows[out.len..old_len].fill(0);
        }
        fits
    }

    /// The rows of the cells `(x0, y0) ..= (x1, y1)` that the disc's bounds touch, at most
    /// `N` (≤ 64) columns and 64 rows.
    fn contained_rows_unclean<const N: usize>(
        &self,
        grid: &crate::spatial::grid::Grid,
        clip: &Aabb,
        (x0, y0): (u32, u32),
        (x1, y1): (u32, u32),
        out: &mut CellRows,
    ) {
        let r2 = self.radius * self.radius;
        let (width, len) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
        // Per column (and row): squared distances to the nearest point and to the farthest
        // edge, as `edge_distances` gives them for `classify_cells`, from the squared
        // distances to the grid lines, each worked out once (a column shares its lines with
        // its neighbours): the nearest point is on the line before the centre, the line
        // after it, or level with it (0); the farthest edge is the farther line.
        let (mut near_x, mut far_x) = ([0.0; N], [0.0; N]);
        // Grid lines grow with their index, so when the outer lines lie within `clip`, every
        // column and row does (the usual case, a view away from the map's edges), and the
        // per-line tests are skipped.
        let box_within = clip.contains_box(&Aabb {
            min: grid.corner(x0, y0),
            max: grid.corner(x1 + 1, y1 + 1),
        });
        let mut cols_within = if box_within { u64::MAX >> (64 - width) } else { 0 };
        let (cx, mut a) = (self.center.x, grid.corner(x0, 0).x);
        let mut da = (a - cx) * (a - cx);
        for i in 0..width {
            let b = grid.corner(x0 + i as u32 + 1, 0).x;
            let db = (b - cx) * (b - cx);
            (near_x[i], far_x[i]) = line_distances(cx, (a, da), (b, db));
            if !box_within {
                cols_within |= u64::from(clip.min.x <= a && b <= clip.max.x) << i;
            }
            (a, da) = (b, db);
        }
        // Along a row both distances fall to the column of the centre and rise after it,
        // so a row's contained cells are a run through that column, whose ends move a
        // little from row to row: a few tests per row find them, each the sums and
        // comparisons of `classify_cells`, instead of a test of every cell.
        let mid = (1..width).fold(0, |m, i| if far_x[i] < far_x[m] { i } else { m });
        let (mut lo, mut hi) = (mid, mid);
        (out.x0, out.y0, out.len) = (x0, y0, len);
        let (cy, mut a) = (self.center.y, grid.corner(0, y0).y);
        let mut da = (a - cy) * (a - cy);
        for j in 0..len {
            let b = grid.corner(0, y0 + j as u32 + 1).y;
            let db = (b - cy) * (b - cy);
            let (ny, fy) = line_distances(cy, (a, da), (b, db));
            let row_within = box_within || (clip.min.y <= a && b <= clip.max.y);
            (a, da) = (b, db);
            let inside = |i: usize| cell_within(far_x[i] + fy, near_x[i] + ny, r2);
            out.rows[j] = 0;
            if !(row_within && inside(mid)) {
                continue;
            }
            if inside(lo) {
                while lo > 0 && inside(lo - 1) {
                    lo -= 1;
                }
            } else {
                while !inside(lo) {
                    lo += 1;
                }
            }
            if inside(hi) {
                while hi + 1 < width && inside(hi + 1) {
                    hi += 1;
                }
            } else {
                while !inside(hi) {
                    hi -= 1;
                }
            }
            let run = (u64::MAX >> (63 - (hi - lo))) << lo;
            out.rows[j] = run & cols_within;
        }
    }
}

impl Shape for Disc {
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        b.distance_squared_to(self.center) < self.radius * self.radius
    }

    #[inline]
    fn classify(&self, b: &Aabb) -> Overlap {
        let r2 = self.radius * self.radius;
        if b.distance_squared_to(self.center) >= r2 {
            Overlap::Disjoint
        } else if b.farthest_corner_distance_squared(self.center) <= r2 {
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        let r = DVec2::splat(self.radius);
        Aabb {
            min: self.center - r,
            max: self.center + r,
        }
    }

    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        let r2 = self.radius * self.radius;
        let (near_x, far_x) = axis_distances(&cells.xs, self.center.x);
        let (near_y, far_y) = axis_distances(&cells.ys, self.center.y);
        // The sums are exactly those of `classify`.
        let intersects = cell_mask(&near_x, &near_y, |x, y| x + y < r2);
        let contains = cell_mask(&far_x, &far_y, |x, y| x + y <= r2) & intersects;
        Some(CellMasks { contains, intersects })
    }

    fn intersects_cells(&self, cells: &BlockCells) -> Option<u64> {
        let r2 = self.radius * self.radius;
        let (near_x, _) = axis_distances(&cells.xs, self.center.x);
        let (near_y, _) = axis_distances(&cells.ys, self.center.y);
        let hits = cell_mask(&near_x, &near_y, |x, y| x + y < r2);
        Some(hits)
    }
}

impl Shape for Aabb {
    fn classify(&self, b: &Aabb) -> Overlap {
        if !self.overlaps_open(b) {
            Overlap::Disjoint
        } else if self.contains_box(b) {
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        *self
    }

    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        // Both tests split by axis: a cell passes when its column and its row do.
        let cols_within = axis_mask(&cells.xs, |lo, hi| self.min.x <= lo && hi <= self.max.x);
        let rows_within = axis_mask(&cells.ys, |lo, hi| self.min.y <= lo && hi <= self.max.y);
        let intersects = self.overlap_cells(cells);
        Some(CellMasks {
            contains: outer_mask(cols_within, rows_within) & intersects,
            intersects,
        })
    }
}

/// The open region swept by a disc of `radius` moving from `a` to `b` (a capsule). With
/// radius 0 it is the segment itself, which overlaps a box when it passes through the box's
/// interior (grazing an edge or a corner does not count).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// Start of the axis.
    pub a: DVec2,
    /// End of the axis.
    pub b: DVec2,
    /// Radius (≥ 0).
    pub radius: f64,
}

impl Shape for Capsule {
    fn classify(&self, b: &Aabb) -> Overlap {
        if self.radius <= 0.0 {
            return if segment_enters_box_interior(self.a, self.b, b) {
                Overlap::Partial
            } else {
                Overlap::Disjoint
            };
        }
        let r2 = self.radius * self.radius;
        if segment_box_distance_squared(self.a, self.b, b) >= r2 {
            Overlap::Disjoint
        } else if b
            .corners()
            .iter()
            .all(|&c| point_segment_distance_squared(c, self.a, self.b) <= r2)
        {
            // A capsule is convex: it holds the box when it holds the corners.
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        let r = DVec2::splat(self.radius);
        Aabb {
            min: self.a.min(self.b) - r,
            max: self.a.max(self.b) + r,
        }
    }

    /// Cell by cell with [`classify`](Shape::classify), but only the cells near the
    /// capsule's bounds: a robot's move covers a few cells of a block, and each test is a
    /// segment-to-box distance. Checked by `classify_cells_agrees_with_classify_cell_by_cell`.
    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        let b = self.bounds();
        // A cell this far outside the bounds is farther than the radius from the axis
        // whatever the rounding, so `classify` would find it disjoint.
        let eps = b.rounding_margin();
        let cols = axis_mask(&cells.xs, |lo, hi| hi >= b.min.x - eps && lo <= b.max.x + eps);
        let rows = axis_mask(&cells.ys, |lo, hi| hi >= b.min.y - eps && lo <= b.max.y + eps);
        let mut masks = CellMasks {
            contains: 0,
            intersects: 0,
        };
        let mut near = outer_mask(cols, rows);
        while near != 0 {
            let k = near.trailing_zeros() as usize;
            near &= near - 1;
            let (i, j) = (k % 8, k / 8);
            let cell = Aabb {
                min: DVec2::new(cells.xs[i], cells.ys[j]),
                max: DVec2::new(cells.xs[i + 1], cells.ys[j + 1]),
            };
            match self.classify(&cell) {
                Overlap::Disjoint => {}
                Overlap::Partial => masks.intersects |= 1 << k,
                Overlap::Contains => {
                    masks.intersects |= 1 << k;
                    masks.contains |= 1 << k;
                }
            }
        }
        Some(masks)
    }

    /// [`classify_cells`](Shape::classify_cells)' `intersects` alone, from fewer tests: a
    /// row's cells are tested only between the x the axis reaches within the radius of the
    /// row (a bound with room for rounding), and only for the distance: a long slanting leg
    /// skips most of the block its bounds hold. Checked by
    /// `classify_cells_agrees_with_classify_cell_by_cell`.
    fn intersects_cells(&self, cells: &BlockCells) -> Option<u64> {
        if self.radius <= 0.0 {
            return self.classify_cells(cells).map(|m| m.intersects);
        }
        let r2 = self.radius * self.radius;
        let eps = self.bounds().rounding_margin();
        let reach = self.radius + eps;
        let d = self.b - self.a;
        let mut hits = 0;
        for j in 0..8 {
            let (ylo, yhi) = (cells.ys[j] - reach, cells.ys[j + 1] + reach);
            // The part of the axis within reach of the row, as parameters along it.
            let (t0, t1) = if d.y.abs() <= 1e-3 * d.x.abs() {
                // Nearly level: the parameters would carry the rounding of a division by
                // almost nothing; the whole axis, if it comes within reach of the row.
                if self.a.y.max(self.b.y) < ylo || self.a.y.min(self.b.y) > yhi {
                    continue;
                }
                (0.0, 1.0)
            } else {
                let (u, v) = ((ylo - self.a.y) / d.y, (yhi - self.a.y) / d.y);
                (u.min(v).max(0.0), u.max(v).min(1.0))
            };
            if t0 > t1 {
                continue;
            }
            let (x0, x1) = (self.a.x + t0 * d.x, self.a.x + t1 * d.x);
            let (xlo, xhi) = (x0.min(x1) - reach, x0.max(x1) + reach);
            for i in 0..8 {
                if cells.xs[i + 1] < xlo || cells.xs[i] > xhi {
                    continue;
                }
                let cell = Aabb {
                    min: DVec2::new(cells.xs[i], cells.ys[j]),
                    max: DVec2::new(cells.xs[i + 1], cells.ys[j + 1]),
                };
                if segment_box_distance_squared(self.a, self.b, &cell) < r2 {
                    hits |= 1 << (8 * j + i);
                }
            }
        }
        Some(hits)
    }
}

/// The part of `disc` not wholly inside `seen`, for marking a view that moved: squares
/// lying wholly inside the disc seen last time were marked then (known maps only grow), so
/// they count as disjoint and the quadtree descent skips them. Checked by
/// `moving_views_mark_exactly_what_whole_discs_mark`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscBeyond {
    /// The view now.
    pub disc: Disc,
    /// The view marked last time, if any.
    pub seen: Option<Disc>,
}

impl DiscBeyond {
    fn inside_seen(&self, b: &Aabb) -> bool {
        self.seen
            .is_some_and(|s| b.farthest_corner_distance_squared(s.center) <= s.radius * s.radius)
    }
}

impl Shape for DiscBeyond {
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        !self.inside_seen(b) && self.disc.intersects(b)
    }

    #[inline]
    fn classify(&self, b: &Aabb) -> Overlap {
        match self.disc.classify(b) {
            Overlap::Disjoint => Overlap::Disjoint,
            _ if self.inside_seen(b) => Overlap::Disjoint,
            other => other,
        }
    }

    fn bounds(&self) -> Aabb {
        self.disc.bounds()
    }

    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        let m = self.disc.classify_cells(cells)?;
        let Some(seen) = self.seen else { return Some(m) };
        // Inside the old view: farthest corner within its radius.
        let r2 = seen.radius * seen.radius;
        let (_, far_x) = axis_distances(&cells.xs, seen.center.x);
        let (_, far_y) = axis_distances(&cells.ys, seen.center.y);
        let inside = cell_mask(&far_x, &far_y, |x, y| x + y <= r2);
        Some(CellMasks {
            contains: m.contains & !inside,
            intersects: m.intersects & !inside,
        })
    }
}

/// The intersection of two shapes (used to clip a shape to the map's extent).
#[derive(Clone, Copy, Debug)]
pub struct Clipped<S> {
    /// The shape.
    pub shape: S,
    /// The clip box.
    pub clip: Aabb,
}

impl<S: Shape> Shape for Clipped<S> {
    fn classify(&self, b: &Aabb) -> Overlap {
        match (self.clip.classify(b), self.shape.classify(b)) {
            (Overlap::Disjoint, _) | (_, Overlap::Disjoint) => Overlap::Disjoint,
            (Overlap::Contains, Overlap::Contains) => Overlap::Contains,
            _ => Overlap::Partial,
        }
    }

    fn classify_cells(&self, cells: &BlockCells) -> Option<CellMasks> {
        Some(self.clip.classify_cells(cells)?.and(self.shape.classify_cells(cells)?))
    }

    fn bounds(&self) -> Aabb {
        let s = self.shape.bounds();
        Aabb {
            min: s.min.max(self.clip.min),
            max: s.max.min(self.clip.max).max(s.min.max(self.clip.min)),
        }
    }
}

/// `v.floor()` for the cell arithmetic of hot paths, without the libm call that the
/// baseline x86-64 target makes of it. Exact for |v| < 2⁶³; beyond that (and for NaN) the
/// callers' saturating casts clamp anyway.
#[inline]
pub(crate) fn floor(v: f64) -> f64 {
    let t = v as i64 as f64;
    if t > v { t - 1.0 } else { t }
}

/// Squared distance from `p` to the segment `ab`.
#[inline]
pub fn point_segment_distance_squared(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    nearest_point_on_segment(p, a, b).distance_squared(p)
}

/// The point of the segment `ab` nearest to `p` (`a` if the segment has no length).
#[inline]
pub fn nearest_point_on_segment(p: DVec2, a: DVec2, b: DVec2) -> DVec2 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + ab * t
}

/// The parameter interval `[t0, t1]` ⊆ `[0, 1]` of the segment `a + t (b - a)` inside the
/// closed box, or `None` (Liang–Barsky clipping).
pub fn clip_segment(a: DVec2, b: DVec2, bx: &Aabb) -> Option<(f64, f64)> {
    clip_line(a, b - a, 0.0, 1.0, bx)
}

/// Clip the line `origin + t * dir` for `t ∈ [t0, t1]` against a closed box.
pub fn clip_line(origin: DVec2, dir: DVec2, mut t0: f64, mut t1: f64, bx: &Aabb) -> Option<(f64, f64)> {
    for axis in 0..2 {
        let (o, d, lo, hi) = (origin[axis], dir[axis], bx.min[axis], bx.max[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
        } else {
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo - o) * inv, (hi - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((t0, t1))
}

/// Whether the segment `ab` passes through the open interior of the box.
pub fn segment_enters_box_interior(a: DVec2, b: DVec2, bx: &Aabb) -> bool {
    // The chord cut out by a convex box lies on its boundary only when it runs along an edge
    // or touches a corner; otherwise its midpoint is interior.
    clip_segment(a, b, bx).is_some_and(|(t0, t1)| bx.contains_strictly(a + (b - a) * (0.5 * (t0 + t1))))
}

/// Squared distance between the segment `ab` and the closed box (0 when they meet).
pub fn segment_box_distance_squared(a: DVec2, b: DVec2, bx: &Aabb) -> f64 {
    // A segment whose box lies off the box by more than any rounding of the clip's (a part
    // in 10⁹ of the coordinates) cannot meet it: the clip, two divisions, is skipped.
    // Checked by `segment_box_distance_skips_only_clips_that_miss`.
    let (lo, hi) = (a.min(b), a.max(b));
    let scale = lo.abs().max(hi.abs()).max(bx.min.abs()).max(bx.max.abs()).max_element();
    let margin = 1e-9 * (1.0 + scale);
    let apart =
        hi.x < bx.min.x - margin || lo.x > bx.max.x + margin || hi.y < bx.min.y - margin || lo.y > bx.max.y + margin;
    if !apart && clip_segment(a, b, bx).is_some() {
        return 0.0;
    }
    disjoint_segment_box_distance_squared(a, b, bx)
}

/// Squared distance between the segment `ab` and a closed box it does not meet.
fn disjoint_segment_box_distance_squared(a: DVec2, b: DVec2, bx: &Aabb) -> f64 {
    // Two disjoint convex sets in the plane are closest at a vertex of one of them.
    let from_ends = bx.distance_squared_to(a).min(bx.distance_squared_to(b));
    bx.corners()
        .iter()
        .map(|&c| point_segment_distance_squared(c, a, b))
        .fold(from_ends, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::from_corners(DVec2::ZERO, DVec2::ONE)
    }

    #[test]
    fn disc_classification_by_hand() {
        let d = |x, y, r| Disc {
            center: DVec2::new(x, y),
            radius: r,
        };
        // Touching the right edge from outside: open disc, no common area.
        assert_eq!(d(2.0, 0.5, 1.0).classify(&unit()), Overlap::Disjoint);
        assert_eq!(d(1.9, 0.5, 1.0).classify(&unit()), Overlap::Partial);
        // Farthest corner of the unit box from its centre is sqrt(0.5) ≈ 0.7071 away.
        assert_eq!(d(0.5, 0.5, 0.70).classify(&unit()), Overlap::Partial);
        assert_eq!(d(0.5, 0.5, 0.71).classify(&unit()), Overlap::Contains);
        // Near a corner: distance to (1,1) from (1.6,1.8) is 1.0.
        assert_eq!(d(1.6, 1.8, 1.0).classify(&unit()), Overlap::Disjoint);
        assert_eq!(d(1.6, 1.8, 1.01).classify(&unit()), Overlap::Partial);
    }

    /// The point of a segment nearest a point, by hand: beside the segment its foot, before
    /// the start the start, past the end the end; a segment of no length is its start.
    #[test]
    fn the_nearest_point_of_a_segment_is_the_foot_or_an_end() {
        let (a, b) = (DVec2::new(1.0, 1.0), DVec2::new(5.0, 1.0));
        assert_eq!(
            nearest_point_on_segment(DVec2::new(3.0, 4.0), a, b),
            DVec2::new(3.0, 1.0)
        );
        assert_eq!(nearest_point_on_segment(DVec2::new(-2.0, 0.0), a, b), a);
        assert_eq!(nearest_point_on_segment(DVec2::new(9.0, -3.0), a, b), b);
        assert_eq!(nearest_point_on_segment(DVec2::new(3.0, 4.0), a, a), a);
    }

    /// The segment-to-box distance that skips the clip for segments well off the box is the
    /// one that always clips, bit for bit: random segments and boxes, segments ending on or
    /// a few units in the last place off a box's edges, far from the origin.
    #[test]
    fn segment_box_distance_skips_only_clips_that_miss() {
        use rand::{Rng, SeedableRng};
        let always_clip = |a: DVec2, b: DVec2, bx: &Aabb| {
            if clip_segment(a, b, bx).is_some() {
                return 0.0;
            }
            disjoint_segment_box_distance_squared(a, b, bx)
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut met, mut missed) = (0, 0);
        for _ in 0..200_000 {
            let offset = [0.0, 1e3, 1e5][rng.random_range(0..3)];
            let lo = DVec2::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)).round() + offset;
            let bx = Aabb { min: lo, max: lo + 1.0 };
            let a = lo + DVec2::new(rng.random_range(-2.0..3.0), rng.random_range(-2.0..3.0));
            let mut b = a + DVec2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            if rng.random_bool(0.3) {
                // End on an edge, or a few ulps off it.
                let ulps = f64::from(rng.random_range(-4i32..=4)) * f64::EPSILON * bx.max.x.abs().max(1.0);
                b.x = bx.max.x + ulps;
            }
            let (got, want) = (segment_box_distance_squared(a, b, &bx), always_clip(a, b, &bx));
            assert_eq!(got.to_bits(), want.to_bits(), "{a} {b} {bx:?}");
            if want == 0.0 { met += 1 } else { missed += 1 }
        }
        assert!(met > 10_000 && missed > 10_000, "{met} met, {missed} missed");
    }

    #[test]
    fn segment_interior_by_hand() {
        let b = unit();
        let p = DVec2::new;
        assert!(segment_enters_box_interior(p(-1.0, 0.5), p(2.0, 0.5), &b));
        // Along the bottom edge, through a corner, ending on the boundary: no interior.
        assert!(!segment_enters_box_interior(p(-1.0, 0.0), p(2.0, 0.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 1.0), p(1.0, -1.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 2.0), p(0.0, 1.0), &b));
        // The diagonal crosses the interior.
        assert!(segment_enters_box_interior(p(-1.0, 2.0), p(1.0, 0.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 0.5), p(0.0, 0.5), &b));
        // Starting inside.
        assert!(segment_enters_box_interior(p(0.5, 0.5), p(0.5, 0.5), &b));
    }

    #[test]
    fn capsule_distance_by_hand() {
        let b = unit();
        let p = DVec2::new;
        // A horizontal segment 2 above the box: distance 1 from the top edge.
        let d2 = segment_box_distance_squared(p(-3.0, 2.0), p(3.0, 2.0), &b);
        assert!((d2 - 1.0).abs() < 1e-12);
        // A diagonal segment passing the corner (1,1) at distance sqrt(2)/2.
        let d2 = segment_box_distance_squared(p(1.0, 2.0), p(2.0, 1.0), &b);
        assert!((d2 - 0.5).abs() < 1e-12);
        let c = Capsule {
            a: p(1.0, 2.0),
            b: p(2.0, 1.0),
            radius: 0.70,
        };
        assert_eq!(c.classify(&b), Overlap::Disjoint);
        let c = Capsule { radius: 0.71, ..c };
        assert_eq!(c.classify(&b), Overlap::Partial);
        let c = Capsule {
            a: p(-5.0, 0.5),
            b: p(5.0, 0.5),
            radius: 0.8,
        };
        assert_eq!(c.classify(&b), Overlap::Contains);
    }
}
