//! `team`.

use super::explorer::Explorer;
use crate::Result;
use crate::agent::tactics::team_from_params;
use crate::agent::{Ctx, Needs, Params, Strategy, Tactic, Team};
use crate::world::Action;

/// Team behaviour: leaders explore frontiers, followers keep close to their leader; groups
/// form and break up as robots come into and out of radio range (events in the log).
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct TeamExplorer {
    core: Explorer,
    team: Team,
}

impl Strategy for TeamExplorer {
    crate::serde_state!();

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
            None if self.team.leader().is_none() => match self.core.explore_unclaimed(ctx) {
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

impl TeamExplorer {
    pub(super) fn from_params(p: &Params) -> Result<Self> {
        Ok(Self {
            core: Explorer::default(),
            team: team_from_params(p)?,
        })
    }
}
