//! Step 1: every live robot perceives the start-of-round state, only what its strategy
//! declared in [`Needs`](crate::agent::Needs), and digests the messages delivered to it.

use std::sync::Arc;

use glam::DVec2;

use crate::agent::{DataModule, Perception, SeenRobot, SeenTreasure};
use crate::cache::prefetch;
use crate::engine::simulation::{Agent, MergedFrom, Simulation, Turn};
use crate::spatial::{RobotId, RobotIndex, TreasureIndex};
use crate::world::{Event, Inbox, Message, Payload, Robot, RobotType, Sighting, TreasureState};

/// Move last round's messages picked for `agent` (`picks`, indices into `bag`) into its
/// perception; its last inbox gives its list back, to be filled again in step 3. Returns
/// whether it now holds messages. Each receiver's own: receivers run in parallel.
pub(super) fn hand_out(agent: &mut Agent, picks: &mut Vec<u32>, bag: &Arc<Vec<Message>>) -> bool {
    let mut spare = agent.mind.perception.inbox.take_picks();
    if agent.needs.messages && !picks.is_empty() {
        std::mem::swap(picks, &mut spare);
        agent.mind.perception.inbox = Inbox::new(Arc::clone(bag), spare);
        true
    } else {
        picks.clear();
        false
    }
}

impl Simulation {
    /// Last round's messages, as one bag the receivers' inboxes share, if there is anything
    /// to hand out ([`hand_out`] gives each receiver its own, in step 2's parallel pass).
    pub(super) fn take_mailbag(&mut self) -> Option<Arc<Vec<Message>>> {
        // Nothing sent last round and nothing held from the round before: nothing to do.
        (!self.mailbag.is_empty() || self.inboxes_held).then(|| Arc::new(std::mem::take(&mut self.mailbag)))
    }

    /// First sightings of treasures and the strategies' events, credited in id order, for
    /// the robots whose turn has news (step 2 tells whether any has: most rounds of most
    /// swarms have none, and then this pass is skipped).
    pub(super) fn record_discoveries(&mut self, round: u64, any_news: bool) {
        if !any_news {
            return;
        }
        for (i, ((robot, agent), turn)) in self.robots.iter_mut().zip(&self.agents).zip(&self.turns).enumerate() {
            // Only the agents of robots with something to report are looked at; those a
            // few ahead are prefetched.
            if self.turns.get(i + AGENTS_AHEAD).is_some_and(|t| t.news) {
                let ahead = &self.agents[i + AGENTS_AHEAD];
                prefetch(&ahead.mind.perception.treasures);
                prefetch(&ahead.mind.output);
            }
            if !turn.news {
                continue;
            }
            for t in &agent.mind.perception.treasures {
                let state = &mut self.treasures[t.id.index()];
                if state.found_round.is_none() {
                    state.found_round = Some(round);
                    robot.stats.treasures_found += 1;
                    self.report.events.push(Event::TreasureFound {
                        treasure: t.id,
                        by: robot.id,
                    });
                }
            }
            for e in agent.mind.output.events() {
                self.report.events.push(e.clone().into_event(robot.id));
            }
        }
    }
}

/// How many agents ahead the sequential passes over them prefetch.
const AGENTS_AHEAD: usize = 8;

/// Known maps a robot merges per round at most; later ones that round are dropped.
pub const MAX_MAP_MERGES_PER_ROUND: usize = 2;

/// Senders a robot's table of maps merged holds before it first grows (about 1 KB).
const MERGED_FROM_FIRST_CAPACITY: usize = 56;

/// The shared, read-only state robots perceive in a round.
pub(super) struct Snapshot<'a> {
    /// Each robot's type (robots resolved alone in step 2 are being written meanwhile).
    pub(super) type_of: &'a [usize],
    pub(super) treasures: &'a [TreasureState],
    pub(super) treasure_index: &'a TreasureIndex,
    pub(super) robot_index: &'a RobotIndex,
}

/// Step 1 for one robot: what its strategy needs, and the treasures in view whatever it
/// needs, so that a treasure counts as found when it comes into some robot's view
/// (`treasures_found` does not depend on the strategies).
pub(super) fn perceive(
    agent: &mut Agent,
    turn: &mut Turn,
    robot: &Robot,
    kind: &RobotType,
    world: &Snapshot,
    round: u64,
) {
    let needs = agent.needs;
    let (p, view) = (robot.position, kind.view_radius_m);
    let data = &mut agent.mind.data;
    let perception = &mut agent.mind.perception;
    turn.has_known = data.known.is_some();
    if let Some(known) = data.known.as_mut() {
        let squares = &mut turn.new_squares;
        turn.known_changed |= known.mark_view_reporting(p, view, |sq| squares.push(sq));
    }
    perception.robots.clear();
    if needs.robots {
        see_robots(data, perception, robot, view, world, round);
    }
    perception.treasures.clear();
    if needs.treasures {
        see_treasures(data, perception, p, view, world, round);
    } else {
        treasures_in_view(perception, p, view, world);
    }
    if needs.messages {
        read_messages(agent, turn, round);
    }
    let data = &mut agent.mind.data;
    data.treasures.evict(round);
    data.robots.evict(round);
}

