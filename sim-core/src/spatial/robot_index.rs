//! Robot positions in a spatial hash grid, rebuilt every round (paper §4.1 kept a map of
//! positions and scanned it; this answers "robots within r of p" in time proportional to the
//! robots nearby).
//!
//! Cells of `cell_m` metres are hashed into about two buckets per robot; a rebuild is one
//! stable counting sort (O(n), no per-round allocation once warm: each robot's cell, bucket
//! and copy to its place on all workers, the counts and places on one thread), and a query
//! looks at the buckets of the cells its disc covers. Memory is O(robots), whatever the map
//! size.
//!
//! An index made with [`RobotIndex::dense_when_compact`] lays the cells out row by row
//! instead, when the robots' cells span a rectangle of at most about sixteen cells a robot:
//! a query then reads one run of entries per row of cells (those under the disc's chord over
//! the row), without hashing. Only the order in which a query visits robots differs. In a
//! crowd (more than four robots a cell over the robots' box) such an index also halves its
//! cells, up to three times; [`RobotIndex::rows_when_compact`] keeps the cells asked, and so
//! the hashed walk's order, which budgeted delivery's picks follow. Invariant: a query
//! yields exactly the robots in its disc, in the walk's order, for either layout; checked by
//! `robot_index_matches_brute_force`, `a_robot_on_the_rim_is_found` and
//! `runs_hold_the_disc_in_the_walks_order`.

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use glam::DVec2;
use rayon::prelude::*;

use crate::spatial::geometry::floor;
use crate::spatial::ids::RobotId;

/// A robot as the index holds it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    /// Where it is.
    pub(crate) position: DVec2,
    /// Which robot.
    pub(crate) id: RobotId,
    /// Its cell.
    pub(crate) cell: (i32, i32),
}

/// How cells map to buckets.
#[derive(Clone, Copy, Debug)]
enum Layout {
    /// Hashed into `mask + 1` buckets.
    Hashed { mask: u64 },
    /// Row by row over the `width` × `height` cells from `(x0, y0)`.
    Dense { x0: i32, y0: i32, width: u32, height: u32 },
}

/// Robots by position.
#[derive(Clone, Debug)]
pub struct RobotIndex {
    cell_m: f64,
    /// `1 / cell_m`, for queries whose box is wide enough to take its rounding.
    cells_per_m: f64,
    layout: Layout,
    /// May lay cells out densely.
    dense_allowed: bool,
    /// How many times a dense layout may halve its cells in a crowd.
    most_halvings: u32,
    /// `starts[b]..starts[b + 1]` are bucket b's entries.
    starts: Vec<u32>,
    entries: Vec<Entry>,
    /// The entries' x and y, in their order: a query's distance test reads these columns,
    /// 64 robots a mask, without a branch per robot.
    xs: Vec<f64>,
    ys: Vec<f64>,
    /// The robots as given, with their cells, before they are sorted into buckets.
    scratch: Vec<Entry>,
    /// Each robot's bucket, in the order given.
    bucket_of: Vec<u32>,
    /// The robot (place in `scratch`) at each place of `entries`.
    order: Vec<u32>,
    /// How long the last rebuild's pass on one thread took.
    in_order: Duration,
}

/// The cell of `p` for cells of `cell_m` metres: where a rebuild files a robot and where a
/// query looks for it.
#[inline]
fn cell_at(p: DVec2, cell_m: f64) -> (i32, i32) {
    // `as` saturates, so far-away or non-finite positions land in edge cells, never UB.
    (floor(p.x / cell_m) as i32, floor(p.y / cell_m) as i32)
}

