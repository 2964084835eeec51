//! `frontier` and `cooperative`.

use glam::DVec2;

use super::claims::{self, Claim, Update};
use super::explorer::{Explorer, Sharing, share_knowledge};
use crate::agent::{Ctx, Needs, Strategy};
use crate::world::{Action, Payload};

thread_local! {
    /// A worker's buffer for a round's announcements.
    static UPDATES: std::cell::RefCell<Vec<Update>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// `frontier` and `cooperative`.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Frontier {
    core: Explorer,
    sharing: Option<Sharing>,
    /// Team mates' announced goals, with the round heard (forgotten after 50 rounds), in
    /// no order (see [`claims`](super::claims); as a hash map they cost 14 % of a
    /// `bench-1000` run, as a B-tree 15 %).
    claims: Vec<Claim>,
    announced: Option<DVec2>,
    shared_area: f64,
}

impl Frontier {
    pub(super) fn new(sharing: Option<Sharing>) -> Self {
        Self {
            core: Explorer::default(),
            sharing,
            claims: Vec::new(),
            announced: None,
            shared_area: 0.0,
        }
    }
}

impl Strategy for Frontier {
    crate::serde_state!();

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
        let mut radius = 0.0;
        if let Some(share) = self.sharing {
            share_knowledge(ctx, share.every_rounds, &mut self.shared_area);
            radius = share.avoid_radius_m;
            // Only claims near enough to matter are kept, so crowds stay cheap.
            let near = (4.0 * radius).max(20.0);
            let p = ctx.position();
            let round = ctx.round;
            // This round's announcements, in a buffer of the worker thread, not of the robot
            // (with a crowd of robots each hearing hundreds, spare copies per robot cost
            // megabytes; fresh ones each round, grown as they filled, put a tenth of a
            // crowded round in the allocator).
            let forget = round.is_multiple_of(10).then_some((p, near));
            UPDATES.with_borrow_mut(|updates| {
                updates.clear();
                updates.extend(ctx.messages().iter().filter_map(|m| match *m.payload {
                    Payload::Position { goal, .. } => Some((m.from.get(), goal.filter(|g| g.distance(p) <= near))),
                    _ => None,
                }));
                // Inboxes come in sender order; sort (stably: a sender's last word wins) if
                // not.
                if !updates.is_sorted_by_key(|u| u.0) {
                    updates.sort_by_key(|u| u.0);
                }
                // Old and far claims are forgotten every tenth round.
                if !updates.is_empty() || forget.is_some() || self.claims.len() > share.max_claims {
                    claims::update(&mut self.claims, updates, round, share.max_claims, forget);
                }
            });
        }
        if let Some(a) = self.core.reflexes(ctx) {
            return a;
        }
        let claims = &self.claims;
        let action = self.core.explore(ctx, || claims.iter().map(|c| c.1).collect(), radius);
        // Announce a goal only when it changes: claims stay cheap in crowds.
        if self.sharing.is_some() && ctx.goal() != self.announced {
            self.announced = ctx.goal();
            let goal = ctx.goal();
            ctx.broadcast(Payload::Position {
                position: ctx.position(),
                goal,
            });
        }
        action
    }
}
