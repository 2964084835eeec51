//! Frontier seeking: walk to the nearest frontier.

use glam::DVec2;

use super::Tactic;
use super::navigator::Navigator;
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
    nav: Navigator,
    target: Option<DVec2>,
    /// Round of the last failed frontier search.
    failed_at: Option<u64>,
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
            nav: Navigator::default(),
            target: None,
            failed_at: None,
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
    /// pieces holding them. By target, a search settles a few more pieces.
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

    /// The route follower (strategies that also go elsewhere share it).
    pub fn navigator(&mut self) -> &mut Navigator {
        &mut self.nav
    }

    /// One step towards the nearest frontier whose target lies more than `avoid_radius_m`
    /// from every point `avoid` gives (team mates' goals; asked for only when a new
    /// target is chosen: in crowds they are hundreds, and most rounds keep the target), or
    /// the nearest frontier at all if every one is taken or the nearest clear one is more
    /// than about `max_detour_m` farther (see [`Navigator::frontier_route`];
    /// `f64::INFINITY`: no bound). `None` when none is known.
    pub fn seek(
        &mut self,
        ctx: &mut Ctx,
        avoid: impl FnOnce() -> Vec<DVec2>,
        avoid_radius_m: f64,
        max_detour_m: f64,
    ) -> Option<Action> {
        // Keep walking to a frontier target even once it is seen: the way on reveals more in
        // the same direction, and a new search only every few metres keeps planning cheap.
        // Re-plan on arrival, when the route is gone, or when the target was revealed from
        // close by.
        let p = ctx.position();
        let revealed_near = self.target.is_none_or(|t| {
            ctx.known().is_some_and(|k| k.is_known(t))
                && t.distance(p) < self.replan_within_view * ctx.kind.view_radius_m
        });
        let need_plan = self.nav.is_idle() || revealed_near;
        if need_plan && self.failed_at.is_none_or(|r| ctx.round >= r + 20) {
            let (memo, by_target, reveal_first) = (&mut self.memo, self.by_target, self.reveal_first);
            let found = ctx.timed_planning(|| {
                let avoid = avoid();
                if let Some(views) = by_target
                    && avoid.is_empty()
                {
                    return Navigator::nearest_frontier_route(ctx, memo, views * ctx.kind.view_radius_m, reveal_first);
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
}

impl Tactic for FrontierSeeking {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        self.seek(ctx, Vec::new, 0.0, f64::INFINITY)
    }

    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    crate::serde_state!();
}
