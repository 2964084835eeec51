//! `tactics`: a strategy made of tactics named in the config.

use glam::DVec2;

use crate::Result;
use crate::agent::{Ctx, Needs, Params, Strategy, Tactic, TacticRegistry};
use crate::world::Action;

/// Tactics in priority order. Every tactic sees every round (so that those that count
/// rounds or listen to messages keep up); the first that suggests an action acts, and the
/// robot idles when none does. The goal, if the config gives one, is published every round
/// before the tactics run (`boundary` and `shortest_path` go to it).
pub(super) struct Composed {
    tactics: Vec<(String, Box<dyn Tactic>)>,
    goal: Option<DVec2>,
    needs: Needs,
}

impl Composed {
    /// `tactics="a,b,c"` (names in `registry`), `goal="X,Y"` (optional), and each
    /// tactic's parameters as `NAME.PARAM`.
    pub(super) fn from_params(p: &Params, registry: &TacticRegistry) -> Result<Self> {
        let list = p.text("tactics").unwrap_or_default();
        let names: Vec<&str> = list.split(',').map(str::trim).filter(|n| !n.is_empty()).collect();
        if names.is_empty() {
            return Err(crate::Error::InvalidParameter(format!(
                "parameter 'tactics' must name tactics in priority order, e.g. \"energy,collision,frontier\" (known: {})",
                registry.names().collect::<Vec<_>>().join(", ")
            )));
        }
        if let Some((k, _)) = p.iter().find(|(k, _)| {
            *k != "tactics" && *k != "goal" && !k.split_once('.').is_some_and(|(t, _)| names.contains(&t))
        }) {
            return Err(crate::Error::InvalidParameter(format!(
                "unknown parameter '{k}' (known: tactics, goal, and TACTIC.PARAM for a tactic listed in 'tactics')"
            )));
        }
        let goal = p.point("goal")?;
        // Built-in tactics that only follow a goal, and those that only react (to mates too
        // near, to a low battery): made of them alone, with no goal given, nothing would
        // ever set one and the robots would stand still.
        let followers = ["boundary", "shortest_path"];
        let reacting = ["collision", "energy"];
        if goal.is_none()
            && names.iter().any(|n| followers.contains(n))
            && names.iter().all(|n| followers.contains(n) || reacting.contains(n))
        {
            return Err(crate::Error::InvalidParameter(format!(
                "tactics {} go to a goal and none sets one: give goal=\"X,Y\" or add a tactic that sets goals (frontier, team)",
                names.join(", ")
            )));
        }
        let mut needs = Needs::NONE;
        let mut tactics = Vec::with_capacity(names.len());
        for name in names {
            let t = registry.create(name, &p.prefixed(name))?;
            needs = needs.union(t.needs());
            tactics.push((name.to_owned(), t));
        }
        Ok(Self { tactics, goal, needs })
    }
}

impl Strategy for Composed {
    fn needs(&self) -> Needs {
        self.needs
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        if let Some(g) = self.goal {
            ctx.set_goal(Some(g));
        }
        let mut chosen = None;
        for (_, t) in &mut self.tactics {
            let a = t.suggest(ctx);
            chosen = chosen.or(a);
        }
        chosen.unwrap_or(Action::Idle)
    }

    fn save_state(&self) -> Option<Vec<u8>> {
        let parts: Option<Vec<serde_bytes::ByteBuf>> = self
            .tactics
            .iter()
            .map(|(_, t)| t.save_state().map(serde_bytes::ByteBuf::from))
            .collect();
        crate::agent::save_state(&parts?)
    }

    fn restore_state(&mut self, state: &[u8]) -> Result<()> {
        let mut parts: Vec<serde_bytes::ByteBuf> = Vec::new();
        crate::agent::restore_state(&mut parts, state)?;
        if parts.len() != self.tactics.len() {
            return Err(crate::Error::InvalidParameter(format!(
                "the saved state holds {} tactics, this strategy {}",
                parts.len(),
                self.tactics.len()
            )));
        }
        for ((name, t), s) in self.tactics.iter_mut().zip(&parts) {
            t.restore_state(s)
                .map_err(|e| crate::Error::InvalidParameter(format!("tactic '{name}': {e}")))?;
        }
        Ok(())
    }
}
