//! The built-in strategies: `random_walk`, `frontier`, `cooperative`, `excavator`,
//! `transporter`.

use glam::DVec2;
use rand::Rng;

use super::{Ctx, Needs, Params, Strategy, StrategyRegistry};
use crate::messages::{Payload, Sighting};
use crate::model::{Action, REACH_M};
use crate::tactics::{BoundaryFollowing, CollisionAvoidance, EnergyManagement, Navigator, Tactic, Team, blocked};

/// Register every built-in strategy.
pub fn register_all(r: &mut StrategyRegistry) {
    r.register(
        "random_walk",
        "walks straight, turning at random and when blocked",
        |p| {
            p.only(&["turn_probability"])?;
            let turn_probability = p.f64_or("turn_probability", 0.05)?;
            if !(0.0..=1.0).contains(&turn_probability) {
                return Err(format!("turn_probability must be in [0, 1], got {turn_probability}"));
            }
            Ok(Box::new(RandomWalk {
                turn_probability,
                heading: None,
                coll: CollisionAvoidance::default(),
            }))
        },
    );
    r.register(
        "frontier",
        "frontier exploration: walks to the nearest boundary between known free space and the unknown",
        |p| {
            p.only(&[])?;
            Ok(Box::new(Frontier::new(None)))
        },
    );
    r.register(
        "cooperative",
        "frontier exploration that shares known maps and treasure sightings, and avoids team mates' goals",
        |p| {
            p.only(&["share_every", "avoid_radius_m"])?;
            let share = Sharing::from_params(p)?;
            Ok(Box::new(Frontier::new(Some(share))))
        },
    );
    r.register(
        "team",
        "explorers in groups: the lowest id in radio range leads (frontier exploration), the others follow it",
        |p| {
            p.only(&["spacing_m", "timeout_rounds"])?;
            let spacing_m = p.f64_or("spacing_m", 2.0)?;
            if spacing_m <= 0.0 {
                return Err(format!("spacing_m must be > 0, got {spacing_m}"));
            }
            Ok(Box::new(TeamExplorer {
                core: Explorer::default(),
                team: {
                    let mut team = Team::default();
                    team.spacing_m = spacing_m;
                    team.timeout_rounds = p.u64_or("timeout_rounds", 5)?;
                    team
                },
            }))
        },
    );
    r.register(
        "excavator",
        "goes to known treasures and digs them out; explores when it knows none",
        |p| {
            p.only(&["share_every"])?;
            Ok(Box::new(Excavator { core: Worker::new(p)? }))
        },
    );
    r.register(
        "transporter",
        "fetches dug units (waiting at treasures being dug) and delivers them home",
        |p| {
            p.only(&["share_every"])?;
            Ok(Box::new(Transporter { core: Worker::new(p)? }))
        },
    );
}

/// Walks straight; turns with `turn_probability` per round or when a move is refused.
struct RandomWalk {
    turn_probability: f64,
    heading: Option<DVec2>,
    coll: CollisionAvoidance,
}

impl Strategy for RandomWalk {
    fn needs(&self) -> Needs {
        Needs {
            known_map: true,
            robots: true,
            ..Needs::NONE
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.coll.suggest(ctx) {
            return a;
        }
        let turn = self.heading.is_none() || blocked(ctx) || ctx.rng.random_bool(self.turn_probability);
        if turn {
            self.heading = Some(DVec2::from_angle(ctx.rng.random_range(0.0..std::f64::consts::TAU)));
        }
        let h = self.heading.expect("set above");
        ctx.move_by(h * ctx.kind.speed_m_per_round)
    }
}

/// How a cooperative robot shares what it knows.
#[derive(Clone, Copy, Debug)]
struct Sharing {
    every_rounds: u64,
    avoid_radius_m: f64,
}

impl Sharing {
    fn from_params(p: &Params) -> Result<Self, String> {
        let every_rounds = p.u64_or("share_every", 10)?.max(1);
        let avoid_radius_m = p.f64_or("avoid_radius_m", 5.0)?;
        if avoid_radius_m < 0.0 {
            return Err(format!("avoid_radius_m must be ≥ 0, got {avoid_radius_m}"));
        }
        Ok(Self {
            every_rounds,
            avoid_radius_m,
        })
    }
}

/// Exploration of the nearest frontier, with energy management and collision avoidance.
#[derive(Default)]
struct Explorer {
    nav: Navigator,
    coll: CollisionAvoidance,
    energy: EnergyManagement,
    target: Option<DVec2>,
    /// Round of the last failed frontier search (retried every 20 rounds).
    failed_at: Option<u64>,
}

impl Explorer {
    /// Tactics that override everything: energy first, then collisions.
    fn reflexes(&mut self, ctx: &mut Ctx) -> Option<Action> {
        if let Some(a) = self.energy.suggest(ctx) {
            ctx.set_goal(Some(ctx.home().center()));
            return Some(a);
        }
        if let Some(a) = self.coll.suggest(ctx) {
            self.nav.clear();
            return Some(a);
        }
        None
    }

