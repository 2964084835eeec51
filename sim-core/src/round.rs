//! The round loop, top-down: perceive → decide → resolve → observe.
//!
//! 1. **Perceive** (parallel): every live robot sees the state as it was at the start of the
//!    round and reads the messages delivered to it.
//! 2. **Decide** (parallel, fused with 1): its strategy picks one action and any messages;
//!    each robot owns its strategy and data, nothing shared is written.
//! 3. **Resolve** (sequential, by robot id): the physical unit charges energy and refuses or
//!    trims what is illegal (speed, energy, obstacles, other robots, abilities, capacity),
//!    then applies the rest; messages are addressed to whoever was in range at send time.
//! 4. **Observe**: metrics update; the caller notifies observers with the round's report.
//!
//! Randomness comes from generators seeded by (run seed, robot, round), and every shared
//! update happens in step 3 in id order, so results do not depend on the thread count.

use std::sync::Arc;

use glam::DVec2;
use rayon::prelude::*;

use crate::messages::{Message, Payload, Recipient, Sighting};
use crate::model::{Action, Outcome, REACH_M, Robot, RobotType, TreasureState};
use crate::observer::{Event, Link, RoundReport};
use crate::robot_index::{RobotId, RobotIndex};
use crate::sim::{Agent, Simulation, index_cell_m};
use crate::strategy::{Ctx, SeenRobot, SeenTreasure, WorldView};
use crate::treasure_index::TreasureIndex;

impl Simulation {
    /// Play one round and return its report.
    pub fn step(&mut self) -> &RoundReport {
        self.round += 1;
        let round = self.round;
        self.report = RoundReport {
            round,
            ..RoundReport::default()
        };
        self.deliver_messages();
        self.perceive_and_decide(round);
        self.record_discoveries(round);
        self.update_explored();
        self.start_positions.clear();
        self.start_positions.extend(self.robots.iter().map(|r| r.position));
        let (messages, bytes) = self.resolve(round);
        self.robot_index.rebuild(
            self.robots.iter().map(|r| (r.id, r.position)),
            index_cell_m(&self.types),
        );
        self.report.metrics = self.metrics(round, messages, bytes);
        &self.report
    }

    /// Move last round's messages into the receivers' perception.
    fn deliver_messages(&mut self) {
        for (agent, inbox) in self.agents.iter_mut().zip(self.inboxes.iter_mut()) {
            agent.perception.inbox.clear();
            if agent.needs.messages {
                std::mem::swap(&mut agent.perception.inbox, inbox);
            }
            inbox.clear();
        }
    }

    /// Steps 1 and 2, in parallel over robots.
    fn perceive_and_decide(&mut self, round: u64) {
        let world = WorldView {
            obstacles: &self.map.obstacles,
            nav: &self.nav,
            home: self.map.home,
            types: &self.types,
        };
        let snapshot = Snapshot {
            robots: &self.robots,
            treasures: &self.treasures,
            treasure_index: &self.treasure_index,
            robot_index: &self.robot_index,
        };
        let seed = self.seed;
        self.agents
            .par_iter_mut()
            .zip(self.robots.par_iter())
            .for_each(|(agent, robot)| {
                agent.outbox.clear();
                agent.events.clear();
                agent.known_changed = false;
                if !robot.alive {
                    agent.action = Action::Idle;
                    return;
                }
                let kind = &world.types[robot.type_index];
                perceive(agent, robot, kind, &snapshot, round);
                let mut ctx = Ctx {
                    round,
                    me: robot,
                    kind,
                    perception: &agent.perception,
                    data: &mut agent.data,
                    world,
                    rng: Simulation::rng_for(seed, robot.id, round),
                    outbox: &mut agent.outbox,
                    goal: &mut agent.goal,
                    path: &mut agent.path,
                    events: &mut agent.events,
                };
                agent.action = agent.strategy.decide(&mut ctx);
            });
    }