/// Bit k set where point k of the columns (at most 64) is within the closed disc of squared
/// radius `r2` around `p`, as `position.distance_squared(p) <= r2` decides it, bit for bit
/// (the same differences, products and sum), without a branch.
#[inline]
fn within_mask(xs: &[f64], ys: &[f64], p: DVec2, r2: f64) -> u64 {
    debug_assert!(xs.len() <= 64 && xs.len() == ys.len());
    let test = |x: f64, y: f64| {
        let (dx, dy) = (x - p.x, y - p.y);
        dx * dx + dy * dy <= r2
    };
    let mut bits = 0u64;
    let (xc, yc) = (xs.chunks_exact(8), ys.chunks_exact(8));
    let done = xs.len() - xc.remainder().len();
    for (c, (x8, y8)) in xc.zip(yc).enumerate() {
        // Eight at a time, in lanes the compiler packs into vector compares.
        let mut byte = 0u8;
        for k in 0..8 {
            byte |= u8::from(test(x8[k], y8[k])) << k;
        }
        bits |= u64::from(byte) << (8 * c);
    }
    for k in done..xs.len() {
        bits |= u64::from(test(xs[k], ys[k])) << k;
    }
    bits
}

/// Robots a task of a rebuild's parallel passes: each robot's share is a few loads and
/// stores, so a smaller task costs more to hand to another worker, and to read its writes
/// back, than it saves (the scaling report's "robot indexes" step shows it).
const ROBOTS_A_TASK: usize = 1024;

/// An entry to overwrite.
const PLACEHOLDER: Entry = Entry {
    position: DVec2::ZERO,
    id: RobotId::new(0),
    cell: (0, 0),
};

/// On all workers: file every entry in its cell of `cell_m` metres; returns the corners of
/// the rectangle of cells they span (`(MAX, MAX), (MIN, MIN)` for none).
fn file_in_cells(entries: &mut [Entry], cell_m: f64) -> ((i32, i32), (i32, i32)) {
    let none = ((i32::MAX, i32::MAX), (i32::MIN, i32::MIN));
    entries
        .par_chunks_mut(ROBOTS_A_TASK)
        .map(|chunk| {
            let (mut lo, mut hi) = none;
            for e in chunk {
                e.cell = cell_at(e.position, cell_m);
                (lo, hi) = spanning(lo, hi, e.cell);
            }
            (lo, hi)
        })
        .reduce(
            || none,
            |(lo, hi), (l, h)| (spanning(lo, hi, l).0, spanning(lo, hi, h).1),
        )
}

/// The corners `lo`, `hi` of a rectangle of cells grown to hold `cell`.
#[inline]
fn spanning(lo: (i32, i32), hi: (i32, i32), cell: (i32, i32)) -> ((i32, i32), (i32, i32)) {
    (
        (lo.0.min(cell.0), lo.1.min(cell.1)),
        (hi.0.max(cell.0), hi.1.max(cell.1)),
    )
}

impl Default for RobotIndex {
    fn default() -> Self {
        Self::new()
    }
}

impl RobotIndex {
    /// An empty index whose queries visit robots in hashed-cell order.
    pub fn new() -> Self {
        Self {
            cell_m: 1.0,
            cells_per_m: 1.0,
            layout: Layout::Hashed { mask: 0 },
            dense_allowed: false,
            most_halvings: 0,
            starts: vec![0, 0],
            entries: Vec::new(),
            xs: Vec::new(),
            ys: Vec::new(),
            scratch: Vec::new(),
            bucket_of: Vec::new(),
            order: Vec::new(),
            in_order: Duration::ZERO,
        }
    }

    /// An empty index that lays its cells out row by row when the robots are close
    /// together, with cells down to an eighth of the size asked in a crowd (see the module
    /// docs); queries visit the same robots, in another order.
    pub fn dense_when_compact() -> Self {
        Self {
            dense_allowed: true,
            most_halvings: 3,
            ..Self::new()
        }
    }

    /// An empty index that lays its cells out row by row when the robots are close
    /// together, at the cell size asked. Its queries visit the robots in [`new`](Self::new)'s
    /// order (rows of cells from the lowest, cells along a row from the lowest, each cell's
    /// robots as given) but read a row of cells as one run, without hashing or a check of
    /// each robot's cell. The orders differ only for a query whose box holds more cells than
    /// there are robots (both layouts then scan every robot in their own order): see
    /// [`box_cells_at_most`](Self::box_cells_at_most). Checked by
    /// `rows_walk_the_disc_as_hashed_cells_do`.
    pub fn rows_when_compact() -> Self {
        Self {
            dense_allowed: true,
            ..Self::new()
        }
    }

