//! Shortest paths on the navigation graph within known terrain, and frontier search.

use std::cell::{Cell, RefCell};

use glam::DVec2;

use super::tour::{self, Tour};
use super::{SEARCH_BUDGET, blocked};
use crate::agent::ctx::Ctx;
use crate::spatial::{
    Aabb, BlockCells, Finger, FoundGoal, KnownMap, NavGraph, NavNodeId, Overlap, PieceMemo, Route, Shape, Square,
};
use crate::world::Action;

/// Follows routes on the navigation graph, waypoint by waypoint, and finds frontiers.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Navigator {
    waypoints: Vec<DVec2>,
    next: usize,
    /// Where the robot stood when it last stepped (whatever route it followed then).
    #[serde(default)]
    stepped_from: Option<DVec2>,
}

impl Navigator {
    /// Follow `route` from now on.
    pub fn follow(&mut self, route: Route) {
        self.waypoints = route.waypoints;
        self.next = 0;
    }

    /// Drop the current route.
    pub fn clear(&mut self) {
        self.waypoints.clear();
        self.next = 0;
    }

    /// Whether there is nothing left to follow.
    pub fn is_idle(&self) -> bool {
        self.next >= self.waypoints.len()
    }

    /// The final point of the route.
    pub fn destination(&self) -> Option<DVec2> {
        self.waypoints.last().copied()
    }

    /// The waypoints still ahead.
    pub fn remaining(&self) -> &[DVec2] {
        &self.waypoints[self.next.min(self.waypoints.len())..]
    }

    /// The walk left along the route from `p`: to the next waypoint, then leg by leg to the
    /// last (0 when idle). O(waypoints left).
    pub fn remaining_m(&self, p: DVec2) -> f64 {
        let ahead = self.remaining();
        let first = ahead.first().map_or(0.0, |w| w.distance(p));
        first + ahead.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>()
    }

    /// Plan a shortest route to `to` within known terrain and follow it.
    pub fn go_to(&mut self, ctx: &Ctx, to: DVec2) -> bool {
        let route = ctx.timed_planning(|| {
            ctx.terrain()
                .and_then(|t| ctx.nav().route_within(t, ctx.position(), to, SEARCH_BUDGET))
        });
        match route {
            Some(r) => {
                self.follow(r);
                true
            }
            None => false,
        }
    }

    /// Plan the shortest route to `to` taking unknown terrain as open (see
    /// [`NavGraph::route_optimistic`](crate::spatial::NavGraph::route_optimistic)) and follow it.
    pub fn go_to_optimistic(&mut self, ctx: &Ctx, to: DVec2) -> bool {
        let route = ctx.timed_planning(|| {
            ctx.terrain()
                .and_then(|t| ctx.nav().route_optimistic(t, ctx.position(), to, SEARCH_BUDGET))
        });
        match route {
            Some(r) => {
                self.follow(r);
                true
            }
            None => false,
        }
    }

    /// The move towards the next waypoint (skipping those already reached). A route's legs
    /// join pieces of free space, and the robot's disc can catch a corner on one or find no
    /// room at a waypoint by a wall; when a wall held the last step back and the straight way
    /// on is blocked, it heads for the farthest of the next `LOOK_AHEAD` waypoints in
    /// straight reach, else slides along the wall (see `slide`).
    pub fn step(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let p = ctx.position();
        let tol = 0.05;
        while self.next < self.waypoints.len() && self.waypoints[self.next].distance(p) <= tol {
            self.next += 1;
        }
        let target = *self.waypoints.get(self.next)?;
        ctx.set_path(self.remaining());
        let held_back = self
            .stepped_from
            .is_some_and(|q| q.distance(p) < 0.5 * ctx.kind.speed_m_per_round && blocked(ctx));
        self.stepped_from = Some(p);
        if held_back && ctx.can_move(p, target) == Some(false) {
            // A waypoint further on in straight reach (one the disc cannot stand on is
            // passed by), else a slide towards this one.
            let ahead = (self.next + 1..self.waypoints.len().min(self.next + 1 + LOOK_AHEAD))
                .rev()
                .find(|&k| ctx.can_move(p, self.waypoints[k]) == Some(true));
            if let Some(k) = ahead {
                self.next = k;
                return Some(Action::MoveTo { to: self.waypoints[k] });
            }
            if let Some(to) = slide(ctx, p, target) {
                return Some(Action::MoveTo { to });
            }
        }
        Some(Action::MoveTo { to: target })
    }

    /// Route to the nearest frontier (by path): the closest piece of free space the known map
    /// touches that is either partly unknown (the route ends at its nearest unknown point) or
    /// borders a piece not known at all (the route ends just across their shared edge).
    /// Targets within `avoid_radius_m` of a point in `avoid` (team mates' goals) are skipped,
    /// but only while the search stays within `max_detour_m` of the nearest skipped one:
    /// once it settles a piece entered more than `max_detour_m` beyond the piece of the
    /// first target it skipped, the route goes to that target after all (`f64::INFINITY`:
    /// no bound; the search goes on to the nearest target clear of every claim).
    pub fn frontier_route(ctx: &Ctx, avoid: &[DVec2], avoid_radius_m: f64, max_detour_m: f64) -> Option<Route> {
        Self::frontier_route_memo(ctx, &mut PieceMemo::default(), avoid, avoid_radius_m, max_detour_m)
    }

