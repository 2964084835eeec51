//! How workers of one task share out a large area: each has a bearing from home, takes the
//! treasures in its sector or near it, and waits at a post on its bearing when it has none.

use std::f64::consts::PI;

use glam::DVec2;

use crate::Result;
use crate::agent::{Ctx, Params};
use crate::spatial::{KnownMap, RobotId};

/// The golden angle: robot `i`'s bearing is `i` times it, so the bearings of any run of
/// consecutive ids are spread evenly round home.
const GOLDEN_ANGLE_RAD: f64 = 2.399_963_229_728_653;

/// Steps of the walk along a worker's bearing that finds the edge of its known map.
const EDGE_STEP_M: f64 = 4.0;

/// Steps taken at most per re-estimate of the edge (it moves a few metres between them).
const EDGE_STEPS_MAX: u32 = 64;

/// Rounds between re-estimates of the edge along the bearing.
const EDGE_EVERY_ROUNDS: u64 = 10;

/// The post moves only in steps of this much, so that a waiting worker plans its route again
/// only when the post moved that far.
const POST_STEP_M: f64 = 8.0;

/// Rounds a worker explores before it searches again for a route to a post it found none to.
const ROUTE_RETRY_ROUNDS: u64 = 5;

/// Within this of its post a worker explores round it instead of walking to it.
const AT_POST_M: f64 = 4.0;

/// Bits of the sketch of team mates heard.
const SKETCH_BITS: usize = 256;

/// A worker's parameters for sharing out the area (see [`Spread`]).
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct SpreadParams {
    /// Treasures at most this far from the worker are candidates whatever their bearing.
    near_m: f64,
    /// How many sectors of the team mates heard cover each bearing from home.
    sector_overlap: f64,
    /// How far behind the edge of its known map, along its bearing, a worker with nothing to
    /// do waits.
    post_behind_m: f64,
}

impl SpreadParams {
    /// An excavator's defaults (BENCHMARKS.md, "Workers").
    pub(super) const EXCAVATOR: Self = Self {
        near_m: 40.0,
        sector_overlap: 5.0,
        post_behind_m: 0.0,
    };

    /// A transporter's defaults: a wider sector than an excavator's and a post behind the
    /// edge, as it comes for units once they are dug.
    pub(super) const TRANSPORTER: Self = Self {
        near_m: 60.0,
        sector_overlap: 12.0,
        post_behind_m: 15.0,
    };

    /// The parameters `near_m`, `sector_overlap` and `post_behind_m` of `p`, with the task's
    /// `defaults`.
    pub(super) fn from_params(p: &Params, defaults: Self) -> Result<Self> {
        Ok(Self {
            near_m: p.f64_in("near_m", defaults.near_m, 0.0..=1.0e6)?,
            sector_overlap: p.f64_in("sector_overlap", defaults.sector_overlap, 0.0..=1.0e6)?,
            post_behind_m: p.f64_in("post_behind_m", defaults.post_behind_m, 0.0..=1.0e6)?,
        })
    }
}

/// How one worker shares out the area with the team mates of its task.
///
/// Claims (see `Worker`) keep two workers within radio range off one treasure, but a
/// treasure heard of far away draws every worker that hears of it, and all but one walk for
/// nothing. So each worker has a bearing from home (its id times the golden angle) and
/// takes only treasures within [`SpreadParams::near_m`] of it or in its sector: the bearings
/// within `π × sector_overlap / (n + 1)` of its own, where `n` is the number of team mates
/// it has heard claims from (a lone worker's sector is the whole circle). With nothing to
/// take, it waits at its post: on its bearing, [`SpreadParams::post_behind_m`] behind the
/// edge of its known map, where new treasures are found. Cost: a walk of at most 64 map
/// look-ups every 10 rounds for the edge, and a 256-bit sketch of the team mates heard.
/// `workers_take_the_treasures_of_their_sector_once_they_know_their_team`
/// (tests/workers.rs) checks the choice; BENCHMARKS.md ("Workers") gives its figures.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct Spread {
    params: SpreadParams,
    /// Linear-counting sketch of the team mates heard: a bit per hash of their ids.
    mates: [u64; SKETCH_BITS / 64],
    /// How far the known map reaches along the bearing, and the round it was measured.
    edge: Option<(f64, u64)>,
    /// The last post with no known route to it, and the round that was found.
    no_route: Option<(DVec2, u64)>,
}

impl Spread {
    pub(super) fn new(params: SpreadParams) -> Self {
        Self {
            params,
            mates: [0; SKETCH_BITS / 64],
            edge: None,
            no_route: None,
        }
    }

    /// Note a team mate heard.
    pub(super) fn heard(&mut self, mate: RobotId) {
        let bit = (mix(u64::from(mate.get())) >> 56) as usize;
        self.mates[bit / 64] |= 1 << (bit % 64);
    }

