//! Frontier seeking: walk to the nearest frontier.

use glam::DVec2;

use super::Tactic;
use super::navigator::Navigator;
use super::tour::Tour;
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::spatial::PieceMemo;
use crate::world::Action;

/// How near a revealed target a robot walks before it searches for the next frontier, as a
/// fraction of its view radius, by default. Smaller fractions search less often, but 0
/// (re-plan only on arrival) stalls exploration (BENCHMARKS.md, "Defaults of
/// `cooperative`"); a lone explorer walks less with 0.5 (`frontier`'s default, BENCHMARKS.md,
/// "Exploration quality").
pub const REPLAN_WITHIN_VIEW: f64 = 0.25;

/// `seen_cost_views` of the `frontier` strategy and tactic, by default: a frontier whose
/// view round it is all known costs two view radii more than one as near whose view is all
/// unknown, so a lone explorer takes frontiers that reveal more (BENCHMARKS.md,
/// "Exploration quality").
pub const SEEN_COST_VIEWS: f64 = 2.0;

/// `reveal_first` of the `frontier` strategy and tactic, by default: frontiers with at least
/// 15 % of the view round them unknown are taken before those that reveal less, which are
/// left for last (BENCHMARKS.md, "Exploration quality").
pub const REVEAL_FIRST: f64 = 0.15;

/// `replan_when_known` of the `frontier` strategy, by default: once the target is seen and
/// at least 65 % of the view round it is known, walking on would reveal little (a room seen
/// whole from its door), so the robot searches again (BENCHMARKS.md, "Exploration quality").
pub const REPLAN_WHEN_KNOWN: f64 = 0.65;

/// Rounds a seeker ranking by target may follow routes to one target without getting
/// nearer to it along them before it gives the target up: its disc does not fit through a
/// gap the route takes, or a robot stands in the way and does not move.
pub const GIVE_UP_ROUNDS: u64 = 40;

/// A pause in seeking longer than this many rounds (another tactic acting, a trip home to
/// recharge) starts the count of [`GIVE_UP_ROUNDS`] afresh; escapes when stuck are shorter.
const PAUSE_ROUNDS: u64 = 10;

/// How near a seeker has come to its target along the routes it followed.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct Progress {
    target: DVec2,
    /// The shortest walk left to the target seen so far.
    best_m: f64,
    /// The round that walk was last cut by half a step or more.
    since: u64,
    /// The round the seeker last looked.
    seen: u64,
}

/// Targets given up that a seeker remembers, at most (the oldest is forgotten first).
const MAX_GIVEN_UP: usize = 16;

/// Targets within this many view radii of one given up are skipped.
const SAME_TARGET_VIEWS: f64 = 0.25;

fn default_replan_within_view() -> f64 {
    REPLAN_WITHIN_VIEW
}

/// Walks to the nearest frontier (by route: known free space bordering the unknown) and
/// publishes it as the goal; quiet once nothing is left to explore (a failed search is
/// retried every 20 rounds, as merged maps may open new frontiers).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct FrontierSeeking {
    /// Search again once the target is known and nearer than this fraction of the view
    /// radius (default [`REPLAN_WITHIN_VIEW`]).
    #[serde(default = "default_replan_within_view")]
    replan_within_view: f64,
    /// Rank frontiers by the walk to their targets, charging this many view radii for a
    /// view round the target already known (see [`Navigator::nearest_frontier_route`]),
    /// when no claim is to be avoided; `None` (the default): by the walk to the pieces
    /// holding them.
    #[serde(default)]
    by_target: Option<f64>,
    /// Ranking by target, take frontiers with at least this part of their view unknown
    /// before the rest (0, the default: all alike; see
    /// [`Navigator::nearest_frontier_route`]).
    #[serde(default)]
    reveal_first: f64,
    /// Search again once the target is known and at least this part of the view round it
    /// is known (`None`, the default: only as `replan_within_view` says).
    #[serde(default)]
    replan_when_known: Option<f64>,
    /// Ranking by target, head for the first stop of a tour over the nearest frontiers
    /// (`None`, the default: for the nearest; see [`Navigator::frontier_tour_route`]).
    #[serde(default)]
    tour: Option<Tour>,
    nav: Navigator,
    target: Option<DVec2>,
    /// Round of the last failed frontier search.
    failed_at: Option<u64>,
    /// The last target searched again for `replan_when_known`: a search that finds the
    /// same target again keeps it, rather than searching every round.
    #[serde(default)]
    rechecked: Option<DVec2>,
    /// Ranking by target: how near the robot has come to its target.
    #[serde(default)]
    progress: Option<Progress>,
    /// Ranking by target: targets given up (see [`GIVE_UP_ROUNDS`]), oldest first.
    #[serde(default)]
    given_up: Vec<DVec2>,
    /// What the searches learnt of this robot's map (worked out again after a restore).
    #[serde(skip)]
    memo: PieceMemo,
}

