//! Anya (Harabor, Grastien, Öz and Aksakalli, "Optimal Any-Angle Pathfinding In Practice",
//! JAIR 2016) on the cell raster: exact point-robot paths with no preprocessing, whose cost
//! follows the area a search sweeps, not the number of corners of the map.
//!
//! A search node is a *root* (the start, or a lattice corner the path bends at) and an
//! *interval* of one grid row line that the root sees: the rays from the root through the
//! interval form a cone. Expanding a node pushes the cone through the band of cells ahead to
//! the next row line, cut into one interval per run of free cells there (observable
//! successors), and bends round the corners at the cut ends, which become roots of cones into
//! the part of the band the old root does not see and of walks along the row line
//! (non-observable successors). Where nothing can happen for several bands, the cone crosses
//! them in one step: rows whose free run is the same walled run (a rectangle), or rows where
//! the cone keeps a free cell beside it on both sides (no corner at its ends, nothing cuts
//! it). Paths along a row line (Anya's flat nodes) are walked at once, bit-scan by
//! bit-scan, to the end of the free stretch, rooting cones at the convex corners on the
//! way. A* orders the nodes by the root's distance plus the shortest way from the root
//! through the interval to the goal; a corner reached again no shorter is pruned
//! (root-level pruning, as in Polyanya: a bend that only the longer way there would make is
//! on no shortest path, since the shorter way plus a straight leg beats it).
//!
//! The start and the goal may be any points where a robot may stand: a start inside a band of
//! cells sees the run of free cells around it on the band's two lines; the goal is offered to
//! a node whose cone reaches it, at the cost of the straight leg from the root, and the leg's
//! sight is tested (exactly, `sight`) only when the search takes the offer. Interval ends are
//! rationals of small integers (ratios of lattice distances), so ends within a tolerance
//! relative to the map's size (`SNAP_ULPS`) of an integer are that integer. Ends that are
//! points a path may not touch (a diagonal touch of two blocked cells) are *open*: no ray
//! through them and no bend at them.

// Exact comparisons of snapped coordinates are intended.
#![allow(clippy::float_cmp)]

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::DVec2;

use super::raster::CellRaster;
use super::sight::{corner_passable, segment_between_legal_ends_clear};

/// Interval ends within `SNAP_ULPS · (W + 1)(H + 1) · f64::EPSILON` of an integer are that
/// integer (`W × H` cells; 2e-9 on a 768² map). Relative, not absolute, so that it holds on
/// large maps: a true end `r.x + (e.x - r.x) · (y - r.y) / (e.y - r.y)` (root `r`, corner `e`)
/// that is not an integer lies at least `1 / H` from one (`1 / (2H + 1)` from a cell-centre
/// start), and the computed end carries a few roundings of a coordinate up to `W`, magnified
/// by up to `H` where a cone is carried from a line near its root to one far off; the
/// tolerance lies between the two while `(W + 1)(H + 1)² < 2^47`: every map up to 52,000
/// cells a side (every square map the raster accepts) and strips of 2^31 cells up to 65,000
/// rows high. Beyond that, or from a start just off a row line, an end may be mis-snapped by
/// about the tolerance: a leg then fails the exact sight test (the visibility graph answers)
/// or the path is that much longer than the optimum.
const SNAP_ULPS: f64 = 16.0;
/// Ways to a corner within this of each other are equally long (the later is pruned).
const TIE: f64 = 1e-9;
/// No root: the start's parent.
const NONE: u32 = u32::MAX;

/// A point paths bend at, the length of the best way to it found, and where it comes from.
struct Root {
    pos: DVec2,
    g: f64,
    prev: u32,
    /// Whether the goal has been offered from here (once is enough).
    offered: bool,
}