    /// The most cells the box of a query of `radius_m` can hold in cells of `cell_m`
    /// metres, wherever it is: `(⌈2 radius_m / cell_m⌉ + 2)²`, which allows for the
    /// query's slack carrying the box's edge across a cell's.
    pub fn box_cells_at_most(radius_m: f64, cell_m: f64) -> f64 {
        let side = (2.0 * radius_m / cell_m).ceil() + 2.0;
        side * side
    }

    #[inline]
    fn cell_of(&self, p: DVec2) -> (i32, i32) {
        cell_at(p, self.cell_m)
    }

    #[inline]
    fn bucket(&self, cell: (i32, i32)) -> usize {
        match self.layout {
            Layout::Hashed { mask } => {
                let h = u64::from(cell.0 as u32).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    ^ u64::from(cell.1 as u32).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
                ((h ^ (h >> 29)) & mask) as usize
            }
            Layout::Dense { x0, y0, width, .. } => {
                (cell.1.abs_diff(y0) as usize) * width as usize + cell.0.abs_diff(x0) as usize
            }
        }
    }

    /// Replace the contents with `robots`, using cells of `cell_m` metres (pick about the
    /// typical query radius). Positions must be finite.
    pub fn rebuild(&mut self, robots: impl IntoIterator<Item = (RobotId, DVec2)>, cell_m: f64) {
        self.scratch.clear();
        self.scratch.extend(robots.into_iter().map(|(id, position)| Entry {
            position,
            id,
            cell: (0, 0),
        }));
        self.sort_scratch(cell_m);
    }

    /// [`rebuild`](Self::rebuild) from robots `0..n`, `robot(i)` giving robot i's id and
    /// position, read on all workers. The same index as `rebuild` of the same sequence.
    pub fn rebuild_from(&mut self, n: usize, robot: impl Fn(usize) -> (RobotId, DVec2) + Sync, cell_m: f64) {
        self.scratch.resize(n, PLACEHOLDER);
        self.scratch
            .par_iter_mut()
            .enumerate()
            .with_min_len(ROBOTS_A_TASK)
            .for_each(|(i, e)| {
                let (id, position) = robot(i);
                *e = Entry {
                    position,
                    id,
                    cell: (0, 0),
                };
            });
        self.sort_scratch(cell_m);
    }

    /// Index the robots of `scratch` in cells of `cell_m` metres: a stable counting sort by
    /// bucket. Everything a robot's own (its cell, its bucket, copying it to its place) is
    /// done on all workers; counting the buckets and giving each robot its place, a few
    /// loads and stores a robot, in order on one thread.
    fn sort_scratch(&mut self, cell_m: f64) {
        assert!(
            cell_m.is_finite() && cell_m > 0.0,
            "robot index cell size must be positive, got {cell_m}"
        );
        self.cell_m = cell_m;
        let n = self.scratch.len();
        let (mut lo, mut hi) = file_in_cells(&mut self.scratch, cell_m);
        let area_of = |lo: (i32, i32), hi: (i32, i32)| {
            if n == 0 {
                u64::MAX
            } else {
                (u64::from(hi.0.abs_diff(lo.0)) + 1).saturating_mul(u64::from(hi.1.abs_diff(lo.1)) + 1)
            }
        };
        let mut area = area_of(lo, hi);
        // A crowd (more than four robots a cell over the robots' box) gets cells half as
        // wide, up to three times, so that a query reads fewer robots outside its disc.
        let mut halvings = 0;
        while self.dense_allowed && halvings < self.most_halvings && n as u64 > area.saturating_mul(4) {
            halvings += 1;
            self.cell_m *= 0.5;
            (lo, hi) = file_in_cells(&mut self.scratch, self.cell_m);
            area = area_of(lo, hi);
        }
        self.cells_per_m = 1.0 / self.cell_m;
        let buckets = if self.dense_allowed && area <= 16 * n as u64 + 4096 {
            self.layout = Layout::Dense {
                x0: lo.0,
                y0: lo.1,
                width: hi.0.abs_diff(lo.0) + 1,
                height: hi.1.abs_diff(lo.1) + 1,
            };
            area as usize
        } else {
            let buckets = (2 * n).next_power_of_two().max(16);
            self.layout = Layout::Hashed {
                mask: buckets as u64 - 1,
            };
            buckets
        };
        let mut bucket_of = std::mem::take(&mut self.bucket_of);
        let this = &*self;
        bucket_of.resize(n, 0);
        bucket_of
            .par_iter_mut()
            .zip(&self.scratch)
            .with_min_len(ROBOTS_A_TASK)
            .for_each(|(b, e)| *b = this.bucket(e.cell) as u32);
        let t = Instant::now();
        self.place_in_buckets(&bucket_of, buckets);
        self.in_order = t.elapsed();
        self.bucket_of = bucket_of;
        self.copy_to_places();
    }

