//! What a round leaves behind besides the state: its events, message links and metrics.

use crate::spatial::RobotId;
use crate::spatial::TreasureId;
use crate::world::metrics::RoundMetrics;

/// Something notable that happened in a round.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A robot ran out of energy and is disabled for good.
    RobotDisabled {
        /// The robot.
        robot: RobotId,
    },
    /// A robot's strategy failed (it panicked): the robot is disabled for good, the run
    /// goes on.
    StrategyFailed {
        /// The robot.
        robot: RobotId,
        /// What went wrong (the panic's message).
        reason: String,
    },
    /// A treasure was seen for the first time.
    TreasureFound {
        /// The treasure.
        treasure: TreasureId,
        /// Who saw it.
        by: RobotId,
    },
    /// The last buried unit of a treasure was dug.
    TreasureExcavated {
        /// The treasure.
        treasure: TreasureId,
        /// Who dug the last unit.
        by: RobotId,
    },
    /// The last unit of a treasure was delivered home.
    TreasureDelivered {
        /// The treasure.
        treasure: TreasureId,
        /// Who delivered the last unit.
        by: RobotId,
    },
    /// The whole free area has been explored.
    MapExplored,
    /// A robot joined the group of a leader (team behaviour).
    GroupJoined {
        /// The follower.
        robot: RobotId,
        /// The leader.
        leader: RobotId,
    },
    /// A robot left its leader's group (the leader went out of range or silent).
    GroupLeft {
        /// The former follower.
        robot: RobotId,
        /// The former leader.
        leader: RobotId,
    },
    /// Something a strategy chose to report.
    Note {
        /// The robot.
        robot: RobotId,
        /// What it says.
        text: String,
    },
}

/// What a strategy may report through `Ctx::report` (in the agent layer).
#[derive(Clone, Debug, PartialEq)]
pub enum StrategyEvent {
    /// This robot now follows `leader`.
    JoinedGroup(RobotId),
    /// This robot stopped following `leader`.
    LeftGroup(RobotId),
    /// Free text for the event log.
    Note(String),
}

impl StrategyEvent {
    /// The kernel event for robot `robot`.
    pub fn into_event(self, robot: RobotId) -> Event {
        match self {
            StrategyEvent::JoinedGroup(leader) => Event::GroupJoined { robot, leader },
            StrategyEvent::LeftGroup(leader) => Event::GroupLeft { robot, leader },
            StrategyEvent::Note(text) => Event::Note { robot, text },
        }
    }
}

impl std::fmt::Display for Event {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Event::RobotDisabled { robot } => write!(f, "robot {robot} is out of energy and disabled"),
            Event::StrategyFailed { robot, reason } => write!(f, "robot {robot} is disabled: {reason}"),
            Event::TreasureFound { treasure, by } => write!(f, "treasure {treasure} found by robot {by}"),
            Event::TreasureExcavated { treasure, by } => {
                write!(f, "treasure {treasure} fully excavated by robot {by}")
            }
            Event::TreasureDelivered { treasure, by } => {
                write!(f, "treasure {treasure} fully delivered by robot {by}")
            }
            Event::MapExplored => write!(f, "the whole free area is explored"),
            Event::GroupJoined { robot, leader } => {
                write!(f, "robot {robot} joined the group of robot {leader}")
            }
            Event::GroupLeft { robot, leader } => write!(f, "robot {robot} left the group of robot {leader}"),
            Event::Note { robot, text } => write!(f, "robot {robot}: {text}"),
        }
    }
}

/// A message delivery of the round: `from` reached `to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Link {
    /// Sender.
    pub from: RobotId,
    /// Receiver.
    pub to: RobotId,
}

/// What happened in one round, besides the state itself.
#[derive(Clone, Debug, Default)]
pub struct RoundReport {
    /// The round (1-based).
    pub round: u64,
    /// Metrics after the round.
    pub metrics: RoundMetrics,
    /// Events, in the order they happened.
    pub events: Vec<Event>,
    /// Robots whose known map changed this round.
    pub known_changed: Vec<RobotId>,
    /// Robots whose strategy took longer than the limit to decide this round (set with
    /// `Simulation::with_decide_limit` in the engine layer, above this one),
    /// with the time it took. Wall time, so unlike everything else here it is not the
    /// same from run to run: observers report it, they do not record it.
    pub slow_decisions: Vec<(RobotId, std::time::Duration)>,
}