    /// First sightings of treasures, credited in id order.
    fn record_discoveries(&mut self, round: u64) {
        for (robot, agent) in self.robots.iter_mut().zip(&self.agents) {
            for t in &agent.perception.treasures {
                let state = &mut self.treasures[t.id.0 as usize];
                if state.found_round.is_none() {
                    state.found_round = Some(round);
                    robot.stats.treasures_found += 1;
                    self.report.events.push(Event::TreasureFound {
                        treasure: t.id,
                        by: robot.id,
                    });
                }
            }
            if agent.known_changed {
                self.report.known_changed.push(robot.id);
            }
            for e in &agent.events {
                self.report.events.push(e.clone().into_event(robot.id));
            }
        }
    }

    /// Step 3: the physical unit, robot by robot in id order. Returns messages and bytes sent.
    fn resolve(&mut self, round: u64) -> (u64, u64) {
        let (mut messages, mut bytes) = (0, 0);
        for i in 0..self.robots.len() {
            if !self.robots[i].alive {
                continue;
            }
            let types = Arc::clone(&self.types);
            let kind = &types[self.robots[i].type_index];
            let action = self.agents[i].action;
            // Living and sensing cost energy whatever the action.
            let sense = if self.agents[i].needs.senses() {
                kind.energy_per_sense
            } else {
                0.0
            };
            self.spend(i, kind.energy_idle + sense);
            let outcome = if self.robots[i].alive {
                self.apply(i, kind, action)
            } else {
                Outcome::Refused
            };
            let outbox = std::mem::take(&mut self.agents[i].outbox);
            for (to, payload) in outbox {
                if !self.robots[i].alive || self.robots[i].energy < kind.energy_per_message {
                    break;
                }
                self.spend(i, kind.energy_per_message);
                let size = payload.size_bytes();
                self.send(i, kind, round, to, payload);
                messages += 1;
                bytes += size;
                self.robots[i].stats.messages_sent += 1;
                self.robots[i].stats.message_bytes += size;
            }
            let r = &mut self.robots[i];
            if r.alive && self.map.home.contains(r.position) {
                r.energy = (r.energy + kind.recharge_per_round).min(kind.energy_capacity);
            }
            r.last_action = (action, outcome);
            r.goal = self.agents[i].goal;
            r.path.clone_from(&self.agents[i].path);
        }
        (messages, bytes)
    }

    /// Charge energy; a robot that runs dry is disabled for good.
    fn spend(&mut self, i: usize, amount: f64) {
        let r = &mut self.robots[i];
        let paid = amount.min(r.energy);
        r.energy -= paid;
        r.stats.energy_used += paid;
        if r.energy <= 1e-12 {
            r.energy = 0.0;
            r.alive = false;
            self.report.events.push(Event::RobotDisabled { robot: r.id });
        }
    }

    /// Check and carry out one action.
    fn apply(&mut self, i: usize, kind: &RobotType, action: Action) -> Outcome {
        match action {
            Action::Idle => Outcome::Done,
            Action::MoveTo { to } => self.apply_move(i, kind, to),
            Action::Excavate { treasure } => {
                let Some(t) = self.reachable_treasure(i, kind, treasure) else {
                    return Outcome::Refused;
                };
                if !kind.can_excavate || t.buried == 0 || self.robots[i].energy < kind.energy_per_excavation {
                    return Outcome::Refused;
                }
                self.spend(i, kind.energy_per_excavation);
                let t = &mut self.treasures[treasure.0 as usize];
                let dug = kind.excavation_per_round.min(t.buried);
                t.buried -= dug;
                t.loose += dug;
                self.robots[i].stats.units_dug += u64::from(dug);
                if t.buried == 0 {
                    self.report.events.push(Event::TreasureExcavated {
                        treasure,
                        by: self.robots[i].id,
                    });
                }
                if dug < kind.excavation_per_round {
                    Outcome::Trimmed
                } else {
                    Outcome::Done
                }
            }
            Action::Load { treasure } => {
                let Some(t) = self.reachable_treasure(i, kind, treasure) else {
                    return Outcome::Refused;
                };
                let room = kind.carry_capacity.saturating_sub(self.robots[i].load());
                let amount = room.min(t.loose);
                if amount == 0 {
                    return Outcome::Refused;
                }
                self.treasures[treasure.0 as usize].loose -= amount;
                let cargo = &mut self.robots[i].cargo;
                match cargo.iter_mut().find(|c| c.0 == treasure) {
                    Some(c) => c.1 += amount,
                    None => cargo.push((treasure, amount)),
                }
                if amount < t.loose && amount < room {
                    Outcome::Trimmed
                } else {
                    Outcome::Done
                }
            }
            Action::Unload => {
                let r = &mut self.robots[i];
                if r.cargo.is_empty() || !self.map.home.contains(r.position) {
                    return Outcome::Refused;
                }
                for (treasure, amount) in std::mem::take(&mut r.cargo) {
                    let t = &mut self.treasures[treasure.0 as usize];
                    t.delivered += amount;
                    r.stats.units_delivered += u64::from(amount);
                    if t.delivered == t.initial {
                        self.report.events.push(Event::TreasureDelivered { treasure, by: r.id });
                    }
                }
                Outcome::Done
            }
        }
    }