    /// In order, on one thread: count each bucket's robots and give every robot its place,
    /// so that `starts[b]..starts[b + 1]` is bucket b's run, each run in input order (stable,
    /// so query order is deterministic). `order[k]` is the robot at place k.
    fn place_in_buckets(&mut self, bucket_of: &[u32], buckets: usize) {
        self.starts.clear();
        self.starts.resize(buckets + 1, 0);
        for &b in bucket_of {
            self.starts[b as usize] += 1;
        }
        // Running sums, so that `starts[b]` is where bucket `b` ends; placing the robots
        // from the last one back then leaves it where `b` starts. The sum is kept in a local
        // and no copy of the starts is made.
        let mut end = 0;
        for start in &mut self.starts {
            end += *start;
            *start = end;
        }
        self.order.resize(bucket_of.len(), 0);
        for (i, &b) in bucket_of.iter().enumerate().rev() {
            let at = &mut self.starts[b as usize];
            *at -= 1;
            self.order[*at as usize] = i as u32;
        }
    }

    /// On all workers: the entries and their x and y columns in `order`.
    fn copy_to_places(&mut self) {
        let n = self.order.len();
        self.entries.resize(n, PLACEHOLDER);
        self.xs.resize(n, 0.0);
        self.ys.resize(n, 0.0);
        let scratch = &self.scratch;
        self.entries
            .par_iter_mut()
            .zip(&mut self.xs)
            .zip(&mut self.ys)
            .zip(&self.order)
            .with_min_len(ROBOTS_A_TASK)
            .for_each(|(((entry, x), y), &i)| {
                let e = scratch[i as usize];
                (*entry, *x, *y) = (e, e.position.x, e.position.y);
            });
    }

    /// How long the last rebuild spent on one thread (counting the buckets and placing the
    /// robots); the rest of it runs on all workers.
    pub fn in_order_time(&self) -> Duration {
        self.in_order
    }

    /// Number of robots indexed.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no robot is indexed.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Visit every robot within `radius_m` of `p` (closed disc), with its position.
    pub fn for_each_within(&self, p: DVec2, radius_m: f64, mut visit: impl FnMut(RobotId, DVec2)) {
        let _ = self.try_for_each_within(p, radius_m, |id, q| {
            visit(id, q);
            ControlFlow::Continue(())
        });
    }

    /// [`for_each_within`](Self::for_each_within) that the visitor may stop early; the
    /// order is fixed by the index's contents (cell by cell), the same on every run.
    pub fn try_for_each_within(
        &self,
        p: DVec2,
        radius_m: f64,
        mut visit: impl FnMut(RobotId, DVec2) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        self.try_for_each_entry_within(p, radius_m, |i| {
            let e = &self.entries[i];
            visit(e.id, e.position)
        })
    }

    /// [`try_for_each_within`](Self::try_for_each_within) that gives each robot's place in
    /// [`entries`](Self::entries), for callers that keep data of their own beside the
    /// entries. Cost: a mask of 64 distance tests at a time over the cells the disc
    /// touches, then a visit per robot in the disc. The same robots in the same order as
    /// a test per entry: `runs_hold_the_disc_in_the_walks_order`.
    pub(crate) fn try_for_each_entry_within(
        &self,
        p: DVec2,
        radius_m: f64,
        mut visit: impl FnMut(usize) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let r2 = radius_m * radius_m;
        self.try_for_each_run_near(p, radius_m, |start, run, cell| {
            let end = start + run.len();
            let mut a = start;
            while a < end {
                let b = end.min(a + 64);
                let mut bits = within_mask(&self.xs[a..b], &self.ys[a..b], p, r2);
                while bits != 0 {
                    let i = a + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    // Other cells may share a hashed bucket; each robot belongs to its own
                    // cell's run.
                    if cell.is_none_or(|c| self.entries[i].cell == c) {
                        visit(i)?;
                    }
                }
                a = b;
            }
            ControlFlow::Continue(())
        })
    }

