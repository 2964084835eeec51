//! Shortest paths on the navigation graph within known terrain, and frontier search.

use std::cell::{Cell, RefCell};

use glam::DVec2;

use super::SEARCH_BUDGET;
use crate::agent::ctx::Ctx;
use crate::spatial::{Aabb, Frontier, KnownMap, NavNodeId, Overlap, PieceMemo, Route, Shape};
use crate::world::Action;

/// Follows routes on the navigation graph, waypoint by waypoint, and finds frontiers.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Navigator {
    waypoints: Vec<DVec2>,
    next: usize,
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

    /// Plan a shortest route to `to` within known terrain and follow it.
    pub fn go_to(&mut self, ctx: &Ctx, to: DVec2) -> bool {
        let route = ctx
            .terrain()
            .and_then(|t| ctx.nav().route_within(t, ctx.position(), to, SEARCH_BUDGET));
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
        let route = ctx
            .terrain()
            .and_then(|t| ctx.nav().route_optimistic(t, ctx.position(), to, SEARCH_BUDGET));
        match route {
            Some(r) => {
                self.follow(r);
                true
            }
            None => false,
        }
    }

    /// The move towards the next waypoint (skipping those already reached).
    pub fn step(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let p = ctx.position();
        let tol = 0.05;
        while self.next < self.waypoints.len() && self.waypoints[self.next].distance(p) <= tol {
            self.next += 1;
        }
        let target = *self.waypoints.get(self.next)?;
        ctx.set_path(self.remaining());
        Some(Action::MoveTo { to: target })
    }

    /// Route to the nearest frontier (by path): the closest piece of free space the known map
    /// touches that is either partly unknown (the route ends at its nearest unknown point) or
    /// borders a piece not known at all (the route ends just across their shared edge).
    /// Targets within `avoid_radius_m` of a point in `avoid` (team mates' goals) are skipped.
    ///
    /// With `frontier` (the robot's [`Frontier`], synced with its known map) the search asks
    /// the set whether a node is a frontier before asking the map; without, it asks the map
    /// of each node it reaches. The route is the same either way. The built-in explorers
    /// search without: keeping the set costs more than it saves when the frontier is near,
    /// as it mostly is (BENCHMARKS.md, "Navigation").
    pub fn frontier_route(
        ctx: &Ctx,
        frontier: Option<&Frontier>,
        avoid: &[DVec2],
        avoid_radius_m: f64,
    ) -> Option<Route> {
        Self::frontier_route_memo(ctx, &mut PieceMemo::default(), frontier, avoid, avoid_radius_m)
    }

    /// [`frontier_route`](Self::frontier_route) that remembers, in `memo`, which pieces the
    /// robot's known map touches and covers (a strategy keeps one per robot: its next
    /// search asks about much the same pieces). The route is the same.
    pub fn frontier_route_memo(
        ctx: &Ctx,
        memo: &mut PieceMemo,
        frontier: Option<&Frontier>,
        avoid: &[DVec2],
        avoid_radius_m: f64,
    ) -> Option<Route> {
        let terrain = ctx.terrain()?;
        let known = terrain.known;
        let nav = ctx.nav();
        let p = ctx.position();
        let step_in = 0.5 * known.grid().cell_m();
        let clear = |t: DVec2| avoid.iter().all(|a| a.distance(t) > avoid_radius_m);
        // The goal test of a node asks its neighbours whether the known map touches them,
        // and the search asks again right after, when it expands the node: the answers are
        // kept in between (a "no" is not in the memo).
        let touched: RefCell<Vec<(NavNodeId, bool)>> = RefCell::new(Vec::new());
        let memo = RefCell::new(memo);
        let touches = |m: NavNodeId| memo.borrow_mut().touched(nav, known, m);
        nav.search(
            p,
            terrain,
            |m| {
                let hit = touched.borrow().iter().find(|e| e.0 == m).map(|e| e.1);
                hit.unwrap_or_else(|| touches(m))
            },
            |n| {
                touched.borrow_mut().clear();
                if frontier.is_some_and(|f| !f.contains(n)) {
                    return None;
                }
                if !memo.borrow_mut().covered(nav, known, n) {
                    return nearest_unknown(known, &nav.bounds(n), p).filter(|t| clear(*t));
                }
                let mut cache = touched.borrow_mut();
                let mut found = None;
                for m in nav.neighbors(n) {
                    let t = touches(m);
                    cache.push((m, t));
                    if t || found.is_some() {
                        continue;
                    }
                    let portal = nav.portal(n, m);
                    let inward = (nav.bounds(m).center() - portal).normalize_or_zero();
                    found = Some(portal + inward * step_in).filter(|t| clear(*t));
                }
                found
            },
            SEARCH_BUDGET,
        )
    }
}

/// The unknown point of `area` nearest to `p`, nudged a little into the unknown cell.
fn nearest_unknown(known: &KnownMap, area: &Aabb, p: DVec2) -> Option<DVec2> {
    let cell = known.grid().cell_m();
    let best_d = Cell::new(f64::INFINITY);
    let mut best: Option<DVec2> = None;
    let pruned = NearerThan {
        area: *area,
        p,
        best: &best_d,
    };
    let _ = known.tree().visit_leaves_in(&pruned, false, |_, b| {
        let lo = b.min.max(area.min);
        let hi = b.max.min(area.max);
        // Aim a little inside the unknown box so reaching it reveals it.
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

/// `area`, minus the boxes whose part in `area` lies farther from `p` than the best
/// distance found so far: their leaves cannot win (issue 11: the search scanned every
/// unknown leaf of a large free node). Only strictly farther boxes are cut, so ties resolve
/// as in a full scan (first visited wins) and the result is the same.
struct NearerThan<'a> {
    area: Aabb,
    p: DVec2,
    best: &'a Cell<f64>,
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

    fn bounds(&self) -> Aabb {
        self.area
    }
}
