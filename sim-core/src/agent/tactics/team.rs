//! Team behaviour: forming, following and breaking up groups.

use glam::DVec2;

use super::Tactic;
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::spatial::RobotId;
use crate::world::{Action, Payload, StrategyEvent};

/// Team behaviour: robots of the same type that hear each other form a group led by the
/// lowest id in range; followers keep to their own slot `spacing_m` from the leader; the
/// group breaks up when the leader has not been heard for `timeout_rounds`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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
        let goal = ctx.goal();
        ctx.broadcast(Payload::Position {
            position: ctx.position(),
            goal,
        });
    }
}

impl Tactic for Team {
    fn needs(&self) -> Needs {
        Needs {
            robots: true,
            messages: true,
            ..Needs::NONE
        }
    }

    crate::serde_state!();

    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let my_type = ctx.me.type_index;
        let me = ctx.me.id;
        let before = self.leader.map(|l| l.0);
        for m in ctx.messages() {
            if let Payload::Position { position, .. } = m.payload
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
            && ctx.round.saturating_sub(heard) > self.timeout_rounds
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
        let slot = at + DVec2::from_angle(f64::from(me.get()) * 2.399_963_229_728_653) * self.spacing_m;
        if ctx.position().distance(slot) > 0.25 * self.spacing_m {
            return Some(Action::MoveTo { to: slot });
        }
        None
    }
}

/// [`Team`] as a tactic by name (`team`): it also announces the robot's position every
/// round (what a strategy using [`Team`] directly does with [`Team::announce`]), so a
/// strategy composed of tactics needs nothing else to team up.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Teaming(pub Team);

impl Tactic for Teaming {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let action = self.0.suggest(ctx);
        Team::announce(ctx);
        action
    }

    fn needs(&self) -> Needs {
        self.0.needs()
    }

    crate::serde_state!();
}