    /// [`frontier_route`](Self::frontier_route) that remembers, in `memo`, which pieces the
    /// robot's known map touches and covers (a strategy keeps one per robot: its next
    /// search asks about much the same pieces). The route is the same, as the memo answers
    /// as the map does (`piece_memo_answers_as_the_map_does`, spatial/nav/tests.rs).
    pub fn frontier_route_memo(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        avoid: &[DVec2],
        avoid_radius_m: f64,
        max_detour_m: f64,
    ) -> Option<Route> {
        Self::frontier_search(ctx, memo, avoid, avoid_radius_m, max_detour_m, Ranking::ByEntry)
    }

    /// The route to the frontier nearest by route for a robot that avoids no claims: as
    /// [`frontier_route_memo`](Self::frontier_route_memo) with nothing to avoid, but the
    /// frontiers are ranked by the walk to their targets, not to the pieces holding them
    /// (see [`NavGraph::search_nearest_goal`]), and each target is the unknown point
    /// nearest to where the route enters its piece. Pieces are up to 16 leaves long, so
    /// the first piece reached can hold a frontier metres farther than a later one's.
    ///
    /// A frontier's cost is also charged `seen_cost_m` times the part of the view round its
    /// target that the robot knows already ([`KnownMap::known_fraction_near`]): of two
    /// frontiers about as near, the one with more unknown round it is taken (0: by route
    /// only). Frontiers whose view round the target is at least `reveal_first` unknown are
    /// taken before the rest, which are searched for only when there is none of those (0:
    /// all alike): corners that reveal little are left for last rather than walked into.
    /// Targets within `skip.1` of a point of `skip.0` (targets given up) are passed over.
    pub fn nearest_frontier_route(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        seen_cost_m: f64,
        reveal_first: f64,
        (skip, skip_radius_m): (&[DVec2], f64),
    ) -> Option<Route> {
        let by_target = |max_known| Ranking::ByTarget { seen_cost_m, max_known };
        let search = |memo: &mut PieceMemo, max_known| {
            Self::frontier_search(ctx, memo, skip, skip_radius_m, f64::INFINITY, by_target(max_known))
        };
        if reveal_first > 0.0
            && let Some(route) = search(memo, 1.0 - reveal_first)
        {
            return Some(route);
        }
        search(memo, 1.0)
    }

    /// The route to the first stop of a tour over the frontiers nearest by route, for a
    /// robot that avoids no claims: of the `TOUR_CANDIDATES` (64) cheapest targets (ranked as
    /// [`nearest_frontier_route`](Self::nearest_frontier_route) ranks them, those with
    /// `reveal_first` of their view unknown if there are any), up to `tour.stops` at least
    /// `tour.spacing_views` view radii apart, visited in the order that minimises the
    /// weighted arrival (`tour::first_stop`; a stop weighs the part of its view still
    /// unknown plus `tour.base_weight`). Legs between stops are taken as long as the
    /// longer of the straight line and the difference of the walks to them, which no route
    /// between them can be shorter than. A corner the nearest-first rule would leave for
    /// last is taken when the tour passes it, rather than walked back for.
    ///
    /// Cost: one search settling the pieces nearer than the last candidate, and the first
    /// stop's O(2^stops × stops²).
    pub fn frontier_tour_route(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        seen_cost_m: f64,
        reveal_first: f64,
        skip: (&[DVec2], f64),
        tour: Tour,
    ) -> Option<Route> {
        let terrain = ctx.terrain()?;
        let (known, view_m) = (terrain.known, ctx.kind.view_radius_m);
        let mut found = Vec::new();
        if reveal_first > 0.0 {
            found = Self::cheapest_frontiers(ctx, memo, seen_cost_m, 1.0 - reveal_first, skip);
        }
        if found.is_empty() {
            found = Self::cheapest_frontiers(ctx, memo, seen_cost_m, 1.0, skip);
        }
        let mut stops = spaced(found, tour.stops.min(tour::MAX_TOUR_STOPS), tour.spacing_views * view_m);
        let unknown: Vec<f64> = stops
            .iter()
            .map(|s| 1.0 - known.known_fraction_near(s.point, view_m))
            .collect();
        // The walk to each stop, without the search's charge for what is known round it.
        let walk: Vec<f64> = stops
            .iter()
            .zip(&unknown)
            .map(|(s, u)| s.cost_m - seen_cost_m * (1.0 - u))
            .collect();
        let weight: Vec<f64> = unknown.iter().map(|u| u + tour.base_weight).collect();
        let leg_m = |i: usize, j: usize| stops[i].point.distance(stops[j].point).max((walk[i] - walk[j]).abs());
        let (first, _) = tour::first_stop(&walk, leg_m, &weight)?;
        let chosen = stops.swap_remove(first);
        memo.set_route_end(chosen.nodes.last().copied());
        Some(ctx.nav().route_to_found(ctx.position(), chosen, terrain))
    }

