//! Frontier exploration and knowledge sharing: the core of `frontier`, `cooperative`, `team`
//! and the workers.

use glam::DVec2;

use super::{MAX_DISTANCE_M, SHARE_EVERY};
use crate::Result;
use crate::agent::{BoundaryFollowing, CollisionAvoidance, Ctx, EnergyManagement, FrontierSeeking, Params, Tactic};
use crate::spatial::KnownMap;
use crate::world::{Action, Payload, Sighting};

/// How a cooperative robot shares what it knows.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct Sharing {
    pub(super) every_rounds: u64,
    pub(super) avoid_radius_m: f64,
    /// Team mates' goals remembered at most (the most recently heard).
    #[serde(default = "default_max_claims")]
    pub(super) max_claims: usize,
    /// How much farther than the nearest frontier a robot walks to one no team mate
    /// claims (`None`: as far as it takes; see [`FrontierSeeking::seek`]). Unbounded by
    /// default: a bound of 0 explores large maps faster but small teams cover the example
    /// maps more slowly (BENCHMARKS.md, "Defaults of `cooperative`").
    #[serde(default)]
    pub(super) max_detour_m: Option<f64>,
    /// Team mates heard from which a robot walks out along its bearing (`None`: never; see
    /// `Spoke`).
    #[serde(default)]
    pub(super) spoke_mates: Option<f64>,
    /// Rounds a robot of a small team waits when it leaves its new target to a team mate
    /// nearer to it (0: never; see `Frontier::leave_to_mates`). Checkpoints without it
    /// resume with 0, as they ran.
    #[serde(default)]
    pub(super) wait_rounds: u64,
    /// A robot of a small team takes, of this many frontiers nearest to it, the one its team
    /// mates' goals are least often nearer to (0: the nearest frontier clear of their goals;
    /// see `Navigator::least_contested_frontier_route`). Checkpoints without it resume
    /// with 0, as they ran.
    #[serde(default)]
    pub(super) compare_frontiers: usize,
}

/// Team mates' goals a cooperative robot remembers by default: a scalable memory list of
/// the paper's kind (the last n), so that a crowd's memory and work stay linear in its
/// size. Only robots in a crowd hear more than 64 goals, and for them merging hundreds a
/// round is costly (BENCHMARKS.md, "Defaults of `cooperative`").
pub(super) const MAX_CLAIMS: u64 = 64;

/// Rounds a `cooperative` robot of a small team waits, by default, when it leaves its new
/// target to a team mate (see [`Sharing::wait_rounds`]; BENCHMARKS.md, "Exploration
/// quality").
pub(super) const WAIT_ROUNDS: u64 = 5;

/// Frontiers a `cooperative` robot of a small team compares, by default (see
/// [`Sharing::compare_frontiers`]; BENCHMARKS.md, "Exploration quality").
pub(super) const COMPARE_FRONTIERS: u64 = 8;

fn default_max_claims() -> usize {
    MAX_CLAIMS as usize
}

impl Sharing {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        let every_rounds = p.u64_in("share_every", 10, SHARE_EVERY)?;
        let avoid_radius_m = p.f64_in("avoid_radius_m", 5.0, 0.0..=MAX_DISTANCE_M)?;
        let max_claims = p.u64_in("max_claims", MAX_CLAIMS, 0..=1_000_000)? as usize;
        let max_detour_m = p.opt_f64_in("max_detour_m", 0.0..=MAX_DISTANCE_M)?;
        let spoke_mates = p.opt_f64_in("spoke_mates", 0.0..=1.0e9)?;
        let wait_rounds = p.u64_in("wait_rounds", WAIT_ROUNDS, 0..=1_000_000)?;
        let compare_frontiers = p.u64_in("compare_frontiers", COMPARE_FRONTIERS, 0..=1_000)? as usize;
        Ok(Self {
            every_rounds,
            avoid_radius_m,
            max_claims,
            max_detour_m,
            spoke_mates,
            wait_rounds,
            compare_frontiers,
        })
    }
}

/// Exploration of the nearest frontier, with energy management and collision avoidance.
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub(super) struct Explorer {
    pub(super) frontier: FrontierSeeking,
    coll: CollisionAvoidance,
    energy: EnergyManagement,
}

impl Explorer {
    /// Tactics that override everything: energy first, then collisions.
    pub(super) fn reflexes(&mut self, ctx: &mut Ctx) -> Option<Action> {
        if let Some(a) = self.energy.suggest(ctx) {
            ctx.set_goal(Some(ctx.home().center()));
            return Some(a);
        }
        if let Some(a) = self.coll.suggest(ctx) {
            self.frontier.navigator().clear();
            return Some(a);
        }
        None
    }

    /// [`explore`](Self::explore) with no team mates' goals to avoid.
    pub(super) fn explore_unclaimed(&mut self, ctx: &mut Ctx) -> Action {
        self.explore(ctx, Vec::new, 0.0, f64::INFINITY, 0)
    }

    /// One step of frontier exploration (see [`FrontierSeeking::seek`]); home when nothing
    /// is left to explore.
    pub(super) fn explore(
        &mut self,
        ctx: &mut Ctx,
        avoid: impl FnOnce() -> Vec<DVec2>,
        avoid_radius_m: f64,
        max_detour_m: f64,
        compare_frontiers: usize,
    ) -> Action {
        if let Some(a) = self
            .frontier
            .seek(ctx, avoid, avoid_radius_m, max_detour_m, compare_frontiers)
        {
            return a;
        }
        // Nothing left to explore: go home and wait there.
        let home = ctx.home().center();
        let nav = self.frontier.navigator();
        if ctx.home().contains(ctx.position()) {
            Action::Idle
        } else if nav.go_to(ctx, home) {
            nav.step(ctx).unwrap_or(Action::Idle)
        } else {
            let dir = BoundaryFollowing::heading(ctx, home - ctx.position()).unwrap_or(DVec2::ZERO);
            ctx.move_by(dir)
        }
    }
}

/// Every `every` rounds (staggered by robot id): broadcast the known map if it grew by half
/// since it was last shared, and in any case every fifth time (maps of a crowd are
/// near-identical, and merging them costs receivers time for nothing), and all remembered
/// sightings. Other rounds: fresh sightings, if any.
pub(super) fn share_knowledge(ctx: &mut Ctx, every: u64, shared_area: &mut f64) {
    if (ctx.round + u64::from(ctx.me.id.get())).is_multiple_of(every) {
        let area = ctx.known().map_or(0.0, KnownMap::known_area_m2);
        // Also every fifth time regardless, so robots met late still get the whole map.
        let refresh = ((ctx.round + u64::from(ctx.me.id.get())) / every).is_multiple_of(5);
        if area > 1.5 * *shared_area || (refresh && area > 0.0) {
            *shared_area = area;
            ctx.broadcast_known_map();
        }
        let all: Vec<Sighting> = ctx.data.treasures.iter().map(|(s, _)| *s).collect();
        if !all.is_empty() {
            ctx.broadcast(Payload::Sightings(all));
        }
    } else {
        let round = ctx.round;
        let fresh: Vec<Sighting> = ctx
            .treasures_in_view()
            .iter()
            .map(|t| Sighting {
                treasure: t.id,
                position: t.position,
                buried: t.buried,
                loose: t.loose,
                round,
            })
            .collect();
        if !fresh.is_empty() {
            ctx.broadcast(Payload::Sightings(fresh));
        }
    }
}