/// The robots in view, by id, and the memory of robots seen.
#[inline]
fn see_robots(
    data: &mut DataModule,
    perception: &mut Perception,
    robot: &Robot,
    view: f64,
    world: &Snapshot,
    round: u64,
) {
    world.robot_index.for_each_within(robot.position, view, |id, q| {
        if id != robot.id {
            perception.robots.push(SeenRobot {
                id,
                position: q,
                type_index: world.type_of[id.index()],
            });
        }
    });
    perception.robots.sort_by_key(|r| r.id);
    // Only those the memory will keep: in a crowd a robot sees hundreds, and a bounded
    // memory forgets all but the last few. Recording the rest too would leave the same
    // memory: `recording_the_kept_tail_is_recording_all` (world/memory.rs).
    for r in data.robots.kept_of(&perception.robots) {
        data.robots.record(r.id, (r.position, round), round);
    }
}

/// The treasures in view with something left, by id, into `perception`.
#[inline]
fn treasures_in_view(perception: &mut Perception, p: DVec2, view: f64, world: &Snapshot) {
    world.treasure_index.for_each_in_disc(p, view, |t| {
        let s = &world.treasures[t.id.index()];
        if s.buried + s.loose > 0 {
            perception.treasures.push(SeenTreasure {
                id: t.id,
                position: t.position,
                buried: s.buried,
                loose: s.loose,
            });
        }
    });
    perception.treasures.sort_by_key(|t| t.id);
}

/// The treasures in view with something left, by id, and the memory of treasures: those in
/// view recorded, those remembered in view but gone recorded as emptied.
#[inline]
fn see_treasures(
    data: &mut DataModule,
    perception: &mut Perception,
    p: DVec2,
    view: f64,
    world: &Snapshot,
    round: u64,
) {
    treasures_in_view(perception, p, view, world);
    // Remembered treasures that should be in view but are not have been emptied: record
    // that as a fresh sighting, so older hearsay cannot bring them back.
    // The first test scans the slab and usually fails; the walk keeps the list's order.
    let emptied =
        |s: &Sighting| s.position.distance(p) <= view && !perception.treasures.iter().any(|t| t.id == s.treasure);
    if data.treasures.any(emptied) {
        let emptied: Vec<Sighting> = data
            .treasures
            .iter()
            .filter(|(s, _)| emptied(s))
            .map(|(s, _)| Sighting {
                buried: 0,
                loose: 0,
                round,
                ..*s
            })
            .collect();
        for s in emptied {
            data.treasures.record(s.treasure, s, round);
        }
    }
    for t in &perception.treasures {
        let s = Sighting {
            treasure: t.id,
            position: t.position,
            buried: t.buried,
            loose: t.loose,
            round,
        };
        data.treasures.record(t.id, s, round);
    }
}

/// This round's messages: maps merged (a bounded number), sightings heard recorded.
#[inline]
fn read_messages(agent: &mut Agent, turn: &mut Turn, round: u64) {
    let data = &mut agent.mind.data;
    let mut merged = 0;
    for m in &agent.mind.perception.inbox {
        match &m.payload {
            // A robot digests a bounded number of maps a round (first come, first
            // served): in a crowd hundreds arrive at once. The bound is tested first:
            // once it is reached, the rest cost no lookup (each a likely cache miss on
            // sender and table).
            Payload::KnownMap(_) if merged >= MAX_MAP_MERGES_PER_ROUND => {}
            Payload::KnownMap(other) => {
                // Maps only grow: one no larger than the last merged from its sender is
                // contained in ours already.
                let cells = other.known_cells();
                let seen = || agent.merged_from.get(&m.from).is_some_and(|&c| c >= cells);
                if let Some(known) = data.known.as_mut()
                    && !seen()
                {
                    merged += 1;
                    turn.known_changed |= known.merge(other);
                    remember_merge(&mut agent.merged_from, m.from, cells);
                }
            }
            Payload::Sightings(list) => {
                for s in list {
                    let newer = data.treasures.get(s.treasure).is_none_or(|old| old.round < s.round);
                    if newer {
                        data.treasures.record(s.treasure, *s, round);
                    }
                }
            }
            Payload::Position { .. } | Payload::Claim { .. } | Payload::Custom { .. } => {}
        }
    }
}

/// Note that a robot merged a map of `cells` known cells from `from`.
fn remember_merge(merged_from: &mut MergedFrom, from: RobotId, cells: u64) {
    if merged_from.capacity() == 0 {
        // In a crowd a robot merges from new senders every round: the table starts at a
        // useful size rather than rehashing through every doubling.
        merged_from.reserve(MERGED_FROM_FIRST_CAPACITY);
    }
    merged_from.insert(from, cells);
}