    /// The `TOUR_CANDIDATES` cheapest frontier targets, ranked by the walk plus
    /// `seen_cost_m` times the part of the view round them known, among those with at most
    /// `max_known` of it known; targets near those in `skip` are passed over.
    fn cheapest_frontiers(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        seen_cost_m: f64,
        max_known: f64,
        (skip, skip_radius_m): (&[DVec2], f64),
    ) -> Vec<FoundGoal> {
        let Some(terrain) = ctx.terrain() else {
            return Vec::new();
        };
        let (known, nav, view_m) = (terrain.known, ctx.nav(), ctx.kind.view_radius_m);
        let start_hint = memo.route_end();
        let ranking = Ranking::ByTarget { seen_cost_m, max_known };
        let search = FrontierSearch::new(ranking, nav, known, skip, skip_radius_m, f64::INFINITY, memo);
        nav.search_cheapest_goals(
            ctx.position(),
            start_hint,
            |m| search.usable(m),
            |n, d, at, reached| search.goal_by_target(n, d, at, reached, view_m),
            &|t| search.seen_charge(t, view_m),
            TOUR_CANDIDATES,
            SEARCH_BUDGET,
        )
    }

    /// Route to the least contested of the `k` frontiers nearest by route (`MinPos`, after
    /// Bautin, Simonin and Charpillet, 2012): each frontier's rank is the number of
    /// `mates` (team mates' announced goals, where they are headed) that lie nearer to its
    /// target, in a straight line, than this robot's route; the frontier of lowest rank
    /// wins, the nearest of those. Targets are ranked by the walk to them, as
    /// [`nearest_frontier_route`](Self::nearest_frontier_route) does with no view charged,
    /// and a target within `SAME_FRONTIER_M` of a nearer one counts as the same frontier.
    /// A robot so takes a frontier its mates will not reach first, rather than the nearest,
    /// which a mate may be about to explore. Cost: one search settling the pieces nearer
    /// than the `k`-th target, and `k` × mates distances.
    pub fn least_contested_frontier_route(ctx: &Ctx, memo: &mut PieceMemo, mates: &[DVec2], k: usize) -> Option<Route> {
        let terrain = ctx.terrain()?;
        let known = terrain.known;
        let nav = ctx.nav();
        let p = ctx.position();
        let start_hint = memo.route_end();
        let by_walk = Ranking::ByTarget {
            seen_cost_m: 0.0,
            max_known: 1.0,
        };
        let search = FrontierSearch::new(by_walk, nav, known, &[], 0.0, f64::INFINITY, memo);
        let found = nav.search_cheapest_goals(
            p,
            start_hint,
            |m| search.usable(m),
            |n, d, at, reached| search.goal(n, d, at, reached),
            &|_| 0.0,
            k,
            SEARCH_BUDGET,
        );
        let mut frontiers = spaced(found, usize::MAX, SAME_FRONTIER_M);
        let rank = |f: &FoundGoal| mates.iter().filter(|m| m.distance(f.point) < f.cost_m).count();
        // Cheapest first already: the first of the lowest rank is the nearest of them.
        let best = (0..frontiers.len()).min_by_key(|&i| (rank(&frontiers[i]), i))?;
        let chosen = frontiers.swap_remove(best);
        search.memo.into_inner().set_route_end(chosen.nodes.last().copied());
        Some(nav.route_to_found(p, chosen, terrain))
    }

    /// A frontier search (see [`frontier_route_memo`](Self::frontier_route_memo)) ranking
    /// frontiers as `ranking` says.
    fn frontier_search(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        avoid: &[DVec2],
        avoid_radius_m: f64,
        max_detour_m: f64,
        ranking: Ranking,
    ) -> Option<Route> {
        let terrain = ctx.terrain()?;
        let known = terrain.known;
        let nav = ctx.nav();
        let p = ctx.position();
        let view_m = ctx.kind.view_radius_m;
        let start_hint = memo.route_end();
        let search = FrontierSearch::new(ranking, nav, known, avoid, avoid_radius_m, max_detour_m, memo);
        let route = match ranking {
            Ranking::ByEntry => nav.search_knowing_reached(
                p,
                start_hint,
                terrain,
                |m| search.usable(m),
                |n, d, reached| search.goal(n, d, p, reached),
                SEARCH_BUDGET,
            ),
            Ranking::ByTarget { .. } => nav.search_nearest_goal(
                p,
                start_hint,
                terrain,
                |m| search.usable(m),
                |n, d, at, reached| search.goal_by_target(n, d, at, reached, view_m),
                &|t| search.seen_charge(t, view_m),
                SEARCH_BUDGET,
            ),
        };
        if let Some(r) = &route {
            search.memo.into_inner().set_route_end(r.nodes.last().copied());
        }
        route
    }
}

/// Targets of [`Navigator::least_contested_frontier_route`] this near a nearer one count as
/// the same frontier: its search finds one target per piece, and a frontier's unknown edge
/// borders many pieces.
pub const SAME_FRONTIER_M: f64 = 2.0;

