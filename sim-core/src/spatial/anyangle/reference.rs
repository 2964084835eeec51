//! A slow, exact reference for any-angle paths between lattice points, written independently
//! of the planner so that tests (ours and users') can check paths against it: legality by
//! integer arithmetic cell by cell, and shortest lengths by Dijkstra over every lattice point.

/// Whether the cells around lattice point `(x, y)` let a path touch it (not all four
/// blocked, not a diagonal pair of blocked cells between two free ones).
fn touchable(blocked: &impl Fn(i64, i64) -> bool, x: i64, y: i64) -> bool {
    let sw = blocked(x - 1, y - 1);
    let se = blocked(x, y - 1);
    let nw = blocked(x - 1, y);
    let ne = blocked(x, y);
    let all = sw && se && nw && ne;
    let pinch = (sw && ne && !se && !nw) || (se && nw && !sw && !ne);
    !all && !pinch
}

/// `n / d` with `d > 0`.
#[derive(Clone, Copy)]
struct Frac(i128, i128);

impl Frac {
    fn new(n: i128, d: i128) -> Self {
        if d < 0 { Self(-n, -d) } else { Self(n, d) }
    }
    fn lt(self, o: Self) -> bool {
        self.0 * o.1 < o.0 * self.1
    }
}

/// Whether segment `a → b` meets the open interior of cell `(i, j)`.
fn enters_cell(a: (i64, i64), b: (i64, i64), i: i64, j: i64) -> bool {
    // The open interval of t where one coordinate is strictly inside (lo, lo + 1).
    let range = |a: i64, d: i64, lo: i64| -> Option<(Frac, Frac)> {
        if d == 0 {
            // An integer coordinate is never strictly inside a unit interval.
            return None;
        }
        let (p, q) = (
            Frac::new(i128::from(lo - a), i128::from(d)),
            Frac::new(i128::from(lo + 1 - a), i128::from(d)),
        );
        Some(if d > 0 { (p, q) } else { (q, p) })
    };
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (Some((lx, hx)), Some((ly, hy))) = (range(a.0, dx, i), range(a.1, dy, j)) else {
        return false;
    };
    let l = if lx.lt(ly) { ly } else { lx };
    let h = if hx.lt(hy) { hx } else { hy };
    l.lt(h) && l.lt(Frac(1, 1)) && Frac(0, 1).lt(h)
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 { a.abs() } else { gcd(b, a % b) }
}

/// Whether the straight segment between lattice points `a` and `b` is a legal any-angle
/// path piece on the cells `blocked` describes (which must say `true` outside the map).
pub fn segment_is_legal(blocked: &impl Fn(i64, i64) -> bool, a: (i64, i64), b: (i64, i64)) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let steps = gcd(dx, dy);
    // Every lattice point on the segment, the ends included.
    for k in 0..=steps {
        let (x, y) = if steps == 0 {
            a
        } else {
            (a.0 + dx / steps * k, a.1 + dy / steps * k)
        };
        if !touchable(blocked, x, y) {
            return false;
        }
    }
    // Along a grid line: each unit piece needs a free cell on one side.
    if dx == 0 {
        for y in a.1.min(b.1)..a.1.max(b.1) {
            if blocked(a.0 - 1, y) && blocked(a.0, y) {
                return false;
            }
        }
        return true;
    }
    if dy == 0 {
        for x in a.0.min(b.0)..a.0.max(b.0) {
            if blocked(x, a.1 - 1) && blocked(x, a.1) {
                return false;
            }
        }
        return true;
    }
    // Otherwise it may not enter a blocked cell.
    for j in a.1.min(b.1)..a.1.max(b.1) {
        for i in a.0.min(b.0)..a.0.max(b.0) {
            if blocked(i, j) && enters_cell(a, b, i, j) {
                return false;
            }
        }
    }
    true
}

/// The length of a shortest legal path between lattice points `s` and `g` on a
/// `width × height` map (Dijkstra over all its lattice points, every pair joined when their
/// segment is legal), or `None` when there is none. Cost grows with the fourth power of the
/// side: for maps of a few dozen cells.
#[allow(clippy::cast_precision_loss)] // Small lattices.
pub fn shortest_length(
    blocked: &impl Fn(i64, i64) -> bool,
    width: i64,
    height: i64,
    s: (i64, i64),
    g: (i64, i64),
) -> Option<f64> {
    let points: Vec<(i64, i64)> = (0..=height)
        .flat_map(|y| (0..=width).map(move |x| (x, y)))
        .filter(|&(x, y)| touchable(blocked, x, y))
        .collect();
    let si = points.iter().position(|&p| p == s)?;
    let gi = points.iter().position(|&p| p == g)?;
    let len = |i: usize, j: usize| {
        let (a, b) = (points[i], points[j]);
        ((a.0 - b.0) as f64).hypot((a.1 - b.1) as f64)
    };
    let mut dist = vec![f64::INFINITY; points.len()];
    let mut done = vec![false; points.len()];
    dist[si] = 0.0;
    loop {
        let u = (0..points.len())
            .filter(|&i| !done[i] && dist[i].is_finite())
            .min_by(|&i, &j| dist[i].total_cmp(&dist[j]))?;
        if u == gi {
            return Some(dist[u]);
        }
        done[u] = true;
        for v in 0..points.len() {
            if !done[v] && segment_is_legal(blocked, points[u], points[v]) {
                dist[v] = dist[v].min(dist[u] + len(u, v));
            }
        }
    }
}