/// A cone: the rays from a root through `[a, b]` on row line `y`, heading up (`y` growing)
/// or down. An open end is a point no path may touch.
#[derive(Clone, Copy)]
struct Cone {
    root: u32,
    y: i64,
    a: f64,
    b: f64,
    a_open: bool,
    b_open: bool,
    up: bool,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Item {
    Cone(u32),
    /// The goal, straight from this root (its sight not yet tested).
    Goal(u32),
}

/// [`Item`] in 32 bits (the top one tells a goal offer), keeping heap entries at 16 bytes.
const GOAL_BIT: u32 = 1 << 31;

/// A heap entry: estimated length, then the order of pushing (deterministic ties). The
/// length is kept as its bits, which order non-negative floats as integers (cheaper to
/// compare than `total_cmp`).
#[derive(PartialEq, Eq, PartialOrd, Ord)]
struct Entry {
    f_bits: u64,
    seq: u32,
    item: u32,
}

impl Entry {
    fn item(&self) -> Item {
        if self.item & GOAL_BIT == 0 {
            Item::Cone(self.item)
        } else {
            Item::Goal(self.item & !GOAL_BIT)
        }
    }
}

/// The nearest integer to `x` (as a float). A cast instead of `round`, which is a library
/// call on the baseline x86-64 target.
#[inline]
fn nearest(x: f64) -> f64 {
    if x >= 0.0 {
        (x + 0.5) as i64 as f64
    } else {
        -((0.5 - x) as i64 as f64)
    }
}

/// `x` as an integer, if it is one (coordinates of the map are far below 2^31).
#[inline]
fn lattice(x: f64) -> Option<i64> {
    (x.abs() < 2_147_483_648.0 && x == nearest(x)).then_some(x as i64)
}

#[inline]
fn floor_i(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 > x { t - 1 } else { t }
}

#[inline]
fn ceil_i(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x { t + 1 } else { t }
}

#[inline]
#[allow(clippy::cast_precision_loss)] // Lattice coordinates below 2^31.
fn point(x: i64, y: i64) -> DVec2 {
    DVec2::new(x as f64, y as f64)
}

/// The shortest way from `r` to `g` through a point of `[a, b]` on row line `y` (never longer
/// than any path from `r` through that interval to `g`).
fn through(r: DVec2, y: f64, a: f64, b: f64, g: DVec2) -> f64 {
    // A goal on the root's side is mirrored to the other: the same length to any point of
    // the line, and then the straight line crosses it.
    let g2 = if (r.y - y) * (g.y - y) > 0.0 {
        DVec2::new(g.x, 2.0 * y - g.y)
    } else {
        g
    };
    let x = if g2.y == r.y {
        g2.x
    } else {
        r.x + (g2.x - r.x) * (y - r.y) / (g2.y - r.y)
    };
    let p = DVec2::new(x.clamp(a, b), y);
    r.distance(p) + p.distance(g2)
}

/// A search's buffers, kept per thread between queries so that none is allocated per
/// query. They grow with the largest search run on the thread (what it sweeps, never the
/// map's size) and are cut back to [`KEEP`] entries after a search that needed more, so a
/// thread's scratch stays bounded across any number of queries and maps. Checked by
/// `a_query_on_a_large_map_keeps_little_scratch`.
#[derive(Default)]
struct Scratch {
    roots: Vec<Root>,
    cones: Vec<Cone>,
    open: BinaryHeap<Reverse<Entry>>,
    best: Best,
}

/// Entries of each buffer a thread keeps between searches (some 20 MiB in all): ten times
/// what the longest searches on 768² mazes use.
const KEEP: usize = 1 << 18;

impl Scratch {
    fn trim(&mut self) {
        if self.roots.capacity() > KEEP {
            self.roots = Vec::new();
        }
        if self.cones.capacity() > KEEP {
            self.cones = Vec::new();
        }
        if self.open.capacity() > KEEP {
            self.open = BinaryHeap::new();
        }
        self.best.trim();
    }
}

/// The best length found to each lattice corner this query, for the corners the search has
/// rooted at (a sparse map: memory follows what the search sweeps, not the map's size; a
/// fixed hasher, and never iterated, so results are deterministic).
#[derive(Default)]
struct Best {
    g: HashMap<u64, f64, foldhash::fast::FixedState>,
}

impl Best {
    fn clear(&mut self) {
        self.g.clear();
    }