/// Frontier targets a tour's search gathers before it keeps those far enough apart
/// ([`Navigator::frontier_tour_route`]): it finds one target per piece, and a frontier's
/// unknown edge borders many pieces.
pub const TOUR_CANDIDATES: usize = 64;

/// Of `found` (cheapest first), up to `max` targets each more than `spacing_m` from every
/// cheaper one kept.
fn spaced(found: Vec<FoundGoal>, max: usize, spacing_m: f64) -> Vec<FoundGoal> {
    let mut kept: Vec<FoundGoal> = Vec::with_capacity(found.len().min(max));
    for f in found {
        if kept.len() == max {
            break;
        }
        if kept.iter().all(|g| g.point.distance(f.point) > spacing_m) {
            kept.push(f);
        }
    }
    kept
}

/// Whether at most `max_known` of the view round `t` is known (always, from 1 on).
fn known_at_most(known: &KnownMap, t: DVec2, view_m: f64, max_known: f64) -> bool {
    max_known >= 1.0 || known.known_fraction_near(t, view_m) <= max_known
}

/// Waypoints past the next that a robot held back by a wall looks at for one in straight
/// reach.
const LOOK_AHEAD: usize = 16;

/// A step from `p` towards `target` along one axis (the longer part of the way first), one
/// the known map shows free: how a disc caught on a corner gets round it. `None` if neither
/// is free.
fn slide(ctx: &Ctx, p: DVec2, target: DVec2) -> Option<DVec2> {
    let d = target - p;
    let mut parts = [DVec2::new(d.x, 0.0), DVec2::new(0.0, d.y)];
    if d.y.abs() > d.x.abs() {
        parts.swap(0, 1);
    }
    parts
        .into_iter()
        .filter(|part| part.length() > 1e-9)
        .map(|part| p + part.clamp_length_max(ctx.kind.speed_m_per_round))
        .find(|&to| ctx.can_move(p, to) == Some(true))
}

/// How a frontier search ranks the frontiers it finds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ranking {
    /// By the walk to where the route enters the piece holding the frontier; the first
    /// piece with one wins, its target the unknown point nearest to the robot.
    ByEntry,
    /// By the walk to the target itself, plus `seen_cost_m` times the part of the view round
    /// it already known, among the targets with at most `max_known` of that view known
    /// (see [`Navigator::nearest_frontier_route`]).
    ByTarget { seen_cost_m: f64, max_known: f64 },
}

/// A frontier search under way (see [`Navigator::frontier_route_memo`]): what it looks
/// for, and what its usable test and goal test share.
struct FrontierSearch<'a, 'm> {
    ranking: Ranking,
    nav: &'a NavGraph,
    known: &'a KnownMap,
    avoid: &'a [DVec2],
    avoid_radius_m: f64,
    max_detour_m: f64,
    /// How far past an edge a target across it lies.
    step_in: f64,
    /// The goal test of a node asks its neighbours whether the known map touches them,
    /// and the search asks again right after, when it expands the node: the answers are
    /// kept in between (a "no" is not in the memo).
    touched: RefCell<Vec<(NavNodeId, bool)>>,
    /// The first target skipped for a claim: its piece, the distance walked to enter
    /// that piece, and the target.
    skipped: Cell<Option<(NavNodeId, f64, DVec2)>>,
    memo: RefCell<&'m mut PieceMemo>,
    finger: RefCell<Finger<'a>>,
}

impl<'a, 'm> FrontierSearch<'a, 'm> {
    /// A search for frontiers as `ranking` says, on `nav` with the robot's `known` map and
    /// its `memo`, skipping targets within `avoid_radius_m` of `avoid` for up to
    /// `max_detour_m` (see [`Navigator::frontier_route`]).
    fn new(
        ranking: Ranking,
        nav: &'a NavGraph,
        known: &'a KnownMap,
        avoid: &'a [DVec2],
        avoid_radius_m: f64,
        max_detour_m: f64,
        memo: &'m mut PieceMemo,
    ) -> Self {
        Self {
            ranking,
            nav,
            known,
            avoid,
            avoid_radius_m,
            max_detour_m,
            step_in: 0.5 * known.grid().cell_m(),
            touched: RefCell::new(Vec::with_capacity(32)),
            skipped: Cell::new(None),
            memo: RefCell::new(memo),
            // The pieces asked about lie close together: descents of the known map start
            // from where the last one passed.
            finger: RefCell::new(Finger::new(known.tree())),
        }
    }
}

impl FrontierSearch<'_, '_> {
    /// Whether the known map touches piece `m`.
    #[inline]
    fn touches(&self, m: NavNodeId) -> bool {
        self.memo
            .borrow_mut()
            .touched_from(self.nav, self.known, &mut self.finger.borrow_mut(), m)
    }

    /// The search's usable test: whether the known map touches piece `m`, answered from the
    /// last goal test's answers when it asked.
    #[inline]
    fn usable(&self, m: NavNodeId) -> bool {
        let hit = self.touched.borrow().iter().find(|e| e.0 == m).map(|e| e.1);
        hit.unwrap_or_else(|| self.touches(m))
    }