    /// The number of distinct team mates heard, estimated from the sketch (linear counting:
    /// within a tenth up to 400, `the_sketch_counts_distinct_team_mates_within_a_tenth`).
    pub(super) fn mates_heard(&self) -> f64 {
        let set: u32 = self.mates.iter().map(|w| w.count_ones()).sum();
        let bits = SKETCH_BITS as f64;
        let clear = (SKETCH_BITS as u32 - set).max(1);
        -bits * (f64::from(clear) / bits).ln()
    }

    fn bearing(id: RobotId) -> DVec2 {
        DVec2::from_angle(f64::from(id.get()) * GOLDEN_ANGLE_RAD)
    }

    /// Whether this worker takes a treasure, by where it lies: near it, or in its sector.
    pub(super) fn takes(&self, ctx: &Ctx) -> impl Fn(DVec2) -> bool + use<> {
        let half_rad = PI * self.params.sector_overlap / (self.mates_heard() + 1.0);
        let (near_m, bearing) = (self.params.near_m, Self::bearing(ctx.me.id));
        let (me, home) = (ctx.position(), ctx.home().center());
        move |at| half_rad >= PI || me.distance(at) <= near_m || bearing.angle_to(at - home).abs() <= half_rad
    }

    /// Where this worker waits with nothing to do, if it knows any terrain.
    pub(super) fn post(&mut self, ctx: &Ctx) -> Option<DVec2> {
        let known = ctx.known()?;
        let home = ctx.home().center();
        let dir = Self::bearing(ctx.me.id);
        let edge_m = match self.edge {
            Some((m, at)) if ctx.round < at + EDGE_EVERY_ROUNDS => m,
            previous => {
                let m = edge_along(known, home, dir, previous.map_or(0.0, |(m, _)| m));
                self.edge = Some((m, ctx.round));
                m
            }
        };
        let from_home_m = ((edge_m - self.params.post_behind_m) / POST_STEP_M).floor().max(0.0) * POST_STEP_M;
        Some(home + dir * from_home_m)
    }

    /// Note that no known route leads to `post` this round.
    pub(super) fn no_route_to(&mut self, ctx: &Ctx, post: DVec2) {
        self.no_route = Some((post, ctx.round));
    }

    /// Whether a route to `post` is worth searching for: unless none was found to it in the
    /// last [`ROUTE_RETRY_ROUNDS`].
    pub(super) fn may_route_to(&self, ctx: &Ctx, post: DVec2) -> bool {
        self.no_route
            .is_none_or(|(p, at)| p != post || ctx.round >= at + ROUTE_RETRY_ROUNDS)
    }

    /// Whether the worker stands at its post.
    pub(super) fn at(ctx: &Ctx, post: DVec2) -> bool {
        ctx.position().distance(post) <= AT_POST_M
    }
}

/// The finaliser of `SplitMix64`: ids of a group are consecutive, and linear counting needs their
/// bits spread as if at random.
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// How far from `home` along unit `dir` the known map reaches, from last estimate `from_m`:
/// forward while known, back while not, [`EDGE_STEP_M`] at a time, at most
/// [`EDGE_STEPS_MAX`] steps.
fn edge_along(known: &KnownMap, home: DVec2, dir: DVec2, from_m: f64) -> f64 {
    let known_at = |m: f64| known.is_known(home + dir * m);
    let mut m = from_m;
    if known_at(m) {
        for _ in 0..EDGE_STEPS_MAX {
            if !known_at(m + EDGE_STEP_M) {
                break;
            }
            m += EDGE_STEP_M;
        }
    } else {
        for _ in 0..EDGE_STEPS_MAX {
            if m <= 0.0 || known_at(m) {
                break;
            }
            m = (m - EDGE_STEP_M).max(0.0);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::{Spread, SpreadParams};
    use crate::spatial::RobotId;

    /// The sketch's estimate against the exact count of distinct ids heard (each heard
    /// twice), for runs of ids as a group has and for scattered ones.
    #[test]
    fn the_sketch_counts_distinct_team_mates_within_a_tenth() {
        let params = SpreadParams {
            near_m: 0.0,
            sector_overlap: 1.0,
            post_behind_m: 0.0,
        };
        for (first, n, stride) in [(800, 10, 1), (800, 100, 1), (0, 300, 1), (17, 100, 7919), (5, 400, 13)] {
            let mut s = Spread::new(params);
            for _ in 0..2 {
                for k in 0..n {
                    s.heard(RobotId::new(first + k * stride));
                }
            }
            let estimate = s.mates_heard();
            let n = f64::from(n);
            assert!(
                (estimate - n).abs() <= 0.1 * n,
                "{n} ids heard, estimated {estimate:.1}"
            );
        }
        assert!(Spread::new(params).mates_heard().abs() < 1e-9);
    }
}
