//! Tactics (paper §4.3): reusable local procedures any strategy can call.
//!
//! A [`Tactic`] watches the situation and, when it wants to act, *suggests* the action
//! (the paper's `hasAction()` / `performAction()`). Built in: [`CollisionAvoidance`] (robots
//! and obstacles, with stuck detection), [`EnergyManagement`] (keep a path home; go back in
//! time; recharge), [`BoundaryFollowing`] (slide along an obstacle), [`Navigator`] (shortest
//! paths on the navigation graph within known terrain, and frontier search) and [`Team`]
//! (forming, following and breaking up groups).

use glam::DVec2;
use rand::Rng;

use crate::geometry::Aabb;
use crate::messages::Payload;
use crate::model::{Action, Outcome};
use crate::nav::Route;
use crate::observer::StrategyEvent;
use crate::robot_index::RobotId;
use crate::strategy::Ctx;

/// A local procedure that may take over a round.
pub trait Tactic: Send {
    /// The action this tactic wants now, if any.
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action>;
}

/// Nodes a single search may settle (bounds the cost of one plan).
pub const SEARCH_BUDGET: usize = 50_000;

/// Escapes when a robot has been stuck (moves refused or trimmed to nothing, by walls or
/// other robots) for `patience_rounds`: it heads off in a random free direction for
/// `escape_rounds`, then the strategy takes over again. (Overlaps themselves can never
/// happen: the physical unit refuses them.)
#[derive(Clone, Debug)]
pub struct CollisionAvoidance {
    /// Rounds without progress before escaping (default 3).
    pub patience_rounds: u32,
    /// Rounds an escape lasts (default 3).
    pub escape_rounds: u32,
    stuck: u32,
    escaping: u32,
    heading: DVec2,
    last_position: Option<DVec2>,
}

impl Default for CollisionAvoidance {
    fn default() -> Self {
        Self {
            patience_rounds: 3,
            escape_rounds: 3,
            stuck: 0,
            escaping: 0,
            heading: DVec2::X,
            last_position: None,
        }
    }
}

impl CollisionAvoidance {
    /// Whether the robot has stopped making progress.
    pub fn is_stuck(&self) -> bool {
        self.stuck >= self.patience_rounds
    }
}

impl Tactic for CollisionAvoidance {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let p = ctx.position();
        let moved = self.last_position.map_or(f64::INFINITY, |q| q.distance(p));
        self.last_position = Some(p);
        // Held back by a wall or a robot; standing still by choice is not being stuck.
        let held_back = matches!(
            ctx.me.last_action,
            (Action::MoveTo { .. }, Outcome::Trimmed | Outcome::Refused)
        );
        if held_back && moved < 0.01 * ctx.kind.speed_m_per_round {
            self.stuck += 1;
        } else {
            self.stuck = 0;
        }
        if self.is_stuck() && self.escaping == 0 {
            self.escaping = self.escape_rounds;
            self.stuck = 0;
            self.heading = random_free_heading(ctx).unwrap_or(-self.heading);
        }
        if self.escaping > 0 {
            self.escaping -= 1;
            let to = p + self.heading * ctx.kind.speed_m_per_round;
            if ctx.can_move(p, to) == Some(false) {
                self.heading = random_free_heading(ctx).unwrap_or(-self.heading);
            }
            return Some(Action::MoveTo {
                to: p + self.heading * ctx.kind.speed_m_per_round,
            });
        }
        None
    }
}

fn random_free_heading(ctx: &mut Ctx) -> Option<DVec2> {
    let p = ctx.position();
    let step = ctx.kind.speed_m_per_round;
    let start = ctx.rng.random_range(0.0..std::f64::consts::TAU);
    (0..12)
        .map(|i| DVec2::from_angle(start + f64::from(i) * std::f64::consts::TAU / 12.0))
        .find(|h| ctx.can_move(p, p + *h * step) != Some(false))
}

/// Slides along an obstacle: when the desired heading is blocked, turns (to the left) in
/// steps of 30° until the way is free in known terrain.
#[derive(Clone, Debug, Default)]
pub struct BoundaryFollowing;

impl BoundaryFollowing {
    /// A free heading as close as possible to `desired`, turning left; `None` if boxed in.
    pub fn heading(ctx: &Ctx, desired: DVec2) -> Option<DVec2> {
        let p = ctx.position();
        let step = ctx.kind.speed_m_per_round;
        let desired = desired.try_normalize()?;
        (0..12)
            .map(|i| DVec2::from_angle(f64::from(i) * std::f64::consts::TAU / 12.0).rotate(desired))
            .find(|h| ctx.can_move(p, p + *h * step) == Some(true))
    }
}