impl Default for FrontierSeeking {
    fn default() -> Self {
        Self {
            replan_within_view: REPLAN_WITHIN_VIEW,
            by_target: None,
            reveal_first: 0.0,
            replan_when_known: None,
            tour: None,
            nav: Navigator::default(),
            target: None,
            failed_at: None,
            rechecked: None,
            progress: None,
            given_up: Vec::new(),
            memo: PieceMemo::default(),
        }
    }
}

impl FrontierSeeking {
    /// Search again once the target is known and nearer than `fraction` of the view radius.
    #[must_use]
    pub fn with_replan_within_view(mut self, fraction: f64) -> Self {
        self.replan_within_view = fraction;
        self
    }

    /// Rank frontiers by the walk to their targets when no claim is to be avoided, charging
    /// `seen_cost_views` view radii for a view round the target wholly known (in
    /// proportion; see [`Navigator::nearest_frontier_route`]); `None`: by the walk to the
    /// pieces holding them. By target, a search settles a few more pieces, and a target the
    /// robot gets no nearer to along its routes for [`GIVE_UP_ROUNDS`] is given up: later
    /// searches skip targets near it, so a route the robot cannot follow does not hold it
    /// for ever.
    #[must_use]
    pub fn with_ranking_by_target(mut self, seen_cost_views: Option<f64>) -> Self {
        self.by_target = seen_cost_views;
        self
    }

    /// Ranking by target, take frontiers with at least `fraction` of the view round them
    /// unknown before those that reveal less (0: all alike).
    #[must_use]
    pub fn with_reveal_first(mut self, fraction: f64) -> Self {
        self.reveal_first = fraction;
        self
    }

    /// Search again once the target is known and at least `fraction` of the view round it
    /// is known, wherever the robot stands (once a target; `None`: only as
    /// `replan_within_view` says).
    #[must_use]
    pub fn with_replan_when_known(mut self, fraction: Option<f64>) -> Self {
        self.replan_when_known = fraction;
        self
    }

    /// Ranking by target, head for the first stop of the tour `tour` plans over the nearest
    /// frontiers instead of the nearest (`None`: the nearest; see
    /// [`Navigator::frontier_tour_route`]): what the nearest-first rule leaves behind is
    /// taken on the way rather than walked back for.
    #[must_use]
    pub fn with_tour(mut self, tour: Option<Tour>) -> Self {
        self.tour = tour;
        self
    }

    /// [`with_tour`](Self::with_tour) on a seeker already made: from its next search on.
    pub fn set_tour(&mut self, tour: Option<Tour>) {
        self.tour = tour;
    }

    /// The route follower (strategies that also go elsewhere share it).
    pub fn navigator(&mut self) -> &mut Navigator {
        &mut self.nav
    }

