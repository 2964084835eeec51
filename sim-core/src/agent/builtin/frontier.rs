//! `frontier` and `cooperative`.

use std::collections::HashMap;

use glam::DVec2;

use super::explorer::{Explorer, Sharing, share_knowledge};
use crate::agent::{Ctx, Needs, Strategy};
use crate::world::{Action, Payload};

/// Team mates' goals by robot id, with the round heard.
type Claims = HashMap<u32, (DVec2, u64), foldhash::fast::FixedState>;

/// [`Claims`] as a list sorted by robot id.
mod sorted_claims {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::Claims;

    pub(super) fn serialize<S: Serializer>(claims: &Claims, s: S) -> Result<S::Ok, S::Error> {
        let mut list: Vec<_> = claims.iter().collect();
        list.sort_unstable_by_key(|(k, _)| **k);
        list.serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Claims, D::Error> {
        let list = Vec::<(u32, (glam::DVec2, u64))>::deserialize(d)?;
        Ok(list.into_iter().collect())
    }
}

/// `frontier` and `cooperative`.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Frontier {
    core: Explorer,
    sharing: Option<Sharing>,
    /// Team mates' announced goals, with the round heard (forgotten after 50 rounds). A
    /// fast fixed-seed hash map: in a crowd hundreds arrive a round, and only their set
    /// matters (goals near any of them are avoided), not their order. (A B-tree here cost
    /// 15 % of a `bench-1000` round.) Checkpoints store them sorted by robot id, so that
    /// equal states save to equal bytes whatever the map's history.
    #[serde(with = "sorted_claims")]
    claims: Claims,
    announced: Option<DVec2>,
    shared_area: f64,
}

impl Frontier {
    pub(super) fn new(sharing: Option<Sharing>) -> Self {
        Self {
            core: Explorer::default(),
            sharing,
            claims: Claims::default(),
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
            for m in ctx.messages() {
                if let Payload::Position { goal, .. } = *m.payload {
                    match goal {
                        Some(g) if g.distance(p) <= near => self.claims.insert(m.from.get(), (g, ctx.round)),
                        _ => self.claims.remove(&m.from.get()),
                    };
                }
            }
            let round = ctx.round;
            if round.is_multiple_of(10) {
                self.claims
                    .retain(|_, (g, heard)| round <= *heard + 50 && g.distance(p) <= near);
            }
        }
        if let Some(a) = self.core.reflexes(ctx) {
            return a;
        }
        let claims = &self.claims;
        let action = self
            .core
            .explore(ctx, || claims.values().map(|c| c.0).collect(), radius);
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