/// Keeps enough energy to get home along a known path: when what is left falls to the cost
/// of the way home plus a reserve, it takes over and walks home, then waits there until
/// recharged.
#[derive(Clone, Debug)]
pub struct EnergyManagement {
    /// Extra energy kept beyond the way home, as a fraction of capacity (default 0.1).
    pub reserve_fraction: f64,
    /// Recharge until this fraction of capacity before leaving home again (default 0.95).
    pub leave_at_fraction: f64,
    /// Re-measure the way home every this many rounds (default 10).
    pub replan_every: u64,
    returning: bool,
    home_route: Option<(u64, Route)>,
    nav: Navigator,
}

impl Default for EnergyManagement {
    fn default() -> Self {
        Self {
            reserve_fraction: 0.1,
            leave_at_fraction: 0.95,
            replan_every: 10,
            returning: false,
            home_route: None,
            nav: Navigator::default(),
        }
    }
}

impl EnergyManagement {
    /// Whether it is taking the robot home.
    pub fn is_returning(&self) -> bool {
        self.returning
    }

    /// Energy needed to walk `length_m` and pay idle and sensing costs on the way.
    fn cost(ctx: &Ctx, length_m: f64) -> f64 {
        let k = ctx.kind;
        let rounds = length_m / k.speed_m_per_round.max(1e-9) + 1.0;
        length_m * k.energy_per_m + rounds * (k.energy_idle + k.energy_per_sense)
    }
}

impl Tactic for EnergyManagement {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let home = ctx.home();
        let p = ctx.position();
        let cap = ctx.kind.energy_capacity;
        if home.contains(p) {
            if ctx.me.energy < self.leave_at_fraction * cap && (self.returning || ctx.me.energy < 0.5 * cap) {
                self.returning = true;
                self.nav.clear();
                return Some(Action::Idle);
            }
            self.returning = false;
            return None;
        }
        let stale = self
            .home_route
            .as_ref()
            .is_none_or(|(at, _)| ctx.round >= at + self.replan_every);
        if stale {
            let target = home.center();
            let route = ctx
                .known()
                .and_then(|k| ctx.nav().route_within(k, p, target, SEARCH_BUDGET))
                .unwrap_or_else(|| Route {
                    nodes: Vec::new(),
                    waypoints: vec![target],
                    length_m: 1.5 * p.distance(target),
                });
            self.home_route = Some((ctx.round, route));
        }
        let (_, route) = self.home_route.as_ref().expect("planned above");
        // Walking one more round away costs up to two rounds of travel on the way back.
        let margin = 2.0 * Self::cost(ctx, ctx.kind.speed_m_per_round);
        if !self.returning && ctx.me.energy <= Self::cost(ctx, route.length_m) + margin + self.reserve_fraction * cap {
            self.returning = true;
            self.nav.follow(route.clone());
        }
        if self.returning {
            if self.nav.is_idle() {
                let route = self.home_route.as_ref().expect("planned").1.clone();
                self.nav.follow(route);
            }
            return Some(self.nav.step(ctx).unwrap_or(Action::MoveTo { to: home.center() }));
        }
        None
    }
}

/// Follows routes on the navigation graph, waypoint by waypoint, and finds frontiers.
#[derive(Clone, Debug, Default)]
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
            .known()
            .and_then(|k| ctx.nav().route_within(k, ctx.position(), to, SEARCH_BUDGET));
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

    /// Route to the nearest frontier (by path): the closest free leaf the known map touches
    /// that is either partly unknown (the route ends at its nearest unknown point) or borders
    /// a free leaf not known at all (the route ends just across their shared edge). Targets
    /// within `avoid_radius_m` of a point in `avoid` (team mates' goals) are skipped.
    pub fn frontier_route(ctx: &Ctx, avoid: &[DVec2], avoid_radius_m: f64) -> Option<Route> {
        let known = ctx.known()?;
        let nav = ctx.nav();
        let p = ctx.position();
        let step_in = 0.5 * known.grid().cell_m();
        let clear = |t: DVec2| avoid.iter().all(|a| a.distance(t) > avoid_radius_m);
        nav.search(
            p,
            |n| known.touches_square(nav.square(n)),
            |n| {
                if !known.covers_square(nav.square(n)) {
                    return nearest_unknown(known, &nav.bounds(n), p).filter(|t| clear(*t));
                }
                nav.neighbors(n)
                    .filter(|&m| !known.touches_square(nav.square(m)))
                    .map(|m| {
                        let portal = nav.portal(n, m);
                        let inward = (nav.bounds(m).center() - portal).normalize_or_zero();
                        portal + inward * step_in
                    })
                    .find(|t| clear(*t))
            },
            SEARCH_BUDGET,
        )
    }
}

