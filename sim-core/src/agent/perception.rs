//! What a robot perceives in a round and what it remembers between rounds.

use glam::DVec2;

use crate::spatial::{KnownMap, RobotId, TreasureId};
use crate::world::{Inbox, MemoryList, Retention, Sighting};

/// A robot seen in the view radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenRobot {
    /// Its id.
    pub id: RobotId,
    /// Its position.
    pub position: DVec2,
    /// Its type (index into the run's types).
    pub type_index: usize,
}

/// A treasure seen in the view radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenTreasure {
    /// Its id.
    pub id: TreasureId,
    /// Its position.
    pub position: DVec2,
    /// Units still buried.
    pub buried: u32,
    /// Units dug and lying there.
    pub loose: u32,
}

/// One round's perceptions (buffers reused across rounds).
#[derive(Clone, Debug, Default)]
pub struct Perception {
    /// Robots in view, by id.
    pub robots: Vec<SeenRobot>,
    /// Treasures in view, by id.
    pub treasures: Vec<SeenTreasure>,
    /// Messages delivered this round, in sending order.
    pub inbox: Inbox,
}

/// The data module: what a robot remembers between rounds.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DataModule {
    /// The explored region, if the strategy keeps one.
    pub known: Option<KnownMap>,
    /// Treasures seen or heard of.
    pub treasures: MemoryList<TreasureId, Sighting>,
    /// Robots seen, with where and when.
    pub robots: MemoryList<RobotId, (DVec2, u64)>,
}

impl DataModule {
    /// A data module with the given retention for remembered treasures and robots.
    pub fn new(known: Option<KnownMap>, treasures: Retention, robots: Retention) -> Self {
        Self {
            known,
            treasures: MemoryList::new(treasures),
            robots: MemoryList::new(robots),
        }
    }
}
