//! Energy management: keep a known way home, and go back in time.

use super::boundary::BoundaryFollowing;
use super::navigator::Navigator;
use super::{SEARCH_BUDGET, Tactic, blocked};
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::spatial::Route;
use crate::world::Action;

/// Keeps enough energy to get home along a known path: when what is left falls to the cost
/// of the way home plus a reserve, it takes over and walks home, then waits there until
/// recharged.
///
/// The way home is measured (a shortest route within the known map) once an excursion
/// starts, and again only when the energy left nears what it costs: in between, the last
/// measure plus the distance walked since bounds it from above (the robot can always walk
/// back the way it came), and while that bound leaves room, no route is searched.
/// `energy_management_bounds_the_way_home_between_measures` (tests/tactics.rs) checks that
/// the bound decides between measures.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct EnergyManagement {
    /// Extra energy kept beyond the way home, as a fraction of capacity (default 0.1).
    pub reserve_fraction: f64,
    /// Recharge until this fraction of capacity before leaving home again (default 0.95).
    pub leave_at_fraction: f64,
    /// Near the line, re-measure the way home at most every this many rounds (default 10);
    /// in between, the bound decides (erring on the side of turning back early).
    pub replan_every: u64,
    returning: bool,
    /// The last measured way home.
    home_route: Option<WayHome>,
    nav: Navigator,
    /// Rounds in a row its moves home were held back.
    held: u32,
}

/// A way home as measured: when, the route, and the robot's odometer then.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct WayHome {
    round: u64,
    route: Route,
    odometer_m: f64,
}

impl WayHome {
    /// An upper bound on the way home once the odometer reads `odometer_m`: this route plus
    /// the way back along what was walked since.
    fn bound_m(&self, odometer_m: f64) -> f64 {
        self.route.length_m + (odometer_m - self.odometer_m)
    }
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
            held: 0,
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

    /// At home: wait there until recharged if it came back to recharge (or is low),
    /// otherwise let the robot go and forget the last way home.
    fn at_home(&mut self, ctx: &Ctx) -> Option<Action> {
        let cap = ctx.kind.energy_capacity;
        if ctx.me.energy < self.leave_at_fraction * cap && (self.returning || ctx.me.energy < 0.5 * cap) {
            self.returning = true;
            self.nav.clear();
            return Some(Action::Idle);
        }
        self.returning = false;
        // The next excursion measures its way home afresh.
        self.home_route = None;
        None
    }

    /// The way home from where the robot stands: a shortest route within the known map, or
    /// one and a half times the straight line if there is none.
    fn measure(ctx: &Ctx) -> WayHome {
        let p = ctx.position();
        let target = ctx.home().center();
        let route = ctx
            .terrain()
            .and_then(|t| ctx.nav().route_within(t, p, target, SEARCH_BUDGET))
            .unwrap_or_else(|| Route {
                nodes: Vec::new(),
                waypoints: vec![target],
                length_m: 1.5 * p.distance(target),
            });
        WayHome {
            round: ctx.round,
            route,
            odometer_m: ctx.me.stats.distance_m,
        }
    }

    /// Away from home: measure the way home if this excursion has not yet, and turn back
    /// once the energy left falls to what the way home costs plus the reserve.
    fn check_way_home(&mut self, ctx: &Ctx) {
        let cap = ctx.kind.energy_capacity;
        let odometer = ctx.me.stats.distance_m;
        // Walking one more round away costs up to two rounds of travel on the way back.
        let margin = 2.0 * Self::cost(ctx, ctx.kind.speed_m_per_round);
        let needed = |length_m: f64| Self::cost(ctx, length_m) + margin + self.reserve_fraction * cap;
        let measured = self.home_route.get_or_insert_with(|| Self::measure(ctx));
        if !self.returning && ctx.me.energy <= needed(measured.bound_m(odometer)) {
            // Near the line: measure again, at most every `replan_every` rounds (in between,
            // the bound decides).
            if ctx.round >= measured.round + self.replan_every {
                *measured = Self::measure(ctx);
            }
            if ctx.me.energy <= needed(measured.bound_m(odometer)) {
                self.returning = true;
                // Home from here, not from where the way was last measured.
                if measured.round != ctx.round {
                    *measured = Self::measure(ctx);
                }
                self.nav.follow(measured.route.clone());
            }
        }
    }

    /// Walk home along the measured way, planning again from here when moves are held back
    /// twice in a row, and sliding along the obstacle after that.
    fn walk_home(&mut self, ctx: &mut Ctx) -> Action {
        let home = ctx.home();
        let p = ctx.position();
        self.held = if blocked(ctx) { self.held + 1 } else { 0 };
        if self.held == 2 {
            // The route was planned from elsewhere (or its next leg is too tight for this
            // body): plan again from here.
            self.nav.clear();
            if let Some(route) = ctx
                .terrain()
                .and_then(|t| ctx.nav().route_within(t, p, home.center(), SEARCH_BUDGET))
            {
                self.home_route = Some(WayHome {
                    round: ctx.round,
                    route,
                    odometer_m: ctx.me.stats.distance_m,
                });
            }
        }
        if self.nav.is_idle() {
            let route = self.home_route.as_ref().expect("measured above").route.clone();
            self.nav.follow(route);
        }
        let step = self.nav.step(ctx).unwrap_or(Action::MoveTo { to: home.center() });
        if self.held >= 3
            && let Action::MoveTo { to } = step
        {
            // Still held back: slide along whatever is in the way towards the waypoint.
            let dir = BoundaryFollowing::heading(ctx, to - p).unwrap_or(to - p);
            return ctx.move_by(dir * ctx.kind.speed_m_per_round);
        }
        step
    }
}

impl Tactic for EnergyManagement {
    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    crate::serde_state!();

    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        if ctx.home().contains(ctx.position()) {
            return self.at_home(ctx);
        }
        self.check_way_home(ctx);
        if self.returning {
            return Some(self.walk_home(ctx));
        }
        None
    }
}