/// The unknown point of `area` nearest to `p`, nudged a little into the unknown cell.
fn nearest_unknown(known: &crate::known_map::KnownMap, area: &Aabb, p: DVec2) -> Option<DVec2> {
    let cell = known.grid().cell_m();
    let mut best: Option<(f64, DVec2)> = None;
    let _ = known.tree().visit_leaves_in(area, false, |_, b| {
        let lo = b.min.max(area.min);
        let hi = b.max.min(area.max);
        // Aim a little inside the unknown box so reaching it reveals it.
        let inset = DVec2::splat((0.5 * cell).min(0.5 * (hi - lo).min_element()));
        let q = p.clamp(lo + inset, hi - inset);
        let d = q.distance_squared(p);
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, q));
        }
        std::ops::ControlFlow::Continue(())
    });
    best.map(|(_, q)| q)
}

/// Team behaviour: robots of the same type that hear each other form a group led by the
/// lowest id in range; followers keep to their own slot `spacing_m` from the leader; the group breaks up
/// when the leader has not been heard for `timeout_rounds`.
#[derive(Clone, Debug)]
pub struct Team {
    /// Distance followers keep from the leader (default 2 m).
    pub spacing_m: f64,
    /// Rounds without news from the leader before a follower leaves (default 5).
    pub timeout_rounds: u64,
    leader: Option<(RobotId, DVec2, u64)>,
}

impl Default for Team {
    fn default() -> Self {
        Self {
            spacing_m: 2.0,
            timeout_rounds: 5,
            leader: None,
        }
    }
}

impl Team {
    /// The current leader, if this robot follows one.
    pub fn leader(&self) -> Option<RobotId> {
        self.leader.map(|l| l.0)
    }

    /// Announce own position (call every round from strategies that team up).
    pub fn announce(ctx: &mut Ctx) {
        let goal = *ctx.goal;
        ctx.broadcast(Payload::Position {
            position: ctx.position(),
            goal,
        });
    }
}

impl Tactic for Team {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let my_type = ctx.me.type_index;
        let me = ctx.me.id;
        let before = self.leader.map(|l| l.0);
        for m in ctx.messages() {
            if let Payload::Position { position, .. } = *m.payload
                && m.from < me
                && self.leader.is_none_or(|(l, _, _)| m.from <= l)
            {
                let same_type = ctx
                    .robots_in_view()
                    .iter()
                    .find(|r| r.id == m.from)
                    .is_none_or(|r| r.type_index == my_type);
                if same_type {
                    self.leader = Some((m.from, position, ctx.round));
                }
            }
        }
        if let Some((leader, _, heard)) = self.leader
            && ctx.round > heard + self.timeout_rounds
        {
            self.leader = None;
            ctx.report(StrategyEvent::LeftGroup(leader));
        }
        if self.leader.map(|l| l.0) != before
            && let Some((new, _, _)) = self.leader
        {
            if let Some(old) = before {
                ctx.report(StrategyEvent::LeftGroup(old));
            }
            ctx.report(StrategyEvent::JoinedGroup(new));
        }
        let (_, at, _) = self.leader?;
        // Each follower keeps its own slot around the leader (golden-angle spread by id), so
        // followers do not queue for the same spot.
        let slot = at + DVec2::from_angle(f64::from(me.0) * 2.399_963_229_728_653) * self.spacing_m;
        if ctx.position().distance(slot) > 0.25 * self.spacing_m {
            return Some(Action::MoveTo { to: slot });
        }
        None
    }
}

/// Whether a refused or trimmed move suggests the way is blocked.
pub fn blocked(ctx: &Ctx) -> bool {
    matches!(
        ctx.me.last_action,
        (Action::MoveTo { .. }, Outcome::Refused | Outcome::Trimmed)
    )
}
