//! `excavator` and `transporter`.

use glam::DVec2;

use super::SHARE_EVERY;
use super::explorer::{Explorer, share_knowledge};
use crate::Result;
use crate::agent::{Ctx, Needs, Params, Strategy};
use crate::world::{Action, REACH_M, Sighting};

/// What workers perceive: everything but other robots, which they never look at (the
/// physical unit keeps bodies apart and the collision tactic handles being stuck). Issue 11:
/// in a crowd each worker filed hundreds of robots a round into a memory list it never read.
const WORKER_NEEDS: Needs = Needs {
    robots: false,
    ..Needs::ALL
};

/// The part excavators and transporters share: exploration, sharing and going places.
#[derive(serde::Serialize, serde::Deserialize)]
struct Worker {
    explorer: Explorer,
    share_every: u64,
    heading_to: Option<DVec2>,
    shared_area: f64,
}

impl Worker {
    fn new(p: &Params) -> Result<Self> {
        Ok(Self {
            explorer: Explorer::default(),
            share_every: p.u64_in("share_every", 10, SHARE_EVERY)?,
            heading_to: None,
            shared_area: 0.0,
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
        if let Some(a) = self.core.begin_round(ctx) {
            return a;
        }
        let Some(t) = Worker::nearest(ctx, |s| s.buried > 0) else {
            return self.core.explorer.explore_unclaimed(ctx);
        };
        if Worker::within_reach(ctx, t.position) {
            ctx.set_goal(Some(t.position));
            return Action::Excavate { treasure: t.treasure };
        }
        self.core.go(ctx, t.position)
    }
}

/// Fetches dug units and delivers them.
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
            return self.core.explorer.explore_unclaimed(ctx);
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

impl Excavator {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        p.only(&["share_every"])?;
        Ok(Self { core: Worker::new(p)? })
    }
}

impl Transporter {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        p.only(&["share_every"])?;
        Ok(Self { core: Worker::new(p)? })
    }
}
