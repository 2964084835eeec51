//! How a large team shares out the area: each robot has a bearing from home. Workers take
//! the treasures in their sector or near them and wait at a post on their bearing when they
//! have none; scouts walk out along theirs.

use std::f64::consts::PI;

use glam::DVec2;

use crate::Result;
use crate::agent::{Ctx, Navigator, Params};
use crate::spatial::{KnownMap, RobotId};
use crate::world::Action;

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
    mates: MatesSketch,
    /// How far the known map reaches along the bearing, and the round it was measured.
    edge: Option<(f64, u64)>,
    /// The last post with no known route to it, and the round that was found.
    no_route: Option<(DVec2, u64)>,
}

impl Spread {
    pub(super) fn new(params: SpreadParams) -> Self {
        Self {
            params,
            mates: MatesSketch::default(),
            edge: None,
            no_route: None,
        }
    }

    /// Note a team mate heard.
    pub(super) fn heard(&mut self, mate: RobotId) {
        self.mates.heard(mate);
    }

    fn bearing(id: RobotId) -> DVec2 {
        DVec2::from_angle(f64::from(id.get()) * GOLDEN_ANGLE_RAD)
    }

    /// Whether this worker takes a treasure, by where it lies: near it, or in its sector.
    pub(super) fn takes(&self, ctx: &Ctx) -> impl Fn(DVec2) -> bool + use<> {
        let half_rad = PI * self.params.sector_overlap / (self.mates.count() + 1.0);
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

/// How far beyond the edge of its known map a scout's spoke target lies.
const SPOKE_AHEAD_M: f64 = 2.0;

/// A spoke target moves in steps of this much, so that a detour is planned at most once
/// per step.
const SPOKE_STEP_M: f64 = 4.0;

/// Nodes a search for a detour to the spoke target may settle: a short search, as most
/// that fail would otherwise settle the robot's whole known map.
const SPOKE_SEARCH_NODES: usize = 50;

/// Rounds a scout explores frontiers after its spoke was blocked.
const SPOKE_PAUSE_ROUNDS: u64 = 40;

/// How a scout of a large team walks out from home: along its bearing (its id times the
/// golden angle), to just beyond the edge of its known map, so that a crowd leaving home
/// fans out instead of jamming, and each scout pushes its own part of the explored front.
///
/// The target lies [`SPOKE_AHEAD_M`] beyond the edge, in steps of [`SPOKE_STEP_M`]. The
/// scout walks straight to it when no cell it knows to be blocked lies near the way, or
/// else along a detour through known terrain (a search of at most [`SPOKE_SEARCH_NODES`]
/// nodes). When a step is blocked, no detour is found, or the bearing leaves the map, the
/// strategy explores frontiers instead, for [`SPOKE_PAUSE_ROUNDS`]. A scout that has heard
/// fewer than `from_mates` team mates (`cooperative`'s `spoke_mates`) explores frontiers
/// only. Cost: a few map look-ups a round for the edge, a
/// straight-leg test a step, and the short searches; and as scouts reach new terrain sooner,
/// their maps grow and merge sooner.
/// `scouts_of_a_large_team_walk_out_along_their_bearings` (tests/workers.rs) checks the
/// walk; BENCHMARKS.md ("Workers") gives its figures.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct Spoke {
    /// Team mates heard from which the scout walks its spoke.
    from_mates: f64,
    /// How far the known map reaches along the bearing, as last measured.
    edge_m: f64,
    /// The target being walked to, and whether straight (or along the navigator's route).
    heading_to: Option<(DVec2, bool)>,
    /// Frontiers are explored until this round.
    paused_until: u64,
}

impl Spoke {
    /// A scout that walks its spoke once it has heard `from_mates` team mates.
    pub(super) fn from_mates(from_mates: f64) -> Self {
        Self {
            from_mates,
            edge_m: 0.0,
            heading_to: None,
            paused_until: 0,
        }
    }

    /// Forget the target (another tactic moved the robot).
    pub(super) fn interrupt(&mut self) {
        self.heading_to = None;
    }