    /// Whether target `t` of piece `n`, entered after walking `d`, is clear of every claim;
    /// the first target skipped is remembered.
    #[inline]
    fn taken(&self, n: NavNodeId, d: f64, t: DVec2) -> bool {
        let ok = self.avoid.iter().all(|a| a.distance(t) > self.avoid_radius_m);
        if !ok && self.skipped.get().is_none() {
            self.skipped.set(Some((n, d, t)));
        }
        ok
    }

    /// The goal test of a search ranking by target: [`goal`](Self::goal), among targets
    /// with at most the ranking's `max_known` of the view round them known (`view_m`, the
    /// view radius).
    fn goal_by_target(
        &self,
        n: NavNodeId,
        d: f64,
        at: DVec2,
        reached: &dyn Fn(NavNodeId) -> bool,
        view_m: f64,
    ) -> Option<(NavNodeId, DVec2)> {
        let max_known = match self.ranking {
            Ranking::ByTarget { max_known, .. } => max_known,
            Ranking::ByEntry => 1.0,
        };
        self.goal(n, d, at, reached)
            .filter(|&(_, t)| known_at_most(self.known, t, view_m, max_known))
    }

    /// What a target costs beyond the walk to it: the ranking's `seen_cost_m` times the part
    /// of the view round it known (0 ranking by entry).
    fn seen_charge(&self, t: DVec2, view_m: f64) -> f64 {
        match self.ranking {
            Ranking::ByTarget { seen_cost_m, .. } => seen_cost_m * self.known.known_fraction_near(t, view_m),
            Ranking::ByEntry => 0.0,
        }
    }

    /// The search's goal test of piece `n`, entered at `at` after walking `d`: the skipped
    /// target once the detour allowed is used up, else the unknown point nearest to `at`
    /// of a piece the known map does not cover, else a point across an edge into a piece it
    /// does not touch. Ranking by entry passes the robot's position as `at`.
    fn goal(&self, n: NavNodeId, d: f64, at: DVec2, reached: &dyn Fn(NavNodeId) -> bool) -> Option<(NavNodeId, DVec2)> {
        self.touched.borrow_mut().clear();
        // Pieces settle in the order of the distance walked to enter them, so this is the
        // first piece beyond the detour allowed: the skipped target it is.
        if let Some((n0, _, t0)) = self.skipped.get().filter(|s| d > s.1 + self.max_detour_m) {
            return Some((n0, t0));
        }
        if !self
            .memo
            .borrow_mut()
            .covered_from(self.nav, self.known, &mut self.finger.borrow_mut(), n)
        {
            return nearest_unknown(self.known, &self.nav.bounds(n), at)
                .filter(|t| self.taken(n, d, *t))
                .map(|t| (n, t));
        }
        self.goal_across_edge(n, d, at, reached)
    }

    /// A target just across the edge from piece `n` into a neighbour the known map does not
    /// touch, keeping the neighbours' answers for the search's expansion of `n`.
    fn goal_across_edge(
        &self,
        n: NavNodeId,
        d: f64,
        at: DVec2,
        reached: &dyn Fn(NavNodeId) -> bool,
    ) -> Option<(NavNodeId, DVec2)> {
        let mut cache = self.touched.borrow_mut();
        for m in self.nav.neighbors(n) {
            // A node the search reached is touched (the search uses only those), and never
            // asked about again.
            if reached(m) {
                continue;
            }
            let t = self.touches(m);
            cache.push((m, t));
            if t {
                continue;
            }
            // Ranked by the walk to the target, the edge is crossed where it is nearest.
            let portal = match self.ranking {
                Ranking::ByEntry => self.nav.portal(n, m),
                Ranking::ByTarget { .. } => self.nav.entry_point(n, m, at),
            };
            let inward = (self.nav.bounds(m).center() - portal).normalize_or_zero();
            let found = Some(portal + inward * self.step_in).filter(|t| self.taken(n, d, *t));
            if found.is_some() {
                // The search ends here: the other neighbours are not needed.
                return found.map(|t| (n, t));
            }
        }
        None
    }
}

/// The unknown point of `area` nearest to `p`, nudged a little into the unknown cell: of
/// the unknown leaves in `area`, the first (in the tree's walk order) whose point is
/// nearest.
///
/// The walk prunes boxes farther than the best point found so far, but it goes in the
/// tree's order, not outward from `p`: in a large piece most of it could come before a
/// near point is found. So a first point is looked for near `p` (in growing squares round
/// the point of `area` nearest to `p`), and the whole walk starts from it, taking a later
/// leaf at the same distance only where the first walk would have: before it reaches the
/// leaf that point came from. The answer is the one walk's, ties included:
/// `nearest_unknown_equals_a_whole_walk`.
fn nearest_unknown(known: &KnownMap, area: &Aabb, p: DVec2) -> Option<DVec2> {
    let cell = known.grid().cell_m();
    // Small areas are walked whole at once: a first look round `p` would cost about as much.
    if (area.max - area.min).max_element() <= 32.0 * cell {
        return nearest_unknown_within(known, area, area, p).map(|f| f.1);
    }
    let c = p.clamp(area.min, area.max);
    let mut half = 4.0 * cell;
    loop {
        let near = Aabb {
            min: (c - DVec2::splat(half)).max(area.min),
            max: (c + DVec2::splat(half)).min(area.max),
        };
        let whole = near.min == area.min && near.max == area.max;
        match nearest_unknown_within(known, area, &near, p) {
            // The walk over all of `area` is the answer itself.
            found if whole => return found.map(|f| f.1),
            Some(seed) => return Some(nearest_unknown_from(known, area, p, seed)),
            None => half *= 8.0,
        }
    }
}

