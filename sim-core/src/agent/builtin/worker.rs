//! `excavator` and `transporter`.

use glam::DVec2;

use super::SHARE_EVERY;
use super::explorer::{Explorer, share_knowledge};
use super::spread::{Spread, SpreadParams};
use crate::Result;
use crate::agent::{Ctx, Needs, Params, Strategy};
use crate::spatial::{RobotId, TreasureId};
use crate::world::{Action, Payload, REACH_M, Sighting, Task};

/// What workers perceive: everything but other robots, which they never look at (the
/// physical unit keeps bodies apart and the collision tactic handles being stuck), so a
/// crowd's workers file no robots into a memory list they never read.
const WORKER_NEEDS: Needs = Needs {
    robots: false,
    ..Needs::ALL
};

/// Rounds a team mate's claim is kept after it was last heard. Claimants repeat theirs
/// every [`CLAIM_REPEAT_ROUNDS`] while they hold it, so one not heard again for this long
/// belongs to a robot that moved on or out of range.
const CLAIM_LIFETIME_ROUNDS: u64 = 30;

/// How often a worker repeats the claim it holds.
const CLAIM_REPEAT_ROUNDS: u64 = 10;

/// Team mates' claims remembered at most, the most recently heard (a scalable memory
/// list: a crowd's memory stays linear in its size).
const MAX_TREASURE_CLAIMS: usize = 64;

/// A team mate's [`Payload::Claim`] as heard.
#[derive(Clone, Copy, serde::Serialize, serde::Deserialize)]
struct HeardClaim {
    treasure: TreasureId,
    by: RobotId,
    distance_m: f32,
    heard_round: u64,
}

/// The part excavators and transporters share: exploration, sharing, claims on treasures
/// and going places.
///
/// A worker heads for the nearest treasure it knows that needs its task, leaving to a team
/// mate of the same task any treasure that mate claimed from nearer (ties to the lower id),
/// and claims its own choice: so the workers spread over the treasures they know, one of
/// each task per treasure, instead of crowding round the nearest one and blocking each
/// other. `an_excavator_leaves_a_treasure_claimed_from_nearer_to_its_claimant` and
/// `a_transporter_leaves_loose_units_claimed_from_nearer_to_its_claimant` (tests/workers.rs)
/// check it. In a large team it takes only treasures in its sector or near it, and waits at
/// its post when it has none (see [`Spread`]).
#[derive(serde::Serialize, serde::Deserialize)]
struct Worker {
    explorer: Explorer,
    share_every: u64,
    heading_to: Option<DVec2>,
    shared_area: f64,
    /// Team mates' claims for this worker's task: each robot's last word, in the order heard.
    #[serde(default)]
    claims: Vec<HeardClaim>,
    /// The treasure this worker claimed last, and the round it said so.
    #[serde(default)]
    claimed: Option<(TreasureId, u64)>,
    spread: Spread,
}

impl Worker {
    fn new(p: &Params, spread: SpreadParams) -> Result<Self> {
        Ok(Self {
            explorer: Explorer::default(),
            share_every: p.u64_in("share_every", 10, SHARE_EVERY)?,
            heading_to: None,
            shared_area: 0.0,
            claims: Vec::new(),
            claimed: None,
            spread: Spread::new(spread),
        })
    }

