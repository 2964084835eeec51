//! String pulling: the shortest polyline through a route's corridor of free pieces,
//! instead of one that zig-zags through the midpoints of the pieces' shared edges.
//!
//! The corridor is given as its portals, the shared edge stretches in the order the route
//! crosses them. The "simple stupid funnel" keeps the wedge of directions from the last bend
//! (the apex) that passes every portal so far; when a portal's end crosses over the wedge's
//! other side, that side's end is a bend of the shortest path and the next apex. Bends lie
//! only on portal ends, so the path stays in the corridor, which is free space.

use glam::DVec2;

/// A portal as seen walking through it: its left and right ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Portal {
    pub left: DVec2,
    pub right: DVec2,
}

impl Portal {
    /// A point portal (the start or the goal).
    fn point(p: DVec2) -> Self {
        Self { left: p, right: p }
    }
}

/// Positive when `b` lies left of the ray from `o` through `a`, negative when right.
fn side(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// The shortest polyline from `from` through every portal in order to `to`, as its bends
/// and then `to`, each with how many portals lie behind it: `k` for a bend on the `k`-th
/// portal (counting from 1), `portals.len() + 1` for `to`. `from` is not repeated. Every
/// portal must be crossable in order: consecutive portals are edges of one convex piece,
/// `from` lies in the first piece and `to` in the last.
pub(super) fn pull(from: DVec2, portals: &[Portal], to: DVec2) -> Vec<(DVec2, usize)> {
    // Portal 0 is `from`, 1..=n the corridor's, n + 1 the goal.
    let n = portals.len();
    let at = |i: usize| match i {
        0 => Portal::point(from),
        i if i <= n => portals[i - 1],
        _ => Portal::point(to),
    };
    // At most a bend a portal, and the goal.
    let mut bends: Vec<(DVec2, usize)> = Vec::with_capacity(portals.len() + 1);
    let (mut apex, mut left, mut right) = (from, from, from);
    let (mut left_i, mut right_i) = (0usize, 0usize);
    let mut i = 1;
    while i <= n + 1 {
        let p = at(i);
        // The right side narrows (or the wedge is still a point)...
        if side(apex, right, p.right) >= 0.0 {
            if apex == right || side(apex, left, p.right) < 0.0 {
                right = p.right;
                right_i = i;
            } else {
                // ...and crosses over the left side: the left end is a bend.
                apex = left;
                let apex_i = left_i;
                push(&mut bends, from, apex, apex_i);
                (left, right, right_i) = (apex, apex, apex_i);
                i = apex_i + 1;
                continue;
            }
        }
        if side(apex, left, p.left) <= 0.0 {
            if apex == left || side(apex, right, p.left) > 0.0 {
                left = p.left;
                left_i = i;
            } else {
                apex = right;
                let apex_i = right_i;
                push(&mut bends, from, apex, apex_i);
                (left, right, left_i) = (apex, apex, apex_i);
                i = apex_i + 1;
                continue;
            }
        }
        i += 1;
    }
    push(&mut bends, from, to, n + 1);
    bends
}

/// Append a bend unless it repeats the point before it.
fn push(bends: &mut Vec<(DVec2, usize)>, from: DVec2, p: DVec2, passed: usize) {
    if bends.last().map_or(from, |b| b.0) != p {
        bends.push((p, passed));
    } else if let Some(last) = bends.last_mut() {
        // The same point found again lies on a later portal too (or is the goal).
        last.1 = last.1.max(passed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn portal(left: (f64, f64), right: (f64, f64)) -> Portal {
        Portal {
            left: DVec2::new(left.0, left.1),
            right: DVec2::new(right.0, right.1),
        }
    }

    #[test]
    fn straight_through_wide_portals() {
        // Walking east through three vertical portals that all span y = 0..2.
        let ps = [
            portal((1.0, 2.0), (1.0, 0.0)),
            portal((2.0, 2.0), (2.0, 0.0)),
            portal((3.0, 2.0), (3.0, 0.0)),
        ];
        let bends = pull(DVec2::new(0.5, 1.0), &ps, DVec2::new(3.5, 1.5));
        assert_eq!(bends, [(DVec2::new(3.5, 1.5), 4)]);
    }

    #[test]
    fn bends_round_the_corner_it_must() {
        // East through x = 1 (y 0..1), then north through y = 1 (x 1..2), then west through
        // x = 1 (y 1..2): a U-turn round the corner (1, 1), where the path must bend.
        let ps = [
            portal((1.0, 1.0), (1.0, 0.0)),
            portal((1.0, 1.0), (2.0, 1.0)),
            portal((1.0, 1.0), (1.0, 2.0)),
        ];
        let bends = pull(DVec2::new(0.5, 0.5), &ps, DVec2::new(0.5, 1.5));
        assert_eq!(bends, [(DVec2::new(1.0, 1.0), 3), (DVec2::new(0.5, 1.5), 4)]);
    }

    #[test]
    fn narrow_gap_bends_at_both_ends() {
        // East through a wide portal, a one-point gap at (2, 3), then a wide portal again;
        // from low left to low right the path goes up to the gap and down again.
        let ps = [
            portal((1.0, 4.0), (1.0, 0.0)),
            portal((2.0, 3.0), (2.0, 3.0)),
            portal((3.0, 4.0), (3.0, 0.0)),
        ];
        let bends = pull(DVec2::new(0.0, 0.0), &ps, DVec2::new(4.0, 0.0));
        assert_eq!(bends, [(DVec2::new(2.0, 3.0), 2), (DVec2::new(4.0, 0.0), 4)]);
    }
}