    /// One step towards the nearest frontier whose target lies more than `avoid_radius_m`
    /// from every point `avoid` gives (team mates' goals; asked for only when a new
    /// target is chosen: in crowds they are hundreds, and most rounds keep the target), or
    /// the nearest frontier at all if every one is taken or the nearest clear one is more
    /// than about `max_detour_m` farther (see [`Navigator::frontier_route`];
    /// `f64::INFINITY`: no bound). With goals to avoid and `compare_frontiers` above 0, the
    /// least contested of that many nearest frontiers instead
    /// ([`Navigator::least_contested_frontier_route`]). `None` when none is known.
    pub fn seek(
        &mut self,
        ctx: &mut Ctx,
        avoid: impl FnOnce() -> Vec<DVec2>,
        avoid_radius_m: f64,
        max_detour_m: f64,
        compare_frontiers: usize,
    ) -> Option<Action> {
        // Keep walking to a frontier target even once it is seen: the way on reveals more in
        // the same direction, and a new search only every few metres keeps planning cheap.
        // Re-plan on arrival, when the route is gone, or when the target was revealed from
        // close by or with most of the view round it (`target_revealed`).
        if self.by_target.is_some() {
            self.give_up_if_stalled(ctx);
        }
        let need_plan = self.nav.is_idle() || self.target_revealed(ctx);
        if need_plan && self.failed_at.is_none_or(|r| ctx.round >= r + 20) {
            let (memo, by_target, reveal_first, tour) = (&mut self.memo, self.by_target, self.reveal_first, self.tour);
            let given_up = &self.given_up;
            let found = ctx.timed_planning(|| {
                let avoid = avoid();
                if compare_frontiers > 0 && !avoid.is_empty() {
                    return Navigator::least_contested_frontier_route(ctx, memo, &avoid, compare_frontiers);
                }
                if let Some(views) = by_target
                    && avoid.is_empty()
                {
                    let view_m = ctx.kind.view_radius_m;
                    let skip = (given_up.as_slice(), SAME_TARGET_VIEWS * view_m);
                    if let Some(tour) = tour {
                        return Navigator::frontier_tour_route(ctx, memo, views * view_m, reveal_first, skip, tour);
                    }
                    return Navigator::nearest_frontier_route(ctx, memo, views * view_m, reveal_first, skip);
                }
                Navigator::frontier_route_memo(ctx, memo, &avoid, avoid_radius_m, max_detour_m)
                    .or_else(|| Navigator::frontier_route_memo(ctx, memo, &[], 0.0, f64::INFINITY))
            });
            if let Some(route) = found {
                self.target = route.waypoints.last().copied();
                self.nav.follow(route);
                self.failed_at = None;
            } else {
                self.target = None;
                self.nav.clear();
                self.failed_at = Some(ctx.round);
            }
        }
        ctx.set_goal(self.target);
        self.nav.step(ctx)
    }

    /// Whether to search again for the current target's sake: there is none, or it is
    /// known and nearer than `replan_within_view` of the view radius, or (once a target)
    /// it is known with at least `replan_when_known` of the view round it.
    fn target_revealed(&mut self, ctx: &Ctx) -> bool {
        let Some(t) = self.target else {
            return true;
        };
        let Some(known) = ctx.known().filter(|k| k.is_known(t)) else {
            return false;
        };
        let view_m = ctx.kind.view_radius_m;
        if t.distance(ctx.position()) < self.replan_within_view * view_m {
            return true;
        }
        let fresh = self.rechecked != Some(t);
        let seen_round = self
            .replan_when_known
            .is_some_and(|fraction| fresh && known.known_fraction_near(t, view_m) >= fraction);
        if seen_round {
            self.rechecked = Some(t);
        }
        seen_round
    }

    /// Give the target up when the walk left along the routes to it has not shrunk by half
    /// a step in [`GIVE_UP_ROUNDS`] (pauses of more than [`PAUSE_ROUNDS`] start the count
    /// afresh): remember it, drop the route, and search again.
    fn give_up_if_stalled(&mut self, ctx: &Ctx) {
        let Some(target) = self.target.filter(|_| !self.nav.is_idle()) else {
            return;
        };
        let (round, left_m) = (ctx.round, self.nav.remaining_m(ctx.position()));
        let fresh = Progress {
            target,
            best_m: left_m,
            since: round,
            seen: round,
        };
        let progress = match self.progress {
            Some(p) if p.target == target && round <= p.seen + PAUSE_ROUNDS => p,
            _ => fresh,
        };
        let progress = if left_m < progress.best_m - 0.5 * ctx.kind.speed_m_per_round {
            fresh
        } else {
            Progress {
                seen: round,
                ..progress
            }
        };
        self.progress = Some(progress);
        if round >= progress.since + GIVE_UP_ROUNDS {
            if self.given_up.len() == MAX_GIVEN_UP {
                self.given_up.remove(0);
            }
            self.given_up.push(target);
            self.progress = None;
            self.target = None;
            self.nav.clear();
        }
    }
}

impl Tactic for FrontierSeeking {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        self.seek(ctx, Vec::new, 0.0, f64::INFINITY, 0)
    }

    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    crate::serde_state!();
}