    /// The treasure, if it exists and lies within the robot's reach.
    fn reachable_treasure(&self, i: usize, kind: &RobotType, id: crate::TreasureId) -> Option<TreasureState> {
        let t = *self.treasures.get(id.0 as usize)?;
        (t.position.distance(self.robots[i].position) <= kind.radius_m + REACH_M).then_some(t)
    }

    /// A move, trimmed to speed, energy, obstacles and other robots, in that order.
    fn apply_move(&mut self, i: usize, kind: &RobotType, to: DVec2) -> Outcome {
        let from = self.robots[i].position;
        let mut d = to - from;
        let wanted = d.length();
        if !wanted.is_finite() {
            return Outcome::Refused;
        }
        if wanted == 0.0 {
            return Outcome::Done;
        }
        let mut len = wanted.min(kind.speed_m_per_round);
        if kind.energy_per_m > 0.0 {
            len = len.min(self.robots[i].energy / kind.energy_per_m);
        }
        d *= len / wanted;
        let obstacles = &self.map.obstacles;
        if !obstacles.is_swept_disc_free(from, from + d, kind.radius_m) {
            // Largest free fraction of the segment, by bisection.
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..24 {
                let mid = 0.5 * (lo + hi);
                if obstacles.is_swept_disc_free(from, from + d * mid, kind.radius_m) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            d *= lo;
        }
        // Other robots: halve the move until the end position overlaps nobody.
        let mut step = d;
        let mut tries = 0;
        while step.length() > 1e-9 && self.overlaps_someone(i, from + step, kind.radius_m) {
            step *= 0.5;
            tries += 1;
            if tries > 8 {
                step = DVec2::ZERO;
            }
        }
        let moved = step.length();
        if moved <= 1e-12 {
            return Outcome::Refused;
        }
        let r = &mut self.robots[i];
        r.position = from + step;
        r.stats.distance_m += moved;
        self.spend(i, moved * kind.energy_per_m);
        if (moved - wanted).abs() > 1e-9 {
            Outcome::Trimmed
        } else {
            Outcome::Done
        }
    }

    /// Whether a disc at `p` would overlap another robot where it stands now.
    fn overlaps_someone(&self, i: usize, p: DVec2, radius: f64) -> bool {
        // The index holds start-of-round positions; robots move at most max_speed a round.
        let reach = radius + self.max_radius_m + self.max_speed_m;
        let mut hit = false;
        self.robot_index.for_each_within(p, reach, |id, _| {
            let j = id.index();
            if j != i && !hit {
                let other = &self.robots[j];
                let rr = radius + self.types[other.type_index].radius_m;
                hit = other.position.distance_squared(p) < rr * rr;
            }
        });
        hit
    }

    /// Address a message to the robots in range at send time (start-of-round positions).
    fn send(&mut self, i: usize, kind: &RobotType, round: u64, to: Recipient, payload: Payload) {
        let from = self.robots[i].id;
        let at = self.start_positions[i];
        let message = Message {
            from,
            sent_round: round,
            to,
            payload: Arc::new(payload),
        };
        let mut receivers: Vec<RobotId> = Vec::new();
        match to {
            Recipient::Broadcast => {
                self.robot_index.for_each_within(at, kind.comm_radius_m, |id, _| {
                    if id != from {
                        receivers.push(id);
                    }
                });
                receivers.sort_unstable();
            }
            Recipient::Direct(target) => {
                if let Some(&p) = self.start_positions.get(target.index())
                    && target != from
                    && p.distance(at) <= kind.comm_radius_m
                {
                    receivers.push(target);
                }
            }
        }
        for to in receivers {
            if self.robots[to.index()].alive {
                self.inboxes[to.index()].push(message.clone());
                self.report.links.push(Link { from, to });
            }
        }
    }

    /// Mark every sensing robot's view (from where it perceived) in the collective explored
    /// map, crediting the free area it was first to see; feeds the step-4 metrics.
    fn update_explored(&mut self) {
        let obstacles = &self.map.obstacles;
        let cell_area = obstacles.grid().cell_area_m2();
        let before = self.explored_free_cells;
        for (robot, agent) in self.robots.iter_mut().zip(&self.agents) {
            if !agent.needs.senses() || !robot.alive {
                continue;
            }
            let view = crate::geometry::Disc {
                center: robot.position,
                radius: self.types[robot.type_index].view_radius_m,
            };
            let mut fresh = 0;
            self.explored
                .mark_reporting(&view, |sq| fresh += obstacles.tree().count_cells_in(sq, false));
            self.explored_free_cells += fresh;
            robot.stats.explored_m2 += fresh as f64 * cell_area;
        }
        if before < self.total_free_cells && self.explored_free_cells == self.total_free_cells {
            self.report.events.push(Event::MapExplored);
        }
    }
}

/// Known maps a robot merges per round at most; later ones that round are dropped.
pub const MAX_MAP_MERGES_PER_ROUND: usize = 2;

/// The shared, read-only state robots perceive in a round.
struct Snapshot<'a> {
    robots: &'a [Robot],
    treasures: &'a [TreasureState],
    treasure_index: &'a TreasureIndex,
    robot_index: &'a RobotIndex,
}