    /// The robots in the cells that a disc of `radius_m` around `p` touches (a superset of
    /// those within it), run of entries by run, in the order
    /// [`try_for_each_within`](Self::try_for_each_within) visits them, each with where it
    /// starts in [`entries`](Self::entries). A run given with a cell holds other cells'
    /// robots too (a hashed bucket): only those whose [`Entry::cell`] is that cell belong
    /// to it. For callers that test robots by tests of their own, without a branch per
    /// robot, or that keep data of their own beside the entries.
    pub(crate) fn for_each_run_near(
        &self,
        p: DVec2,
        radius_m: f64,
        mut visit: impl FnMut(usize, &[Entry], Option<(i32, i32)>),
    ) {
        let _ = self.try_for_each_run_near(p, radius_m, |start, run, cell| {
            visit(start, run, cell);
            ControlFlow::Continue(())
        });
    }

    /// [`for_each_run_near`](Self::for_each_run_near) that the visitor may stop early.
    pub(crate) fn try_for_each_run_near(
        &self,
        p: DVec2,
        radius_m: f64,
        mut visit: impl FnMut(usize, &[Entry], Option<(i32, i32)>) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let reach = radius_m + self.query_slack(p, radius_m);
        let (x0, y0) = self.cell_of(p - DVec2::splat(reach));
        let (x1, y1) = self.cell_of(p + DVec2::splat(reach));
        // Saturating: a radius far beyond the map (1e12 m) spans more cells than an i64 counts.
        let cells = (i64::from(x1) - i64::from(x0) + 1).saturating_mul(i64::from(y1) - i64::from(y0) + 1);
        if cells > self.entries.len() as i64 {
            // A disc wider than the swarm's spread: a scan is cheaper than the cells.
            return visit(0, &self.entries, None);
        }
        if let Some(((x0, x1), (y0, y1))) = self.dense_span((x0, y0), (x1, y1)) {
            // The rows of cells the disc covers, each one run of entries.
            if x0 > x1 {
                return ControlFlow::Continue(());
            }
            for cy in y0..=y1 {
                let Some((x0, x1)) = self.chord_cells(p, reach, cy, (x0, x1), |x| self.cell_of(DVec2::new(x, 0.0)).0)
                else {
                    continue;
                };
                let (a, b) = self.row_run(cy, x0, x1);
                let (a, b) = (a as usize, b as usize);
                visit(a, &self.entries[a..b], None)?;
            }
            return ControlFlow::Continue(());
        }
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let b = self.bucket((cx, cy));
                let (a, b) = (self.starts[b] as usize, self.starts[b + 1] as usize);
                visit(a, &self.entries[a..b], Some((cx, cy)))?;
            }
        }
        ControlFlow::Continue(())
    }

    /// The rows of cells of the disc's box, each narrowed to the cells under the disc's chord
    /// over it, as ranges of [`entries`](Self::entries), in index
    /// order, when the cells are laid out densely and the box spans at most `N` rows of
    /// them: how many ranges were written to `out` (the first ones), or `None` otherwise.
    /// They hold the robots in the disc that [`for_each_run_near`](Self::for_each_run_near)
    /// gives, in its order (it may scan every robot instead, where the box holds more cells
    /// than there are robots). Each range holds only robots of its row's cells. For a query
    /// in a loop of its own, without a call per run. Checked by
    /// `runs_hold_the_disc_in_the_walks_order`.
    #[inline]
    pub(crate) fn dense_runs_near<const N: usize>(
        &self,
        p: DVec2,
        radius_m: f64,
        out: &mut [(u32, u32); N],
    ) -> Option<usize> {
        // The box of `try_for_each_run_near`, with the same slack. It dwarfs the rounding of
        // a product by `1 / cell_m` (a few units in the last place), so the box still holds
        // every cell a robot in the disc is filed in, without two divisions to wait for.
        let reach = radius_m + self.query_slack(p, radius_m);
        let cell = |q: DVec2| {
            let c = q * self.cells_per_m;
            (floor(c.x) as i32, floor(c.y) as i32)
        };
        let ((x0, x1), (y0, y1)) = self.dense_span(cell(p - DVec2::splat(reach)), cell(p + DVec2::splat(reach)))?;
        if x0 > x1 || y0 > y1 {
            return Some(0);
        }
        let rows = y0.abs_diff(y1) as usize + 1;
        if rows > N {
            return None;
        }
        // Row by row, each narrowed to the cells under the disc's chord.
        let column = |x: f64| floor(x * self.cells_per_m) as i32;
        for (cy, run) in (y0..=y1).zip(out.iter_mut()) {
            *run = match self.chord_cells(p, reach, cy, (x0, x1), column) {
                Some((x0, x1)) => self.row_run(cy, x0, x1),
                None => (0, 0),
            };
        }
        Some(rows)
    }

    /// The cells of row `cy`, within `span`, that the disc of `reach` around `p` can meet:
    /// those under its chord over the row's band (`None` for none). The chord is taken from
    /// the band's edge brought nearer `p` by the slack that `reach` holds beyond the radius,
    /// which dwarfs the rounding of a robot's filing; so every robot in the disc lies in the
    /// cells given, and skipping a row's end cells keeps the walk's order. `column` is the
    /// caller's column of an x (each query path files as it computes its box).
    #[inline]
    fn chord_cells(
        &self,
        p: DVec2,
        reach: f64,
        cy: i32,
        span: (i32, i32),
        column: impl Fn(f64) -> i32,
    ) -> Option<(i32, i32)> {
        let (low, high) = (f64::from(cy) * self.cell_m, f64::from(cy + 1) * self.cell_m);
        let dy = ((low - p.y).max(p.y - high) - self.query_slack(p, reach)).max(0.0);
        if dy > reach {
            return None;
        }
        let half = (reach * reach - dy * dy).sqrt();
        let (x0, x1) = (column(p.x - half).max(span.0), column(p.x + half).min(span.1));
        (x0 <= x1).then_some((x0, x1))
    }

    /// How much wider than its radius a query's box is taken: a robot on the rim passes a
    /// distance test by rounding, yet may lie an ulp beyond `p + r` as computed.
    #[inline]
    fn query_slack(&self, p: DVec2, radius_m: f64) -> f64 {
        1e-9 * (p.abs().max_element() + radius_m + self.cell_m)
    }

    /// The cells `lo ..= hi` clipped to a dense layout's, as column and row ranges (empty
    /// where they miss it), or `None` for a hashed layout.
    #[inline]
    fn dense_span(&self, lo: (i32, i32), hi: (i32, i32)) -> Option<((i32, i32), (i32, i32))> {
        let Layout::Dense { x0, y0, width, height } = self.layout else {
            return None;
        };
        Some((
            (lo.0.max(x0), hi.0.min(x0 + (width - 1) as i32)),
            (lo.1.max(y0), hi.1.min(y0 + (height - 1) as i32)),
        ))
    }

    /// Where in [`entries`](Self::entries) the robots of cells `x0 ..= x1` of row `cy` (of a
    /// dense layout, all inside it) start and end: one run.
    #[inline]
    fn row_run(&self, cy: i32, x0: i32, x1: i32) -> (u32, u32) {
        (
            self.starts[self.bucket((x0, cy))],
            self.starts[self.bucket((x1, cy)) + 1],
        )
    }

    /// The robots in the order the index keeps them (see
    /// [`for_each_run_near`](Self::for_each_run_near)).
    pub(crate) fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.starts.capacity() * 4
            + self.entries.capacity() * std::mem::size_of::<Entry>()
            + (self.xs.capacity() + self.ys.capacity()) * 8
            + self.scratch.capacity() * std::mem::size_of::<Entry>()
            + (self.bucket_of.capacity() + self.order.capacity()) * 4
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec2;
    use proptest::prelude::*;

    use super::RobotIndex;
    use crate::spatial::RobotId;

    /// Robots at `points`, then `crowd` more on a lattice of `row` a row, `spacing_m` apart,
    /// from the origin; ids in that order.
    fn with_crowd(points: &[(f64, f64)], crowd: usize, row: usize, spacing_m: f64) -> Vec<(RobotId, DVec2)> {
        points
            .iter()
            .map(|&(x, y)| DVec2::new(x, y))
            .chain((0..crowd).map(|k| DVec2::new(spacing_m * (k % row) as f64, spacing_m * (k / row) as f64)))
            .enumerate()
            .map(|(k, p)| (RobotId::new(k as u32), p))
            .collect()
    }

    /// The robots within `r` of `p` by a test of each, sorted by id.
    fn in_disc(robots: &[(RobotId, DVec2)], p: DVec2, r: f64) -> Vec<RobotId> {
        let mut ids: Vec<RobotId> = robots
            .iter()
            .filter(|(_, q)| q.distance_squared(p) <= r * r)
            .map(|(id, _)| *id)
            .collect();
        ids.sort();
        ids
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(11), ..ProptestConfig::default() })]

        /// A rebuild is a stable sort by bucket, whether the robots come as a sequence or
        /// from a function read on all workers (3 threads, tasks of 1,024 robots): every robot
        /// once, the buckets' runs where `starts` says, each run in the order given, the x
        /// and y columns beside; checked against a stable sort of the input by bucket.
        #[test]
        fn rebuilds_sort_the_robots_stably_by_bucket(
            points in proptest::collection::vec((-40.0f64..40.0, -40.0f64..40.0), 0..3000),
            crowd in 0usize..1000,
            dense in any::<bool>(),
            cell_m in 0.5f64..6.0,
        ) {
            // A crowd packed into 1.5 m × 1.7 m as well, so that dense indexes halve their cells.
            let robots = with_crowd(&points, crowd, 30, 0.05);
            let fresh = || if dense { RobotIndex::dense_when_compact() } else { RobotIndex::new() };
            let (mut by_sequence, mut by_function) = (fresh(), fresh());
            by_sequence.rebuild(robots.iter().copied(), cell_m);
            let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
            pool.install(|| by_function.rebuild_from(robots.len(), |i| robots[i], cell_m));
            for index in [&by_sequence, &by_function] {
                let bucket_of = |p: DVec2| index.bucket(super::cell_at(p, index.cell_m));
                let mut want: Vec<usize> = (0..robots.len()).collect();
                want.sort_by_key(|&i| bucket_of(robots[i].1));
                let got: Vec<usize> = index.entries().iter().map(|e| e.id.get() as usize).collect();
                prop_assert_eq!(&got, &want);
                for (k, e) in index.entries().iter().enumerate() {
                    let b = bucket_of(e.position);
                    prop_assert!(index.starts[b] as usize <= k && k < index.starts[b + 1] as usize);
                    prop_assert_eq!((index.xs[k], index.ys[k]), (e.position.x, e.position.y));
                    prop_assert_eq!(e.cell, super::cell_at(e.position, index.cell_m));
                }
            }
        }

        /// The runs of entries a query reads are the index's own entries where they say they
        /// start, and, with each run's cell test, hold every robot in the disc once, in
        /// `for_each_within`'s order (contact lists and budgeted delivery read runs and rely
        /// on both), for either layout and a crowd that halves the cells; and so do a dense
        /// layout's runs as ranges. `for_each_within` is the walk by places in the entries
        /// (64 distance tests a mask), so this holds it to a test per entry.
        #[test]
        fn runs_hold_the_disc_in_the_walks_order(
            points in proptest::collection::vec((-20.0f64..20.0, -20.0f64..20.0), 0..300),
            crowd in 0usize..400,
            dense in any::<bool>(),
            cell_m in 0.5f64..6.0,
            queries in proptest::collection::vec((-25.0f64..25.0, -25.0f64..25.0, 0.0f64..15.0), 1..10),
        ) {
            // A crowd packed into 2 m × 2 m as well, so that dense indexes halve their cells.
            let robots = with_crowd(&points, crowd, 20, 0.1);
            let mut index = if dense { RobotIndex::dense_when_compact() } else { RobotIndex::new() };
            index.rebuild(robots.iter().copied(), cell_m);
            for (x, y, r) in queries {
                let p = DVec2::new(x, y);
                let mut walk = Vec::new();
                index.for_each_within(p, r, |id, _| walk.push(id));
                let mut from_runs = Vec::new();
                index.for_each_run_near(p, r, |start, run, cell| {
                    assert_eq!(run.as_ptr(), index.entries()[start..].as_ptr());
                    for e in run {
                        if cell.is_none_or(|c| e.cell == c) && e.position.distance_squared(p) <= r * r {
                            from_runs.push(e.id);
                        }
                    }
                });
                prop_assert_eq!(&from_runs, &walk);
                // The dense layout's runs as ranges: the same robots in the same order, when
                // given (dense layouts of at most four rows).
                let mut ranges = [(0, 0); 4];
                if let Some(n) = index.dense_runs_near(p, r, &mut ranges) {
                    let from_ranges: Vec<RobotId> = ranges[..n]
                        .iter()
                        .flat_map(|&(a, b)| &index.entries()[a as usize..b as usize])
                        .filter(|e| e.position.distance_squared(p) <= r * r)
                        .map(|e| e.id)
                        .collect();
                    prop_assert_eq!(&from_ranges, &walk);
                }
                let mut got = from_runs.clone();
                got.sort();
                prop_assert_eq!(got, in_disc(&robots, p, r));
            }
        }

        /// An index of rows of cells walks a disc in exactly the order of a hashed one of the
        /// same cells (budgeted delivery picks senders in that order and may use either),
        /// whenever there are at least as many robots as the query's box can hold cells;
        /// the same robots otherwise. Both are checked against brute force as sets.
        #[test]
        fn rows_walk_the_disc_as_hashed_cells_do(
            points in proptest::collection::vec((-20.0f64..20.0, -20.0f64..20.0), 0..300),
            crowd in 0usize..400,
            cell_m in 0.5f64..6.0,
            queries in proptest::collection::vec((-25.0f64..25.0, -25.0f64..25.0, 0.0f64..15.0), 1..10),
        ) {
            let robots = with_crowd(&points, crowd, 20, 0.1);
            let (mut hashed, mut rows) = (RobotIndex::new(), RobotIndex::rows_when_compact());
            hashed.rebuild(robots.iter().copied(), cell_m);
            rows.rebuild(robots.iter().copied(), cell_m);
            prop_assert!(rows.cell_m.to_bits() == cell_m.to_bits(), "rows keep the cells asked");
            for (x, y, r) in queries {
                let p = DVec2::new(x, y);
                let walk = |index: &RobotIndex| {
                    let mut walk = Vec::new();
                    index.for_each_within(p, r, |id, _| walk.push(id));
                    walk
                };
                let (mut by_hash, mut by_rows) = (walk(&hashed), walk(&rows));
                if robots.len() as f64 >= RobotIndex::box_cells_at_most(r, cell_m) {
                    prop_assert_eq!(&by_rows, &by_hash);
                }
                let want = in_disc(&robots, p, r);
                by_hash.sort();
                by_rows.sort();
                prop_assert_eq!(&by_hash, &want);
                prop_assert_eq!(&by_rows, &want);
            }
        }
    }

    /// A disc far wider than the map (a radio range of 1e12 m) spans more cells than an
    /// i64 counts; its runs are every robot, in both layouts.
    #[test]
    fn a_disc_wider_than_any_cell_count_holds_every_robot() {
        let robots = with_crowd(&[(-3.0, 7.0), (12.0, -40.0)], 50, 10, 0.5);
        for mut index in [RobotIndex::new(), RobotIndex::dense_when_compact()] {
            index.rebuild(robots.iter().copied(), 0.5);
            for r in [1e12, 1e300] {
                let mut seen = Vec::new();
                index.for_each_run_near(DVec2::new(1.0, 2.0), r, |_, run, _| {
                    seen.extend(run.iter().map(|e| e.id));
                });
                seen.sort();
                let all: Vec<RobotId> = robots.iter().map(|(id, _)| *id).collect();
                assert_eq!(seen, all);
            }
        }
    }
}