    /// One step of frontier exploration; `avoid` are goals taken by others.
    fn explore(&mut self, ctx: &mut Ctx, avoid: &[DVec2], avoid_radius_m: f64) -> Action {
        // Keep walking to a frontier target even once it is seen: the way on reveals more in
        // the same direction, and a new search only every few metres keeps planning cheap.
        // Re-plan on arrival, when the route is gone, or when the target was revealed from
        // close by.
        let p = ctx.position();
        let revealed_near = self
            .target
            .is_none_or(|t| ctx.known().is_some_and(|k| k.is_known(t)) && t.distance(p) < 0.5 * ctx.kind.view_radius_m);
        let need_plan = self.nav.is_idle() || revealed_near;
        if need_plan && self.failed_at.is_none_or(|r| ctx.round >= r + 20) {
            if let Some(route) = Navigator::frontier_route(ctx, avoid, avoid_radius_m)
                .or_else(|| Navigator::frontier_route(ctx, &[], 0.0))
            {
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
        if let Some(a) = self.nav.step(ctx) {
            return a;
        }
        // Nothing left to explore: go home and wait there.
        let home = ctx.home().center();
        if ctx.home().contains(ctx.position()) {
            Action::Idle
        } else if self.nav.go_to(ctx, home) {
            self.nav.step(ctx).unwrap_or(Action::Idle)
        } else {
            let dir = BoundaryFollowing::heading(ctx, home - ctx.position()).unwrap_or(DVec2::ZERO);
            ctx.move_by(dir)
        }
    }
}

/// `frontier` and `cooperative`.
struct Frontier {
    core: Explorer,
    sharing: Option<Sharing>,
    /// Team mates' announced goals, with the round heard (forgotten after 50 rounds).
    claims: std::collections::BTreeMap<u32, (DVec2, u64)>,
    announced: Option<DVec2>,
    shared_area: f64,
}

impl Frontier {
    fn new(sharing: Option<Sharing>) -> Self {
        Self {
            core: Explorer::default(),
            sharing,
            claims: std::collections::BTreeMap::new(),
            announced: None,
            shared_area: 0.0,
        }
    }
}

impl Strategy for Frontier {
    fn needs(&self) -> Needs {
        Needs {
            // Other robots are never looked at: the physical unit prevents collisions and
            // the collision tactic handles being stuck.
            robots: false,
            treasures: self.sharing.is_some(),
            messages: self.sharing.is_some(),
            ..Needs::ALL
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let mut avoid = Vec::new();
        let mut radius = 0.0;
        if let Some(share) = self.sharing {
            share_knowledge(ctx, share.every_rounds, &mut self.shared_area);
            radius = share.avoid_radius_m;
            // Only claims near enough to matter are kept, so crowds stay cheap.
            let near = (4.0 * radius).max(20.0);
            let p = ctx.position();
            for m in ctx.messages() {
                if let Payload::Position { goal, .. } = *m.payload {
                    match goal {
                        Some(g) if g.distance(p) <= near => self.claims.insert(m.from.0, (g, ctx.round)),
                        _ => self.claims.remove(&m.from.0),
                    };
                }
            }
            let round = ctx.round;
            if round.is_multiple_of(10) {
                self.claims
                    .retain(|_, (g, heard)| round <= *heard + 50 && g.distance(p) <= near);
            }
            avoid.extend(self.claims.values().map(|c| c.0));
        }
        if let Some(a) = self.core.reflexes(ctx) {
            return a;
        }
        let action = self.core.explore(ctx, &avoid, radius);
        // Announce a goal only when it changes: claims stay cheap in crowds.
        if self.sharing.is_some() && *ctx.goal != self.announced {
            self.announced = *ctx.goal;
            let goal = *ctx.goal;
            ctx.broadcast(Payload::Position {
                position: ctx.position(),
                goal,
            });
        }
        action
    }
}

/// Every `every` rounds (staggered by robot id): broadcast the known map if it grew by
/// half since it was last shared, and in any case every fifth time (maps of a crowd are
/// near-identical, and merging them costs receivers time for nothing), and all remembered
/// sightings. Other rounds: fresh
/// sightings, if any.
fn share_knowledge(ctx: &mut Ctx, every: u64, shared_area: &mut f64) {
    if (ctx.round + u64::from(ctx.me.id.0)).is_multiple_of(every) {
        let area = ctx.known().map_or(0.0, crate::known_map::KnownMap::known_area_m2);
        // Also every fifth time regardless, so robots met late still get the whole map.
        let refresh = ((ctx.round + u64::from(ctx.me.id.0)) / every).is_multiple_of(5);
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

/// The part excavators and transporters share: exploration, sharing and going places.
struct Worker {
    explorer: Explorer,
    share_every: u64,
    heading_to: Option<DVec2>,
    shared_area: f64,
}

impl Worker {
    fn new(p: &Params) -> Result<Self, String> {
        Ok(Self {
            explorer: Explorer::default(),
            share_every: p.u64_or("share_every", 10)?.max(1),
            heading_to: None,
            shared_area: 0.0,
        })
    }

    /// Walk to `to` along a known route (planned once per destination). With no known
    /// route yet, explore: that is how the robot learns a way there.
    fn go(&mut self, ctx: &mut Ctx, to: DVec2) -> Action {
        if self.heading_to != Some(to) || self.explorer.nav.is_idle() {
            self.heading_to = Some(to);
            if !self.explorer.nav.go_to(ctx, to) {
                self.explorer.nav.clear();
                self.heading_to = None;
                return self.explorer.explore(ctx, &[], 0.0);
            }
        }
        ctx.set_goal(Some(to));
        self.explorer.nav.step(ctx).unwrap_or(Action::MoveTo { to })
    }

    /// The remembered treasure nearest to the robot that `want` accepts.
    fn nearest(ctx: &Ctx, want: impl Fn(&Sighting) -> bool) -> Option<Sighting> {
        let p = ctx.position();
        ctx.data
            .treasures
            .iter()
            .map(|(s, _)| *s)
            .filter(|s| want(s))
            .min_by(|a, b| {
                a.position
                    .distance_squared(p)
                    .total_cmp(&b.position.distance_squared(p))
                    .then(a.treasure.cmp(&b.treasure))
            })
    }

    /// What every worker does first: share what it knows, then let energy management and
    /// collision avoidance take over if they want to (dropping the current route).
    fn begin_round(&mut self, ctx: &mut Ctx) -> Option<Action> {
        share_knowledge(ctx, self.share_every, &mut self.shared_area);
        let reflex = self.explorer.reflexes(ctx);
        if reflex.is_some() {
            self.heading_to = None;
        }
        reflex
    }

    fn within_reach(ctx: &Ctx, p: DVec2) -> bool {
        ctx.position().distance(p) <= ctx.kind.radius_m + REACH_M
    }
}

/// Digs out known treasures.
struct Excavator {
    core: Worker,
}

impl Strategy for Excavator {
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.core.begin_round(ctx) {
            return a;
        }
        let Some(t) = Worker::nearest(ctx, |s| s.buried > 0) else {
            return self.core.explorer.explore(ctx, &[], 0.0);
        };
        if Worker::within_reach(ctx, t.position) {
            ctx.set_goal(Some(t.position));
            return Action::Excavate { treasure: t.treasure };
        }
        self.core.go(ctx, t.position)
    }
}

/// Fetches dug units and delivers them.
struct Transporter {
    core: Worker,
}

impl Strategy for Transporter {
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.core.begin_round(ctx) {
            return a;
        }
        let load = ctx.me.load();
        let full = load >= ctx.kind.carry_capacity;
        // Loose units first; otherwise wait at a treasure still being dug.
        let pick = Worker::nearest(ctx, |s| s.loose > 0).or_else(|| Worker::nearest(ctx, |s| s.buried > 0));
        if load > 0 && (full || pick.is_none_or(|s| s.loose == 0 && load * 2 >= ctx.kind.carry_capacity)) {
            if ctx.home().contains(ctx.position()) {
                return Action::Unload;
            }
            return self.core.go(ctx, ctx.home().center());
        }
        let Some(t) = pick else {
            if load > 0 {
                return self.core.go(ctx, ctx.home().center());
            }
            return self.core.explorer.explore(ctx, &[], 0.0);
        };
        if Worker::within_reach(ctx, t.position) {
            ctx.set_goal(Some(t.position));
            return if t.loose > 0 {
                Action::Load { treasure: t.treasure }
            } else {
                Action::Idle
            };
        }
        self.core.go(ctx, t.position)
    }
}

/// Team behaviour: leaders explore frontiers, followers keep close to their leader; groups
/// form and break up as robots come into and out of radio range (events in the log).
struct TeamExplorer {
    core: Explorer,
    team: Team,
}

impl Strategy for TeamExplorer {
    fn needs(&self) -> Needs {
        Needs {
            treasures: false,
            ..Needs::ALL
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.core.reflexes(ctx) {
            return a;
        }
        let action = match self.team.suggest(ctx) {
            Some(follow) => follow,
            // A leader explores, at 60 % of its speed so that followers can keep up.
            None if self.team.leader().is_none() => match self.core.explore(ctx, &[], 0.0) {
                Action::MoveTo { to } => {
                    let p = ctx.position();
                    Action::MoveTo {
                        to: p + (to - p).clamp_length_max(0.6 * ctx.kind.speed_m_per_round),
                    }
                }
                other => other,
            },
            None => Action::Idle,
        };
        Team::announce(ctx);
        action
    }
}