    /// Walk to `to` along a known route (planned once per destination). With no known
    /// route yet, explore: that is how the robot learns a way there.
    fn go(&mut self, ctx: &mut Ctx, to: DVec2) -> Action {
        if self.heading_to != Some(to) || self.explorer.frontier.navigator().is_idle() {
            self.heading_to = Some(to);
            if !self.explorer.frontier.navigator().go_to(ctx, to) {
                self.explorer.frontier.navigator().clear();
                self.heading_to = None;
                return self.explorer.explore_unclaimed(ctx);
            }
        }
        ctx.set_goal(Some(to));
        self.explorer
            .frontier
            .navigator()
            .step(ctx)
            .unwrap_or(Action::MoveTo { to })
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

    /// What every worker does first: hear team mates' claims for `task`, share what it
    /// knows, then let energy management and collision avoidance take over if they want to
    /// (dropping the current route).
    fn begin_round(&mut self, ctx: &mut Ctx, task: Task) -> Option<Action> {
        self.hear_claims(ctx, task);
        share_knowledge(ctx, self.share_every, &mut self.shared_area);
        let reflex = self.explorer.reflexes(ctx);
        if reflex.is_some() {
            self.heading_to = None;
        }
        reflex
    }

    /// Take in this round's claims for `task`, forgetting those not heard again in
    /// [`CLAIM_LIFETIME_ROUNDS`].
    fn hear_claims(&mut self, ctx: &Ctx, task: Task) {
        let round = ctx.round;
        self.claims.retain(|c| c.heard_round + CLAIM_LIFETIME_ROUNDS > round);
        for m in ctx.messages() {
            if let Payload::Claim {
                treasure,
                task: t,
                distance_m,
            } = m.payload
                && t == task
            {
                self.spread.heard(m.from);
                self.claims.retain(|c| c.by != m.from);
                self.claims.push(HeardClaim {
                    treasure,
                    by: m.from,
                    distance_m,
                    heard_round: round,
                });
            }
        }
        let excess = self.claims.len().saturating_sub(MAX_TREASURE_CLAIMS);
        self.claims.drain(..excess);
    }

    /// Whether a team mate claimed treasure `s` from nearer than this robot is now.
    fn left_to_others(&self, ctx: &Ctx, s: &Sighting) -> bool {
        let (me, d) = (ctx.me.id, ctx.position().distance(s.position) as f32);
        self.claims
            .iter()
            .any(|c| c.treasure == s.treasure && c.distance_m.total_cmp(&d).then(c.by.cmp(&me)).is_lt())
    }

    /// The remembered treasure nearest to the robot that `want` accepts, that is this
    /// worker's to take (see [`Spread::takes`]) and that no nearer team mate claimed.
    fn choose(&self, ctx: &Ctx, want: impl Fn(&Sighting) -> bool) -> Option<Sighting> {
        let takes = self.spread.takes(ctx);
        Self::nearest(ctx, |s| want(s) && takes(s.position) && !self.left_to_others(ctx, s))
    }

    /// Nothing to take: walk to the post (see [`Spread::post`]) and explore round it there.
    /// With no known route to the post, it explores for a few rounds before it searches
    /// again.
    fn stand_by(&mut self, ctx: &mut Ctx) -> Action {
        match self.spread.post(ctx) {
            Some(post) if !Spread::at(ctx, post) && self.spread.may_route_to(ctx, post) => {
                let action = self.go(ctx, post);
                if self.heading_to.is_none() {
                    self.spread.no_route_to(ctx, post);
                }
                action
            }
            _ => self.explorer.explore_unclaimed(ctx),
        }
    }

    /// Claim `t` for `task`: said when the choice changes and repeated every
    /// [`CLAIM_REPEAT_ROUNDS`] while it holds.
    fn claim(&mut self, ctx: &mut Ctx, task: Task, t: &Sighting) {
        if self
            .claimed
            .is_some_and(|(c, at)| c == t.treasure && ctx.round < at + CLAIM_REPEAT_ROUNDS)
        {
            return;
        }
        self.claimed = Some((t.treasure, ctx.round));
        ctx.broadcast(Payload::Claim {
            treasure: t.treasure,
            task,
            distance_m: ctx.position().distance(t.position) as f32,
        });
    }

    fn within_reach(ctx: &Ctx, p: DVec2) -> bool {
        ctx.position().distance(p) <= ctx.kind.radius_m + REACH_M
    }
}

/// Digs out known treasures, one excavator per treasure (see [`Worker`]).
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Excavator {
    core: Worker,
}

impl Strategy for Excavator {
    crate::serde_state!();

    fn needs(&self) -> Needs {
        WORKER_NEEDS
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.core.begin_round(ctx, Task::Excavate) {
            return a;
        }
        let Some(t) = self.core.choose(ctx, |s| s.buried > 0) else {
            return self.core.stand_by(ctx);
        };
        self.core.claim(ctx, Task::Excavate, &t);
        if Worker::within_reach(ctx, t.position) {
            ctx.set_goal(Some(t.position));
            return Action::Excavate { treasure: t.treasure };
        }
        self.core.go(ctx, t.position)
    }
}

/// Fetches dug units and delivers them, one transporter per treasure (see [`Worker`]).
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Transporter {
    core: Worker,
}

impl Strategy for Transporter {
    crate::serde_state!();

    fn needs(&self) -> Needs {
        WORKER_NEEDS
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(a) = self.core.begin_round(ctx, Task::Transport) {
            return a;
        }
        let load = ctx.me.load();
        let full = load >= ctx.kind.carry_capacity;
        // Loose units first; otherwise wait at a treasure still being dug.
        let pick = self
            .core
            .choose(ctx, |s| s.loose > 0)
            .or_else(|| self.core.choose(ctx, |s| s.buried > 0));
        // Deliver what it carries once no loose units it knows of are left to load: waiting
        // at buried treasures with a part load keeps units off the home for hundreds of
        // rounds (`a_transporter_with_a_part_load_and_nothing_loose_goes_home`).
        if load > 0 && (full || pick.is_none_or(|s| s.loose == 0)) {
            if ctx.home().contains(ctx.position()) {
                return Action::Unload;
            }
            return self.core.go(ctx, ctx.home().center());
        }
        let Some(t) = pick else {
            return self.core.stand_by(ctx);
        };
        self.core.claim(ctx, Task::Transport, &t);
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

/// The parameters both workers take.
const WORKER_PARAMS: [&str; 4] = ["share_every", "near_m", "sector_overlap", "post_behind_m"];

impl Excavator {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        p.only(&WORKER_PARAMS)?;
        let spread = SpreadParams::from_params(p, SpreadParams::EXCAVATOR)?;
        Ok(Self {
            core: Worker::new(p, spread)?,
        })
    }
}

impl Transporter {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        p.only(&WORKER_PARAMS)?;
        let spread = SpreadParams::from_params(p, SpreadParams::TRANSPORTER)?;
        Ok(Self {
            core: Worker::new(p, spread)?,
        })
    }
}