    fn trim(&mut self) {
        if self.g.capacity() > KEEP {
            self.g = HashMap::default();
        }
    }

    #[inline]
    fn get(&self, k: u64) -> Option<f64> {
        self.g.get(&k).copied()
    }

    #[inline]
    fn set(&mut self, k: u64, g: f64) {
        self.g.insert(k, g);
    }
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::default();
}

/// Heap bytes this thread's search buffers hold.
#[cfg(test)]
pub(crate) fn scratch_bytes() -> usize {
    SCRATCH.with(|s| {
        let s = s.borrow();
        s.roots.capacity() * size_of::<Root>()
            + s.cones.capacity() * size_of::<Cone>()
            + s.open.capacity() * size_of::<Reverse<Entry>>()
            + s.best.g.capacity() * (size_of::<(u64, f64)>() + 1)
    })
}

/// What a search found.
pub(crate) enum Outcome {
    /// The corners a shortest path bends at, in order.
    Found(Vec<DVec2>),
    /// The goal cannot be reached.
    Unreachable,
    /// The search gave up: more than 2^31 roots or cones (the heap's item index holds 31
    /// bits). No map the raster accepts is expected to need that many; the caller falls
    /// back.
    GaveUp,
}

/// One query's search.
struct Search<'a> {
    raster: &'a CellRaster,
    goal: DVec2,
    roots: &'a mut Vec<Root>,
    cones: &'a mut Vec<Cone>,
    open: &'a mut BinaryHeap<Reverse<Entry>>,
    best: &'a mut Best,
    /// Ends within this of an integer are that integer (see [`SNAP_ULPS`]).
    eps: f64,
    /// Set when an index would reach [`GOAL_BIT`]: the search stops and gives up.
    full: bool,
    /// An entry no greater than any in `open`, kept out of it: a cone's successor is often
    /// the next to expand, and the heap need not see it.
    slot: Option<Entry>,
    seq: u32,
}

/// A shortest legal path from `s` to `g` (cell units): the corners it bends at, or that
/// there is none, or that the search gave up. Both ends must be points a path may touch.
pub(crate) fn shortest(raster: &CellRaster, s: DVec2, g: DVec2) -> Outcome {
    SCRATCH.with(|scratch| {
        // A query on this thread is never re-entered; should it be, fresh buffers serve.
        let mut fresh = None;
        let mut borrowed = scratch.try_borrow_mut().ok();
        let scratch = match borrowed.as_deref_mut() {
            Some(s) => s,
            None => fresh.insert(Scratch::default()),
        };
        let found = search(raster, scratch, s, g);
        scratch.trim();
        found
    })
}

fn search(raster: &CellRaster, scratch: &mut Scratch, s: DVec2, g: DVec2) -> Outcome {
    scratch.roots.clear();
    scratch.cones.clear();
    scratch.open.clear();
    scratch.best.clear();
    #[allow(clippy::cast_precision_loss)] // Sides below 2^31.
    let area = (raster.width() + 1) as f64 * (raster.height() + 1) as f64;
    let mut search = Search {
        raster,
        goal: g,
        roots: &mut scratch.roots,
        cones: &mut scratch.cones,
        open: &mut scratch.open,
        best: &mut scratch.best,
        eps: SNAP_ULPS * area * f64::EPSILON,
        full: false,
        slot: None,
        seq: 0,
    };
    search.start(s);
    while let Some(e) = search.pop() {
        if search.full {
            return Outcome::GaveUp;
        }
        match e.item() {
            Item::Goal(ri) => {
                if segment_between_legal_ends_clear(raster, search.roots[ri as usize].pos, g) {
                    return Outcome::Found(search.corners(ri));
                }
            }
            Item::Cone(ci) => search.expand(ci),
        }
    }
    if search.full {
        Outcome::GaveUp
    } else {
        Outcome::Unreachable
    }
}

