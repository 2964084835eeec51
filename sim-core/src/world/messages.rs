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

/// The work a [`Payload::Claim`] is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Task {
    /// Digging the treasure out.
    Excavate,
    /// Carrying its dug units home.
    Transport,
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
    /// A worker's claim on a treasure: it is on its way there (or at it) to do `task`,
    /// `distance_m` away when it said so. Team mates doing the same task that are farther
    /// from the treasure leave it to the claimant (see the `excavator` and `transporter`
    /// strategies).
    Claim {
        /// The treasure.
        treasure: TreasureId,
        /// What the claimant will do there.
        task: Task,
        /// The claimant's straight-line distance to the treasure when it spoke.
        distance_m: f32,
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
    /// encoded tree at 2 bits a node, positions 33 bytes, claims 9 bytes (treasure, task,
    /// distance), custom its tag and data.
    pub fn size_bytes(&self) -> u64 {
        match self {
            Payload::Sightings(s) => 28 * s.len() as u64,
            Payload::KnownMap(m) => (4 * m.tree().internal_nodes() as u64 + 1).div_ceil(4),
            Payload::Position { .. } => 33,
            Payload::Claim { .. } => 9,
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
    /// Content. The round's mail bag holds each message once, and every receiver reads it
    /// there, so a broadcast heard by hundreds is neither copied nor shared by pointer.
    pub payload: Payload,
}

/// The messages one robot reads in a round, in sending order: picks from the round's mail
/// bag, which every receiver shares. A broadcast heard by hundreds is stored once, and
/// delivering it to a receiver costs an index, not a copy. Iterate it with `for m in
/// ctx.messages()` or [`iter`](Self::iter).
#[derive(Clone, Debug, Default)]
pub struct Inbox {
    bag: Arc<Vec<Message>>,
    picks: Vec<u32>,
}

impl Inbox {
    /// The messages `picks` names in `bag`, in that order. Every pick must index `bag`:
    /// reading one that does not panics. Not checked here, even with debug assertions: a
    /// crowded round makes thousands of inboxes of a hundred picks or more, and every read
    /// checks its pick anyway.
    pub fn new(bag: Arc<Vec<Message>>, picks: Vec<u32>) -> Self {
        Self { bag, picks }
    }

    /// The messages, in sending order.
    pub fn iter(&self) -> InboxIter<'_> {
        InboxIter {
            bag: &self.bag,
            picks: self.picks.iter(),
        }
    }

    /// The `i`-th message, in sending order.
    pub fn get(&self, i: usize) -> Option<&Message> {
        self.picks.get(i).map(|&k| &self.bag[k as usize])
    }

    /// How many.
    pub fn len(&self) -> usize {
        self.picks.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.picks.is_empty()
    }

    /// Empty it, handing back its list of picks (to be reused) and letting go of the bag.
    pub fn take_picks(&mut self) -> Vec<u32> {
        self.bag = Arc::default();
        let mut picks = std::mem::take(&mut self.picks);
        picks.clear();
        picks
    }
}

/// An inbox of exactly these messages, in this order (for tests of strategies and tactics).
impl From<Vec<Message>> for Inbox {
    fn from(messages: Vec<Message>) -> Self {
        let picks = (0..u32::try_from(messages.len()).expect("fewer than 2^32 messages")).collect();
        Self::new(Arc::new(messages), picks)
    }
}

impl<'a> IntoIterator for &'a Inbox {
    type Item = &'a Message;
    type IntoIter = InboxIter<'a>;

    fn into_iter(self) -> InboxIter<'a> {
        self.iter()
    }
}

/// The messages of an [`Inbox`], in sending order.
#[derive(Clone, Debug)]
pub struct InboxIter<'a> {
    bag: &'a [Message],
    picks: std::slice::Iter<'a, u32>,
}

impl<'a> Iterator for InboxIter<'a> {
    type Item = &'a Message;

    fn next(&mut self) -> Option<&'a Message> {
        self.picks.next().map(|&k| &self.bag[k as usize])
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.picks.size_hint()
    }
}

impl DoubleEndedIterator for InboxIter<'_> {
    fn next_back(&mut self) -> Option<Self::Item> {
        self.picks.next_back().map(|&k| &self.bag[k as usize])
    }
}

impl ExactSizeIterator for InboxIter<'_> {}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::DVec2;

    use super::{Inbox, Message, Payload, Recipient};
    use crate::spatial::RobotId;

    fn message(from: u32) -> Message {
        Message {
            from: RobotId::new(from),
            sent_round: 1,
            to: Recipient::Broadcast,
            payload: Payload::Position {
                position: DVec2::splat(f64::from(from)),
                goal: None,
            },
        }
    }

    /// Receivers share the bag: each sees its picks, in its order, and nothing else.
    #[test]
    fn inboxes_read_their_picks_of_a_shared_bag_in_order() {
        let bag = Arc::new((0..5).map(message).collect::<Vec<_>>());
        let a = Inbox::new(Arc::clone(&bag), vec![1, 3, 4]);
        let b = Inbox::new(Arc::clone(&bag), vec![0, 3]);
        let senders = |i: &Inbox| i.iter().map(|m| m.from.get()).collect::<Vec<_>>();
        assert_eq!(senders(&a), [1, 3, 4]);
        assert_eq!(senders(&b), [0, 3]);
        assert_eq!(a.iter().rev().map(|m| m.from.get()).collect::<Vec<_>>(), [4, 3, 1]);
        assert_eq!((a.len(), a.iter().len(), b.len()), (3, 3, 2));
        assert_eq!(a.get(1).map(|m| m.from.get()), Some(3));
        assert!(a.get(3).is_none());
        // One copy of each message, whoever reads it.
        assert!(std::ptr::eq(a.get(1).unwrap(), b.get(1).unwrap()));
        let mut own = Inbox::from(vec![message(7), message(2)]);
        assert_eq!(senders(&own), [7, 2]);
        assert!(own.take_picks().is_empty() && own.is_empty());
        assert!(Inbox::default().iter().next().is_none());
    }
}