/// The point (as [`nearest_unknown`] places it in `area`) of the unknown leaf meeting
/// `within` (a part of `area`) that is nearest to `p`, the first in the walk's order of
/// those as near, with its leaf and squared distance.
fn nearest_unknown_within(known: &KnownMap, area: &Aabb, within: &Aabb, p: DVec2) -> Option<(Square, DVec2, f64)> {
    let (found, at_best) = nearest_unknown_pass(known, area, within, p, None, true);
    if at_best <= 1 {
        return found;
    }
    // Points tied at the nearest distance: the walk's own order picks among them.
    nearest_unknown_pass(known, area, within, p, None, false).0
}

/// The point of leaf `b`'s part in `area` nearest to `p`, a little inside it (so that
/// reaching it reveals it).
fn unknown_point(known: &KnownMap, area: &Aabb, b: &Aabb, p: DVec2) -> DVec2 {
    let lo = b.min.max(area.min);
    let hi = b.max.min(area.max);
    let inset = DVec2::splat((0.5 * known.grid().cell_m()).min(0.5 * (hi - lo).min_element()));
    p.clamp(lo + inset, hi - inset)
}

/// The whole walk of [`nearest_unknown`] over `area`, pruned from the start by `seed` (a
/// leaf's point and squared distance, as [`nearest_unknown_within`] gives).
#[allow(clippy::float_cmp)] // ties are exactly equal distances, as the whole walk sees them
fn nearest_unknown_from(known: &KnownMap, area: &Aabb, p: DVec2, seed: (Square, DVec2, f64)) -> DVec2 {
    let (found, at_best) = nearest_unknown_pass(known, area, area, p, Some(seed), true);
    if at_best <= 1 {
        return found.map_or(seed.1, |f| f.1);
    }
    let (seed_square, seed_point, seed_d) = seed;
    let best_d = Cell::new(seed_d);
    let (mut best, mut best_is_seed, mut passed_seed) = (seed_point, true, false);
    let pruned = NearerThan {
        area: *area,
        p,
        best: &best_d,
        z_order: false,
    };
    let _ = known.tree().visit_leaves_in(&pruned, false, |sq, b| {
        if sq == seed_square {
            passed_seed = true;
            return std::ops::ControlFlow::Continue(());
        }
        let q = unknown_point(known, area, &b, p);
        let d = q.distance_squared(p);
        // A tie goes to the leaf the walk reaches first: this one, if the walk has not
        // reached the seed's leaf yet.
        if d < best_d.get() || (d == best_d.get() && best_is_seed && !passed_seed) {
            best_d.set(d);
            (best, best_is_seed) = (q, false);
        }
        std::ops::ControlFlow::Continue(())
    });
    best
}

/// One pruned walk for the nearest unknown point of `area` meeting `within` (from `seed`,
/// a leaf's point and squared distance, if given; its leaf is not visited again): the
/// first point found at the nearest distance, with its leaf and squared distance, and how
/// many leaves' points (the seed's included) are that near. With `z_order` blocks' leaves
/// come in Z order, cheaper than the walk's own: the leaves visited are the same, as the
/// pruning never cuts a leaf as near as the best, so the nearest distance and the count
/// are too, and when one point alone is that near it is the walk's answer whatever the
/// order.
#[allow(clippy::float_cmp)] // ties are exactly equal distances, as the walks see them
fn nearest_unknown_pass(
    known: &KnownMap,
    area: &Aabb,
    within: &Aabb,
    p: DVec2,
    seed: Option<(Square, DVec2, f64)>,
    z_order: bool,
) -> (Option<(Square, DVec2, f64)>, usize) {
    let best_d = Cell::new(seed.map_or(f64::INFINITY, |s| s.2));
    let mut best = seed.map(|s| (s.0, s.1));
    let mut at_best = usize::from(seed.is_some());
    let pruned = NearerThan {
        area: *within,
        p,
        best: &best_d,
        z_order,
    };
    let _ = known.tree().visit_leaves_in(&pruned, false, |sq, b| {
        if seed.is_some_and(|s| s.0 == sq) {
            return std::ops::ControlFlow::Continue(());
        }
        let q = unknown_point(known, area, &b, p);
        let d = q.distance_squared(p);
        if d < best_d.get() {
            best_d.set(d);
            best = Some((sq, q));
            at_best = 1;
        } else if d == best_d.get() {
            at_best += 1;
        }
        std::ops::ControlFlow::Continue(())
    });
    (best.map(|(sq, q)| (sq, q, best_d.get())), at_best)
}