impl Search<'_> {
    fn push(&mut self, f: f64, item: Item) {
        // Roots and cones are kept below `GOAL_BIT` (`full`); 2^32 entries would take 64 GiB
        // of heap, and wrapping would only reorder ties.
        self.seq = self.seq.wrapping_add(1);
        let item = match item {
            Item::Cone(i) => i,
            Item::Goal(i) => i | GOAL_BIT,
        };
        // Lengths are sums of distances: never negative.
        let e = Entry {
            f_bits: f.to_bits(),
            seq: self.seq,
            item,
        };
        if self.slot.is_none() && self.open.peek().is_none_or(|Reverse(top)| e < *top) {
            self.slot = Some(e);
        } else {
            self.open.push(Reverse(e));
        }
    }

    /// The least entry of the slot and the heap.
    fn pop(&mut self) -> Option<Entry> {
        let Some(e) = self.slot.take() else {
            return self.open.pop().map(|Reverse(e)| e);
        };
        match self.open.peek_mut() {
            Some(mut top) if top.0 < e => Some(std::mem::replace(&mut top.0, e)),
            _ => Some(e),
        }
    }

    /// Key of lattice corner `(x, y)` of the map in `best`.
    #[inline]
    #[allow(clippy::cast_sign_loss)] // Corners of the map.
    fn key(&self, x: i64, y: i64) -> u64 {
        (y * (self.raster.width() + 1) + x) as u64
    }

    /// The best length found to corner `k` this query.
    #[inline]
    fn best(&self, k: u64) -> Option<f64> {
        self.best.get(k)
    }

    /// `x`, or the integer within `eps` of it.
    #[inline]
    fn snap(&self, x: f64) -> f64 {
        let n = nearest(x);
        if (x - n).abs() < self.eps { n } else { x }
    }

    /// A new index into the roots or cones, or `None` (and the search gives up) if it would
    /// collide with the heap entry's goal bit.
    fn index(&mut self, len: usize) -> Option<u32> {
        match u32::try_from(len) {
            Ok(i) if i < GOAL_BIT => Some(i),
            _ => {
                self.full = true;
                None
            }
        }
    }

    /// The corners from the start (excluded) to root `ri` (included).
    fn corners(&self, mut ri: u32) -> Vec<DVec2> {
        let mut out = Vec::new();
        while self.roots[ri as usize].prev != NONE {
            out.push(self.roots[ri as usize].pos);
            ri = self.roots[ri as usize].prev;
        }
        out.reverse();
        out
    }

    /// Offer the goal straight from root `ri`.
    fn offer(&mut self, ri: u32) {
        let root = &mut self.roots[ri as usize];
        if !root.offered {
            root.offered = true;
            let f = root.g + root.pos.distance(self.goal);
            self.push(f, Item::Goal(ri));
        }
    }

    /// A new root at corner `(x, y)` reached through root `via`, unless the corner was reached
    /// before at most as long a way.
    fn add_root(&mut self, x: i64, y: i64, via: u32) -> Option<u32> {
        let pos = point(x, y);
        let from = &self.roots[via as usize];
        let g = from.g + from.pos.distance(pos);
        let k = self.key(x, y);
        if self.best(k).is_some_and(|b| b <= g + TIE) {
            return None;
        }
        let ri = self.index(self.roots.len())?;
        self.best.set(k, g);
        self.roots.push(Root {
            pos,
            g,
            prev: via,
            offered: false,
        });
        Some(ri)
    }

    /// Whether a better way to root `ri`'s corner has been found since it was made.
    fn superseded(&self, ri: u32) -> bool {
        let root = &self.roots[ri as usize];
        match (lattice(root.pos.x), lattice(root.pos.y)) {
            (Some(x), Some(y)) => self.best(self.key(x, y)).is_some_and(|b| b + TIE < root.g),
            _ => false,
        }
    }

    fn touchable(&self, x: i64, y: i64) -> bool {
        corner_passable(self.raster.around(x, y))
    }

    /// The run `[l, h]` of free cells of row `row` whose closure holds the point at `x`.
    fn run_at(&self, row: i64, x: f64) -> Option<(i64, i64)> {
        let r = self.raster;
        let k = floor_i(x);
        let cell = if !r.blocked(k, row) {
            k
        } else if lattice(x).is_some() && !r.blocked(k - 1, row) {
            k - 1
        } else {
            return None;
        };
        Some((r.prev_blocked(row, cell) + 1, r.next_blocked(row, cell)))
    }

    /// Queue the cone from root `ri` through `[a, b]` on line `y`, unless it holds no ray.
    // A cone's fields as they are worked out (root, line, interval, whether each end is open,
    // heading): a struct built at every call site would only rename them.
    #[allow(clippy::too_many_arguments, clippy::fn_params_excessive_bools)]
    fn push_cone(&mut self, ri: u32, y: i64, a: f64, b: f64, mut a_open: bool, mut b_open: bool, up: bool) {
        let (a, b) = (self.snap(a), self.snap(b));
        if a > b {
            return;
        }
        if let Some(x) = lattice(a)
            && !self.touchable(x, y)
        {
            a_open = true;
        }
        if let Some(x) = lattice(b)
            && !self.touchable(x, y)
        {
            b_open = true;
        }
        if a == b && (a_open || b_open) {
            return;
        }
        let root = &self.roots[ri as usize];
        let f = root.g + through(root.pos, y as f64, a, b, self.goal);
        let Some(ci) = self.index(self.cones.len()) else {
            return;
        };
        self.cones.push(Cone {
            root: ri,
            y,
            a,
            b,
            a_open,
            b_open,
            up,
        });
        self.push(f, Item::Cone(ci));
    }

    /// The start's successors: walks along its row line and cones into the bands beside it.
    fn start(&mut self, s: DVec2) {
        self.roots.push(Root {
            pos: s,
            g: 0.0,
            prev: NONE,
            offered: false,
        });
        if let (Some(x), Some(y)) = (lattice(s.x), lattice(s.y)) {
            let k = self.key(x, y);
            self.best.set(k, 0.0);
        }
        if let Some(y0) = lattice(s.y) {
            self.walk(0, y0, 1, s.x);
            self.walk(0, y0, -1, s.x);
            if let Some((l, h)) = self.run_at(y0, s.x) {
                self.push_cone_ints(0, y0 + 1, l, h, true);
            }
            if let Some((l, h)) = self.run_at(y0 - 1, s.x) {
                self.push_cone_ints(0, y0 - 1, l, h, false);
            }
        } else {
            let row = floor_i(s.y);
            if let Some((l, h)) = self.run_at(row, s.x) {
                self.push_cone_ints(0, row + 1, l, h, true);
                self.push_cone_ints(0, row, l, h, false);
            }
        }
    }

    fn push_cone_ints(&mut self, ri: u32, y: i64, l: i64, h: i64, up: bool) {
        self.push_cone(ri, y, l as f64, h as f64, false, false, up);
    }

    /// Offer the goal from root `ri` if it lies beyond line `y` (heading `up` or down) and
    /// before the line `rows` further, in the run `[lo, hi]` of free cells of those rows (a
    /// rectangle a cone of the root enters), and the ray from the root to it crosses line `y`
    /// within `[a, b]`.
    // A cone's root, line and heading with the band's rows, run and interval, as the callers
    // have them.
    #[allow(clippy::too_many_arguments)]
    fn offer_in_band(&mut self, ri: u32, y: i64, up: bool, rows: i64, lo: i64, hi: i64, a: f64, b: f64) {
        let g = self.goal;
        let beyond = (g.y - y as f64) * if up { 1.0 } else { -1.0 };
        if !(beyond > 0.0 && beyond < rows as f64 && g.x >= lo as f64 && g.x <= hi as f64) {
            return;
        }
        let r = self.roots[ri as usize].pos;
        let x = if r.y == y as f64 {
            r.x
        } else {
            r.x + (g.x - r.x) * (y as f64 - r.y) / (g.y - r.y)
        };
        if x >= a - self.eps && x <= b + self.eps {
            self.offer(ri);
        }
    }

    /// Expand cone `ci`: push it through the band ahead, one run of free cells at a time.
    fn expand(&mut self, ci: u32) {
        let c = self.cones[ci as usize];
        if self.superseded(c.root) {
            return;
        }
        if self.goal.y == c.y as f64 && self.goal.x >= c.a - self.eps && self.goal.x <= c.b + self.eps {
            self.offer(c.root);
        }
        let ahead = if c.up { c.y } else { c.y - 1 };
        let mut k = self.raster.next_free(ahead, ceil_i(c.a) - 1);
        let mut first = true;
        while let Some(cell) = k {
            let lo = if first {
                self.raster.prev_blocked(ahead, cell) + 1
            } else {
                cell
            };
            first = false;
            if lo as f64 > c.b {
                break;
            }
            let hi = self.raster.next_blocked(ahead, cell);
            self.piece(&c, lo, hi);
            k = self.raster.next_free(ahead, hi);
        }
    }

    /// The part of cone `c` that enters the run `[lo, hi]` of free cells ahead.
    fn piece(&mut self, c: &Cone, lo: i64, hi: i64) {
        let (lf, hf) = (lo as f64, hi as f64);
        let (pa, pa_open) = if c.a >= lf { (c.a, c.a_open) } else { (lf, false) };
        let (pb, pb_open) = if c.b <= hf { (c.b, c.b_open) } else { (hf, false) };
        if pa > pb {
            return;
        }
        // The rows ahead whose free run is the same `[lo, hi]`, walled on both sides, form
        // a rectangle the cone crosses with no corner on the way: cross it at once.
        let dir = if c.up { 1 } else { -1 };
        let ahead = if c.up { c.y } else { c.y - 1 };
        let mut rows = 1;
        while self.same_run(ahead + dir * rows, lo, hi) {
            rows += 1;
        }
        let r = self.roots[c.root as usize].pos;
        // Rays cross the rows ahead in proportion to their height above the root.
        let t = ((c.y + dir) as f64 - r.y) / (c.y as f64 - r.y);
        if rows == 1 {
            // Rows where the cone keeps a free cell between it and every blocked one have no
            // corner at its ends and do not cut it: cross them at once too.
            let clear = self.clear_rows(c, r, pa, pb, (lo, hi));
            if clear > 1 {
                let next = c.y + dir * clear;
                let tk = (next as f64 - r.y) / (c.y as f64 - r.y);
                self.offer_in_cone(c.root, c.y, c.up, clear, pa, pb);
                let (qa, qb) = (self.snap(r.x + (pa - r.x) * tk), self.snap(r.x + (pb - r.x) * tk));
                self.push_cone(c.root, next, qa, qb, pa_open, pb_open, c.up);
                self.bend_ends(c, (pa, pa_open), (pb, pb_open), lo, hi, t);
                return;
            }
        }
        self.offer_in_band(c.root, c.y, c.up, rows, lo, hi, pa, pb);
        let next = c.y + dir * rows;
        let tk = (next as f64 - r.y) / (c.y as f64 - r.y);
        let qa = self.snap(r.x + (pa - r.x) * tk);
        let qb = self.snap(r.x + (pb - r.x) * tk);
        // A ray that leaves the run sideways hits a blocked cell: cut at the run's ends.
        let (na, na_open) = if qa < lf { (lf, false) } else { (qa, pa_open) };
        let (nb, nb_open) = if qb > hf { (hf, false) } else { (qb, pb_open) };
        if na <= nb {
            self.push_cone(c.root, next, na, nb, na_open, nb_open, c.up);
        }
        self.bend_ends(c, (pa, pa_open), (pb, pb_open), lo, hi, t);
    }

    /// Bend cone `c`'s piece `[pa, pb]` (with their open flags) round its ends where they are
    /// corners.
    fn bend_ends(
        &mut self,
        c: &Cone,
        (pa, pa_open): (f64, bool),
        (pb, pb_open): (f64, bool),
        lo: i64,
        hi: i64,
        t: f64,
    ) {
        if !pb_open && let Some(e) = lattice(pb) {
            self.bend(c, e, 1, lo, hi, t);
        }
        if !pa_open && let Some(e) = lattice(pa) {
            self.bend(c, e, -1, lo, hi, t);
        }
    }

    /// How many rows ahead of cone `c` (root at `r`), through `[pa, pb]` on its line, the
    /// cone crosses with a free cell beside it on both sides all the way (0 if not the
    /// first, whose free run is `first`).
    fn clear_rows(&self, c: &Cone, r: DVec2, pa: f64, pb: f64, first: (i64, i64)) -> i64 {
        let dir = if c.up { 1 } else { -1 };
        let ahead = if c.up { c.y } else { c.y - 1 };
        let (mut a0, mut b0) = (pa, pb);
        let mut rows = 0;
        loop {
            let line = c.y + dir * (rows + 1);
            let tk = (line as f64 - r.y) / (c.y as f64 - r.y);
            let (a1, b1) = (r.x + (pa - r.x) * tk, r.x + (pb - r.x) * tk);
            let (lo, hi) = (floor_i(a0.min(a1)) - 1, ceil_i(b0.max(b1)));
            // The first row's run is known: no scan for the common case of a cone that
            // touches a wall there.
            let blocked_within = if rows == 0 {
                lo < first.0 || hi >= first.1
            } else {
                self.raster.next_blocked(ahead + dir * rows, lo) <= hi
            };
            if blocked_within {
                return rows;
            }
            rows += 1;
            (a0, b0) = (a1, b1);
        }
    }

    /// Offer the goal from root `ri` if it lies beyond line `y` (heading `up` or down) and
    /// before the line `rows` further, and the ray from the root to it crosses line `y` within
    /// `[a, b]`: inside a cone whose rows are free.
    fn offer_in_cone(&mut self, ri: u32, y: i64, up: bool, rows: i64, a: f64, b: f64) {
        let g = self.goal;
        let beyond = (g.y - y as f64) * if up { 1.0 } else { -1.0 };
        if !(beyond > 0.0 && beyond < rows as f64) {
            return;
        }
        let r = self.roots[ri as usize].pos;
        let x = r.x + (g.x - r.x) * (y as f64 - r.y) / (g.y - r.y);
        if x >= a - self.eps && x <= b + self.eps {
            self.offer(ri);
        }
    }

    /// Bend cone `c` round corner `(e, c.y)` at its end on side `side` (1: right, the larger
    /// x; -1: left), into the region beyond its edge ray that its root does not see. `[lo, hi]`
    /// is the run of free cells ahead that the corner bounds or lies in.
    fn bend(&mut self, c: &Cone, e: i64, side: i64, lo: i64, hi: i64, t: f64) {
        let r = self.raster;
        let (behind, ahead) = if c.up { (c.y - 1, c.y) } else { (c.y, c.y - 1) };
        let (out_col, in_col) = if side > 0 { (e, e - 1) } else { (e - 1, e) };
        // A convex corner: one blocked cell, and it must lie on the side the cone cannot see.
        if r.blocked(in_col, behind) || r.blocked(in_col, ahead) {
            return;
        }
        let root = self.roots[c.root as usize].pos;
        let dx = (e as f64 - root.x) * side as f64;
        let proj = self.snap(root.x + (e as f64 - root.x) * t);
        let next = if c.up { c.y + 1 } else { c.y - 1 };
        let (lf, hf) = (lo as f64, hi as f64);
        match (r.blocked(out_col, behind), r.blocked(out_col, ahead)) {
            // Round the cell behind: along the line, and into the band ahead beyond the ray.
            (true, false) if dx >= 0.0 => {
                let Some(ri) = self.add_root(e, c.y, c.root) else {
                    return;
                };
                self.offer_in_band(ri, c.y, c.up, 1, lo, hi, lf, hf);
                self.walk(ri, c.y, side, e as f64);
                if side > 0 {
                    self.push_cone(ri, next, proj.max(lf), hf, false, false, c.up);
                } else {
                    self.push_cone(ri, next, lf, proj.min(hf), false, false, c.up);
                }
            }
            // Round the cell ahead, when the ray heads away from it: into the band ahead
            // between the ray and the cell.
            (false, true) if dx < 0.0 => {
                let Some(ri) = self.add_root(e, c.y, c.root) else {
                    return;
                };
                self.offer_in_band(ri, c.y, c.up, 1, lo, hi, lf, hf);
                if side > 0 {
                    self.push_cone(ri, next, proj.max(lf), hf, false, false, c.up);
                } else {
                    self.push_cone(ri, next, lf, proj.min(hf), false, false, c.up);
                }
            }
            _ => {}
        }
    }

    /// Whether the free cells of `row` around `lo` are exactly `lo..hi`.
    fn same_run(&self, row: i64, lo: i64, hi: i64) -> bool {
        self.raster.prev_blocked(row, lo) == lo - 1 && self.raster.next_blocked(row, lo) == hi
    }

    /// The first cell after `k` in `row` whose state differs from cell `k`'s (`i64::MAX` if
    /// none), scanning right; or the last one before it (`i64::MIN`), scanning left.
    fn change(&self, row: i64, k: i64, side: i64) -> i64 {
        let r = self.raster;
        let blocked = r.blocked(k, row);
        if side > 0 {
            if blocked {
                r.next_free(row, k + 1).unwrap_or(i64::MAX)
            } else {
                r.next_blocked(row, k + 1)
            }
        } else if blocked {
            r.prev_free(row, k - 1).unwrap_or(i64::MIN)
        } else {
            r.prev_blocked(row, k - 1)
        }
    }

    /// Walk along row line `y` from root `ri` (at `x0` on the line) towards `side`, to the end
    /// of the stretch a path may follow: offer the goal if it lies on the way, and root cones
    /// at the convex corners whose blocked cell the walk has just passed (a path along the
    /// line bends round them into the band beyond).
    fn walk(&mut self, ri: u32, y: i64, side: i64, x0: f64) {
        let r = self.raster;
        let (below, above) = (y - 1, y);
        // The cell column of the line's first unit piece.
        let mut k = if side > 0 { floor_i(x0) } else { ceil_i(x0) - 1 };
        let mut from = x0;
        let goal_here = self.goal.y == y as f64;
        loop {
            let (lb, ub) = (r.blocked(k, below), r.blocked(k, above));
            if lb && ub {
                return;
            }
            // The lattice point where either row changes next.
            let c = if side > 0 {
                self.change(below, k, 1).min(self.change(above, k, 1))
            } else {
                self.change(below, k, -1).max(self.change(above, k, -1)) + 1
            };
            let next_cell = if side > 0 { c } else { c - 1 };
            if goal_here && (self.goal.x - from) * side as f64 >= 0.0 && (c as f64 - self.goal.x) * side as f64 >= 0.0 {
                self.offer(ri);
            }
            if !self.touchable(c, y) {
                return;
            }
            let (nb, nu) = (r.blocked(next_cell, below), r.blocked(next_cell, above));
            if nb && nu {
                return;
            }
            if !nb && !nu && lb != ub {
                // A convex corner just passed: bend round it into the band beyond.
                if let Some(ti) = self.add_root(c, y, ri) {
                    let (row, line, up) = if ub {
                        (above, y + 1, true)
                    } else {
                        (below, y - 1, false)
                    };
                    let (l, h) = if side > 0 {
                        (c, r.next_blocked(row, c))
                    } else {
                        (r.prev_blocked(row, c - 1) + 1, c)
                    };
                    self.offer_in_band(ti, y, up, 1, l, h, l as f64, h as f64);
                    self.push_cone_ints(ti, line, l, h, up);
                }
            }
            k = next_cell;
            from = c as f64;
        }
    }
}
