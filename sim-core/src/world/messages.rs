//! Messages between robots: sent in round t, delivered at the start of round t+1 to robots
//! that were inside the sender's communication radius when it was sent (paper §3.1).

use std::sync::Arc;

use glam::DVec2;

use crate::spatial::KnownMap;
use crate::spatial::RobotId;
use crate::spatial::TreasureId;

/// A treasure sighting: where, how much, when.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sighting {
    /// The treasure.
    pub treasure: TreasureId,
    /// Its position.
    pub position: DVec2,
    /// Units still buried when seen.
    pub buried: u32,
    /// Units dug and lying there when seen.
    pub loose: u32,
    /// Round of the sighting.
    pub round: u64,
}

/// What a message carries.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub enum Payload {
    /// Treasure sightings (added to the receiver's treasure memory).
    Sightings(Vec<Sighting>),
    /// A known-region map (merged into the receiver's known map on receipt).
    KnownMap(Arc<KnownMap>),
    /// The sender's position and intent, for team behaviour.
    Position {
        /// Where the sender is.
        position: DVec2,
        /// Where it is heading, if anywhere.
        goal: Option<DVec2>,
    },
    /// Anything else a strategy wants to say.
    Custom {
        /// A tag the receiving strategy recognises.
        kind: String,
        /// Opaque bytes.
        data: Vec<u8>,
    },
}

impl Payload {
    /// Size on the air in bytes (for accounting): sightings 28 bytes each, a known map its
    /// encoded tree at 2 bits a node, positions 33 bytes, custom its tag and data.
    pub fn size_bytes(&self) -> u64 {
        match self {
            Payload::Sightings(s) => 28 * s.len() as u64,
            Payload::KnownMap(m) => (4 * m.tree().internal_nodes() as u64 + 1).div_ceil(4),
            Payload::Position { .. } => 33,
            Payload::Custom { kind, data } => (kind.len() + data.len()) as u64,
        }
    }
}

/// Who a message is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Recipient {
    /// Every robot in range.
    Broadcast,
    /// One robot, if in range.
    Direct(RobotId),
}

/// A message as delivered.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Message {
    /// Sender.
    pub from: RobotId,
    /// Round it was sent.
    pub sent_round: u64,
    /// Addressing.
    pub to: Recipient,
    /// Content (shared, not copied, between receivers).
    pub payload: Arc<Payload>,
}