/// `area`, minus the boxes whose part in `area` lies farther from `p` than the best
/// distance found so far: their leaves cannot win. Only strictly farther boxes are cut, so
/// ties resolve as in a full scan (first visited wins) and the result is the same.
struct NearerThan<'a> {
    area: Aabb,
    p: DVec2,
    best: &'a Cell<f64>,
    /// Whether blocks' leaves may come in Z order (else in the walk's own order).
    z_order: bool,
}

impl NearerThan<'_> {
    fn too_far(&self, b: &Aabb) -> bool {
        let part = Aabb {
            min: b.min.max(self.area.min),
            max: b.max.min(self.area.max),
        };
        part.distance_squared_to(self.p) > self.best.get()
    }
}

impl Shape for NearerThan<'_> {
    fn classify(&self, b: &Aabb) -> Overlap {
        // Never "contains": boxes below must still be tested against the best distance.
        if self.area.intersects(b) && !self.too_far(b) {
            Overlap::Partial
        } else {
            Overlap::Disjoint
        }
    }

    fn intersects(&self, b: &Aabb) -> bool {
        self.area.intersects(b) && !self.too_far(b)
    }

    /// `intersects` for a block's cells at once. A leaf meets the shape exactly when one
    /// of its cells does; the walk then takes a block's leaves against the best distance
    /// as it was at the block, not as it falls leaf by leaf, and the leaves it keeps in
    /// besides cannot win: their points are farther than the best distance.
    fn intersects_cells(&self, cells: &BlockCells) -> Option<u64> {
        Some(self.area.cells_with_part_near(cells, self.p, self.best.get()))
    }

    /// The first leaf found at the nearest distance wins: the walk's own order, unless
    /// only the nearest distance is wanted.
    fn cells_in_z_order(&self) -> bool {
        self.z_order
    }

    fn bounds(&self) -> Aabb {
        self.area
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // nearest means exactly as near
mod tests {
    use glam::DVec2;
    use rand::{Rng, SeedableRng};

    use super::{nearest_unknown, nearest_unknown_from, unknown_point};
    use crate::spatial::{Aabb, Grid, KnownMap};

    /// Every unknown leaf meeting `area`, no pruning: a point nearest (the first in this
    /// walk's order, which is not the pruned walk's), and how many leaves' points are that
    /// near.
    fn brute_force(known: &KnownMap, area: &Aabb, p: DVec2) -> (Option<DVec2>, usize) {
        let cell = known.grid().cell_m();
        let mut points = Vec::new();
        let _ = known.tree().visit_leaves_in(area, false, |_, b| {
            let (lo, hi) = (b.min.max(area.min), b.max.min(area.max));
            let inset = DVec2::splat((0.5 * cell).min(0.5 * (hi - lo).min_element()));
            let q = p.clamp(lo + inset, hi - inset);
            points.push((q, q.distance_squared(p)));
            std::ops::ControlFlow::Continue(())
        });
        let min = points.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
        let first = points.iter().find(|e| e.1 == min).map(|e| e.0);
        (first, points.iter().filter(|e| e.1 == min).count())
    }

    /// One pruned walk from nothing, without a first point near `p`: the reference.
    fn one_walk(known: &KnownMap, area: &Aabb, p: DVec2) -> Option<DVec2> {
        let cell = known.grid().cell_m();
        let best_d = std::cell::Cell::new(f64::INFINITY);
        let mut best = None;
        let pruned = super::NearerThan {
            area: *area,
            p,
            best: &best_d,
            z_order: false,
        };
        let _ = known.tree().visit_leaves_in(&pruned, false, |_, b| {
            let (lo, hi) = (b.min.max(area.min), b.max.min(area.max));
            let inset = DVec2::splat((0.5 * cell).min(0.5 * (hi - lo).min_element()));
            let q = p.clamp(lo + inset, hi - inset);
            let d = q.distance_squared(p);
            if d < best_d.get() {
                best_d.set(d);
                best = Some(q);
            }
            std::ops::ControlFlow::Continue(())
        });
        best
    }

    /// The nearest unknown point found from a first point near the robot is the one a
    /// whole walk finds (and as near as any, by brute force), ties included (robots and
    /// areas on whole and half cells, so that points at equal distances come up), on maps
    /// known in patches of every size.
    #[test]
    fn nearest_unknown_equals_a_whole_walk() {
        let (mut ties, mut found, mut tie_seeds) = (0, 0, 0);
        for seed in 0..40u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let side = [64u32, 128, 256][seed as usize % 3];
            let grid = Grid::new(DVec2::ZERO, 1.0, side, side).unwrap();
            let s = f64::from(side);
            let mut known = KnownMap::new(grid);
            for _ in 0..rng.random_range(0..40) {
                let c = DVec2::new(rng.random_range(0.0..s), rng.random_range(0.0..s));
                if rng.random_bool(0.5) {
                    known.mark_view(c, rng.random_range(1.0..20.0));
                } else {
                    let e = DVec2::new(rng.random_range(1.0..40.0), rng.random_range(1.0..40.0));
                    known.mark(&Aabb {
                        min: c,
                        max: (c + e).min(DVec2::splat(s)),
                    });
                }
            }
            let half = |rng: &mut rand_chacha::ChaCha8Rng| f64::from(rng.random_range(0..2 * side)) * 0.5;
            for _ in 0..200 {
                let (a, b) = (
                    DVec2::new(half(&mut rng), half(&mut rng)),
                    DVec2::new(half(&mut rng), half(&mut rng)),
                );
                let area = Aabb {
                    min: a.min(b),
                    max: a.max(b).max(a.min(b) + 0.5),
                };
                let p = if rng.random_bool(0.5) {
                    DVec2::new(half(&mut rng), half(&mut rng))
                } else {
                    DVec2::new(rng.random_range(-10.0..s + 10.0), rng.random_range(-10.0..s + 10.0))
                };
                let (any, nearest) = brute_force(&known, &area, p);
                let want = one_walk(&known, &area, p);
                assert_eq!(want.is_some(), any.is_some());
                if let (Some(w), Some(a)) = (want, any) {
                    assert_eq!(
                        w.distance_squared(p),
                        a.distance_squared(p),
                        "seed {seed}: a nearest point"
                    );
                }
                assert_eq!(nearest_unknown(&known, &area, p), want, "seed {seed}, {area:?}, {p}");
                // Whatever leaf the first point comes from, the whole walk ends the same;
                // leaves as near as the answer (ties) in particular.
                let mut leaves = Vec::new();
                let _ = known.tree().visit_leaves_in(&area, false, |sq, b| {
                    leaves.push((sq, b));
                    std::ops::ControlFlow::Continue(())
                });
                let nearest_d = want.map(|w| w.distance_squared(p));
                for (sq, b) in leaves {
                    let q = unknown_point(&known, &area, &b, p);
                    if Some(q.distance_squared(p)) != nearest_d && !rng.random_bool(0.2) {
                        continue;
                    }
                    let got = nearest_unknown_from(&known, &area, p, (sq, q, q.distance_squared(p)));
                    assert_eq!(Some(got), want, "seed {seed}, {area:?}, {p}, first point from {sq:?}");
                    tie_seeds +=
                        usize::from(want.is_some_and(|w| w != q && w.distance_squared(p) == q.distance_squared(p)));
                }
                found += usize::from(want.is_some());
                ties += usize::from(nearest > 1);
            }
        }
        assert!(
            found > 4000 && ties > 50 && tie_seeds > 50,
            "{found} found, {ties} ties, {tie_seeds} tied first points"
        );
    }

    /// A robot in a corridor whose route's next waypoint lies too near the wall for its disc:
    /// the first step heads there; held back, the next heads for the waypoint after it.
    #[test]
    fn a_robot_held_back_heads_for_a_later_waypoint_in_reach() {
        use crate::agent::TestWorld;
        use crate::spatial::Route;
        use crate::world::{Action, Outcome};
        let art = ["######", "#R...#", "######"].join("\n");
        let mut w = TestWorld::from_ascii(&art, 1.0).unwrap().knowing_all();
        let mut nav = super::Navigator::default();
        let (too_near, beyond) = (DVec2::new(2.5, 1.05), DVec2::new(4.5, 1.5));
        nav.follow(Route {
            nodes: Vec::new(),
            waypoints: vec![too_near, beyond],
            length_m: 0.0,
        });
        let first = nav.step(&mut w.ctx());
        assert_eq!(first, Some(Action::MoveTo { to: too_near }));
        // The wall stopped it where it stood.
        w.robot.last_action = (Action::MoveTo { to: too_near }, Outcome::Refused);
        assert_eq!(nav.step(&mut w.ctx()), Some(Action::MoveTo { to: beyond }));
        assert_eq!(nav.remaining(), &[beyond]);
    }

    /// Round a corner the straight leg would cut: the disc slides along the wall, on the
    /// axis that is free (here north, as east is the wall).
    #[test]
    fn a_robot_caught_on_a_corner_slides_along_the_wall() {
        use crate::agent::TestWorld;
        use crate::spatial::Route;
        use crate::world::{Action, Outcome};
        let art = ["#####", "#...#", "#R###", "#####"].join("\n");
        let mut w = TestWorld::from_ascii(&art, 1.0).unwrap().knowing_all();
        let mut nav = super::Navigator::default();
        let round_the_corner = DVec2::new(2.5, 2.5);
        nav.follow(Route {
            nodes: Vec::new(),
            waypoints: vec![round_the_corner],
            length_m: 0.0,
        });
        let _ = nav.step(&mut w.ctx());
        w.robot.last_action = (Action::MoveTo { to: round_the_corner }, Outcome::Trimmed);
        let p = w.robot.position;
        assert_eq!(w.ctx().can_move(p, round_the_corner), Some(false));
        assert_eq!(
            nav.step(&mut w.ctx()),
            Some(Action::MoveTo {
                to: DVec2::new(1.5, 2.5)
            })
        );
    }
}
