//! Who could be in a move's way: the robots near its segment at the start of the round,
//! and the move's obstacle-free part.

use glam::DVec2;

use crate::spatial::{IndexEntry, ObstacleMap, RobotIndex, point_segment_distance_squared};

/// The robots where they stood at the start of the round (the contact-sized index), for
/// listing who could be in a move's way.
pub(super) struct Bodies<'a> {
    index: &'a RobotIndex,
    max_radius_m: f64,
    max_speed_m: f64,
}

impl<'a> Bodies<'a> {
    pub(super) fn new(index: &'a RobotIndex, max_radius_m: f64, max_speed_m: f64) -> Self {
        Self {
            index,
            max_radius_m,
            max_speed_m,
        }
    }

    /// The robots (other than `i`) that could touch a disc of `radius` ending anywhere on
    /// the move `d` from `from`, with step 3's id order: robot `i` moves after those before
    /// it and before those after it. One before it has moved at most `max_speed_m`, so one
    /// touching an end point `p` started within `radius + max_radius_m + max_speed_m` of
    /// `p`, hence within that of the move's segment; one after it still stands where it
    /// started, so within `radius + max_radius_m`.
    ///
    /// Robots that [`resolve_alone`](super::turn::resolve_alone) moved ahead of the order are
    /// no exception: one after `i` in a list could not have been alone, as `i` started
    /// within the reach of its move.
    /// `a_move_meets_robots_before_it_where_they_moved_and_after_it_where_they_stand`
    /// (tests/resolve.rs) checks both reaches.
    pub(super) fn near_move(&self, i: usize, from: DVec2, d: DVec2, radius: f64, near: &mut Vec<u32>) {
        near.clear();
        let reach = radius + self.max_radius_m + self.max_speed_m;
        // Wider by far more than any rounding: listing one robot too many changes nothing.
        let widen = |r: f64| (r * (1.0 + 1e-9)).powi(2);
        let (moved, standing) = (widen(reach), widen(radius + self.max_radius_m));
        let (to, mid) = (from + d, from + 0.5 * d);
        let r = reach + 0.5 * d.length();
        let r2 = r * r;
        let i = u32::try_from(i).expect("robot indices are u32");
        let sift = Sift {
            i,
            mid,
            r2,
            from,
            to,
            moved,
            standing,
        };
        // At most three rows when the index's cells are as wide as its queries (see
        // `rebuild_robot_indexes`); a fourth for rounding.
        let mut runs = [(0, 0); 4];
        if let Some(n) = self.index.dense_runs_near(mid, r, &mut runs) {
            let entries = self.index.entries();
            for &(a, b) in &runs[..n] {
                sift.run(&entries[a as usize..b as usize], None, near);
            }
        } else {
            self.index
                .for_each_run_near(mid, r, |_, run, cell| sift.run(run, cell, near));
        }
    }
}

/// The tests of [`Bodies::near_move`] for robot `i`'s move from `from` to `to`.
struct Sift {
    i: u32,
    /// The move's middle and the squared radius around it of the first, cheap test.
    mid: DVec2,
    r2: f64,
    from: DVec2,
    to: DVec2,
    /// Squared reach from the move of robots before `i` (which may have moved) and after it.
    moved: f64,
    standing: f64,
}

impl Sift {
    /// Append to `near` the robots of `run` (of `cell`, see
    /// [`RobotIndex::for_each_run_near`]) that could touch the move.
    ///
    /// The robots are tested without a branch per robot, as in a crowd each test goes
    /// either way. Two passes over each chunk of up to 64 robots: the cheap disc test
    /// first, into a bit per robot, then the segment test (a division) only on the robots
    /// kept, each appended and kept or not by its length.
    #[inline]
    fn run(&self, run: &[IndexEntry], cell: Option<(i32, i32)>, near: &mut Vec<u32>) {
        for chunk in run.chunks(64) {
            let mut in_disc = 0u64;
            for (k, e) in chunk.iter().enumerate() {
                // Bitwise on purpose: every test is made, none is a branch.
                #[allow(clippy::needless_bitwise_bool)]
                let keep = cell.is_none_or(|c| e.cell == c)
                    & (e.position.distance_squared(self.mid) <= self.r2)
                    & (e.id.get() != self.i);
                in_disc |= u64::from(keep) << k;
            }
            while in_disc != 0 {
                let e = &chunk[in_disc.trailing_zeros() as usize];
                in_disc &= in_disc - 1;
                let id = e.id.get();
                let within = if id < self.i { self.moved } else { self.standing };
                let touches = point_segment_distance_squared(e.position, self.from, self.to) <= within;
                near.push(id);
                near.truncate(near.len() - usize::from(!touches));
            }
        }
    }
}

/// The part of move `d` from `from` that a disc of `radius_m` sweeps free of obstacles: all
/// of it, or the largest free fraction found by bisection.
pub(super) fn trim_to_obstacles(obstacles: &ObstacleMap, from: DVec2, d: DVec2, radius_m: f64) -> DVec2 {
    if obstacles.is_swept_disc_free(from, from + d, radius_m) {
        return d;
    }
    d * obstacles.swept_disc_free_fraction(from, d, radius_m)
}