/// Step 1 for one robot: only what its strategy needs.
fn perceive(agent: &mut Agent, robot: &Robot, kind: &RobotType, world: &Snapshot, round: u64) {
    let needs = agent.needs;
    let p = robot.position;
    let view = kind.view_radius_m;
    let data = &mut agent.data;
    let perception = &mut agent.perception;
    if let Some(known) = data.known.as_mut() {
        agent.known_changed |= known.mark_disc(p, view);
    }
    perception.robots.clear();
    if needs.robots {
        world.robot_index.for_each_within(p, view, |id, q| {
            if id != robot.id {
                perception.robots.push(SeenRobot {
                    id,
                    position: q,
                    type_index: world.robots[id.index()].type_index,
                });
            }
        });
        perception.robots.sort_by_key(|r| r.id);
        for r in &perception.robots {
            data.robots.record(r.id, (r.position, round), round);
        }
    }
    perception.treasures.clear();
    if needs.treasures {
        world.treasure_index.for_each_in_disc(p, view, |t| {
            let s = &world.treasures[t.id.0 as usize];
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
        // Remembered treasures that should be in view but are not have been emptied: record
        // that as a fresh sighting, so older hearsay cannot bring them back.
        let emptied: Vec<Sighting> = data
            .treasures
            .iter()
            .filter(|(s, _)| s.position.distance(p) <= view && !perception.treasures.iter().any(|t| t.id == s.treasure))
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
    if needs.messages {
        let mut merged = 0;
        for m in &perception.inbox {
            match &*m.payload {
                Payload::KnownMap(other) => {
                    // Maps only grow: one no larger than the last merged from its sender is
                    // contained in ours already. Of the rest, a robot digests a bounded number
                    // a round (first come, first served): in a crowd hundreds arrive at once.
                    let cells = other.known_cells();
                    let seen = agent.merged_from.get(&m.from).is_some_and(|&c| c >= cells);
                    if let Some(known) = data.known.as_mut()
                        && !seen
                        && merged < MAX_MAP_MERGES_PER_ROUND
                    {
                        merged += 1;
                        agent.known_changed |= known.merge(other);
                        agent.merged_from.insert(m.from, cells);
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
                Payload::Position { .. } | Payload::Custom { .. } => {}
            }
        }
    }
    data.treasures.evict(round);
    data.robots.evict(round);
}