    /// This round's step along the spoke, with `nav` following detours, for a scout that
    /// has heard `mates_heard` team mates; `None`: explore frontiers.
    pub(super) fn step(&mut self, ctx: &mut Ctx, nav: &mut Navigator, mates_heard: f64) -> Option<Action> {
        if ctx.round < self.paused_until || mates_heard < self.from_mates {
            return None;
        }
        let Some(to) = self.target(ctx) else {
            return self.pause(ctx);
        };
        let straight = match self.heading_to {
            Some((t, straight)) if t == to && (straight || !nav.is_idle()) => straight,
            _ => match Self::set_out(ctx, nav, to) {
                Some(straight) => {
                    self.heading_to = Some((to, straight));
                    straight
                }
                None => return self.pause(ctx),
            },
        };
        ctx.set_goal(Some(to));
        if !straight {
            return nav.step(ctx);
        }
        let p = ctx.position();
        let step = p + (to - p).clamp_length_max(ctx.kind.speed_m_per_round);
        if ctx.can_move(p, step) == Some(false) {
            return self.pause(ctx);
        }
        Some(Action::MoveTo { to: step })
    }

    /// Set out for a new target `to`: whether straight (`Some(true)`), along a detour `nav`
    /// now follows (`Some(false)`), or not at all (`None`: no detour found).
    fn set_out(ctx: &Ctx, nav: &mut Navigator, to: DVec2) -> Option<bool> {
        nav.clear();
        let p = ctx.position();
        if ctx.terrain().is_some_and(|t| t.hopeful(p, to)) {
            return Some(true);
        }
        let route = ctx.timed_planning(|| {
            ctx.terrain()
                .and_then(|t| ctx.nav().route_optimistic(t, p, to, SPOKE_SEARCH_NODES))
        })?;
        nav.follow(route);
        Some(false)
    }

    fn pause(&mut self, ctx: &Ctx) -> Option<Action> {
        self.heading_to = None;
        self.paused_until = ctx.round + SPOKE_PAUSE_ROUNDS;
        None
    }

    /// The spoke target: [`SPOKE_AHEAD_M`] beyond the edge of the known map along the
    /// bearing (measured every round, from the last measure), in steps of
    /// [`SPOKE_STEP_M`]; `None` off the map.
    fn target(&mut self, ctx: &Ctx) -> Option<DVec2> {
        let known = ctx.known()?;
        let home = ctx.home().center();
        let dir = Spread::bearing(ctx.me.id);
        self.edge_m = edge_along(known, home, dir, self.edge_m);
        let to = home + dir * (((self.edge_m + SPOKE_AHEAD_M) / SPOKE_STEP_M).ceil() * SPOKE_STEP_M);
        known.grid().extent().contains_strictly(to).then_some(to)
    }
}

/// A linear-counting sketch of the team mates heard: a bit per hash of their ids. 32 bytes
/// whatever the team's size.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub(super) struct MatesSketch([u64; SKETCH_BITS / 64]);

impl MatesSketch {
    /// Note a team mate heard.
    pub(super) fn heard(&mut self, mate: RobotId) {
        let bit = (mix(u64::from(mate.get())) >> 56) as usize;
        self.0[bit / 64] |= 1 << (bit % 64);
    }

    /// The number of distinct team mates heard (within a tenth up to 400,
    /// `the_sketch_counts_distinct_team_mates_within_a_tenth`).
    pub(super) fn count(&self) -> f64 {
        let set: u32 = self.0.iter().map(|w| w.count_ones()).sum();
        let bits = SKETCH_BITS as f64;
        let clear = (SKETCH_BITS as u32 - set).max(1);
        -bits * (f64::from(clear) / bits).ln()
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
    use super::MatesSketch;
    use crate::spatial::RobotId;

    /// The sketch's estimate against the exact count of distinct ids heard (each heard
    /// twice), for runs of ids as a group has and for scattered ones.
    #[test]
    fn the_sketch_counts_distinct_team_mates_within_a_tenth() {
        for (first, n, stride) in [(800, 10, 1), (800, 100, 1), (0, 300, 1), (17, 100, 7919), (5, 400, 13)] {
            let mut s = MatesSketch::default();
            for _ in 0..2 {
                for k in 0..n {
                    s.heard(RobotId::new(first + k * stride));
                }
            }
            let estimate = s.count();
            let n = f64::from(n);
            assert!(
                (estimate - n).abs() <= 0.1 * n,
                "{n} ids heard, estimated {estimate:.1}"
            );
        }
        assert!(MatesSketch::default().count().abs() < 1e-9);
    }
}
