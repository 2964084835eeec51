//! Layer 2, the world model: robot types, robots, treasures and actions, messages, memory
//! lists, the map file, and what a round reports (events, links, metrics). Imports only
//! from [`spatial`](crate::spatial).

mod mapfile;
mod memory;
mod messages;
mod metrics;
mod model;
mod report;

pub use mapfile::{HomeBase, MAGIC, MapData, TreasureSpec, VERSION};
pub use memory::{MemoryList, Retention};
pub use messages::{Inbox, InboxIter, Message, Payload, Recipient, Sighting, Task};
pub use metrics::{EXPLORED_MILESTONES, ExploredMilestones, METRICS_COLUMNS, METRICS_COUNT, RoundMetrics};
pub use model::{Action, Outcome, REACH_M, ROBOT_TYPE_ATTRIBUTES, Robot, RobotStats, RobotType, TreasureState};
pub use report::{Event, Link, RoundReport, StrategyEvent};
