//! Step 3: the physical unit, with the outcome of one pass in robot id order. Each turn
//! (see [`super::turn`]) charges energy, refuses or trims what is illegal and applies the
//! rest. The turns go in id order, or side by side (see
//! [`TurnSharing`](crate::engine::TurnSharing)): the moves settled first (see
//! [`SettledMoves`]), then the turns taken at once, those at treasures in id order.
//! Messages are addressed after the turns, as in id order (blocks of senders on all
//! workers), to whoever was in range at send time and alive then.

use std::time::Instant;

use glam::DVec2;
use rayon::prelude::*;

use super::contact::Bodies;
use super::moves::{SettledMoves, Slot, Step2Marks, takes_turn_side_by_side};
use super::turn::{InOrder, TurnWorld, TurnsOut, Way, upkeep};
use crate::cache::prefetch;
use crate::engine::simulation::{Agent, Fanout, Outgoing, Simulation, Turn};
use crate::spatial::RobotId;
use crate::world::{Action, Message, Payload, Recipient, Robot, RobotType};

/// How many turns ahead the pass in id order prefetches a robot's contact list (and twice
/// as many, its robot and agent). Prefetches are hints: they change no result.
const TURNS_READ_AHEAD: usize = 4;

/// Robots a task takes in step 3's turns side by side.
const TURNS_PER_TASK: usize = 64;

impl Simulation {
    /// Step 3 for the robots that did not have their turn in step 2 (see
    /// [`resolve_alone`](super::turn::resolve_alone)). Returns messages and bytes sent.
    ///
    /// Side by side (see [`TurnSharing`](crate::engine::TurnSharing)), the moves are settled
    /// first (see [`SettledMoves`]), then every turn but those at treasures is taken at
    /// once, and the turns at treasures follow in id order. Otherwise every turn goes in id
    /// order. The outcome is the same: `turns_side_by_side_give_the_id_order_run` and
    /// `turns_resolved_alone_give_the_id_order_run` (tests/kernel.rs).
    pub(super) fn resolve(&mut self, round: u64, turns: &[Turn]) -> (u64, u64) {
        let started = Instant::now();
        let mut out = TurnsOut::default();
        let side_by_side = !self.step3.unknown
            && self
                .turn_sharing
                .side_by_side(self.robots.len(), rayon::current_num_threads());
        if side_by_side {
            let Step3 {
                moves, at_treasures, ..
            } = &mut self.step3;
            moves.sort(&self.bodies_now, at_treasures);
            self.phase_times.rounds_side_by_side += 1;
            let t = Instant::now();
            self.phase_times.ordering += t.duration_since(started);
            self.step3.moves.settle(turns, &self.bodies_now);
            self.take_turns_side_by_side(&mut out);
            let t2 = Instant::now();
            self.phase_times.side_by_side += t2.duration_since(t);
            self.take_turns_at_treasures(&mut out);
            self.phase_times.ordering += t2.elapsed();
        } else {
            self.step3.list_pending(turns);
            self.take_turns_in_id_order(turns, &mut out);
            self.phase_times.in_order += started.elapsed();
        }
        let t = Instant::now();
        self.settle_events(&mut out);
        self.phase_times.events += t.elapsed();
        let sent = self.address_sends(round, turns, &mut out.senders);
        let t2 = Instant::now();
        self.fan_out(turns);
        self.phase_times.fan_out += t2.elapsed();
        sent
    }

    /// What step 3's turns borrow of the simulation, each part apart.
    fn turn_parts(&mut self) -> TurnParts<'_> {
        TurnParts {
            world: TurnWorld::new(&self.types, &self.map, &mut self.treasures),
            bodies: Bodies::new(&self.body_index, self.max_radius_m, self.max_speed_m),
            robots: &mut self.robots,
            agents: &mut self.agents,
            bodies_now: &mut self.bodies_now,
            step3: &self.step3,
        }
    }

    /// Every turn left for step 3 but those at treasures, at once, the moves settled.
    fn take_turns_side_by_side(&mut self, out: &mut TurnsOut) {
        let TurnParts {
            world,
            robots,
            agents,
            bodies_now,
            step3,
            ..
        } = self.turn_parts();
        let moves = &step3.moves;
        let side_out = robots
            .par_chunks_mut(TURNS_PER_TASK)
            .zip(agents.par_chunks_mut(TURNS_PER_TASK))
            .zip(bodies_now.par_chunks_mut(TURNS_PER_TASK))
            .zip(moves.roles().par_chunks(TURNS_PER_TASK))
            .enumerate()
            .fold(
                TurnsOut::default,
                |mut out, (c, (((robots, agents), bodies), roles))| {
                    for (k, &role) in roles.iter().enumerate() {
                        let ahead = k + TURNS_READ_AHEAD;
                        if roles.get(ahead).is_some_and(|&r| takes_turn_side_by_side(r)) {
                            prefetch_turn(&robots[ahead], &agents[ahead]);
                        }
                        if !takes_turn_side_by_side(role) {
                            continue;
                        }
                        let i = c * TURNS_PER_TASK + k;
                        let way = Way::Settled(moves.step_of(i), &mut bodies[k]);
                        world.take_turn(i, &mut robots[k], &mut agents[k], way, &mut out);
                    }
                    out
                },
            )
            .reduce(TurnsOut::default, TurnsOut::merge);
        out.merge_from(side_out);
    }

    /// The turns at treasures, in id order (they move nobody: only their order matters).
    fn take_turns_at_treasures(&mut self, out: &mut TurnsOut) {
        let p = self.turn_parts();
        for &i in &p.step3.at_treasures {
            let i = i as usize;
            let way = Way::Settled(None, &mut p.bodies_now[i]);
            p.world.take_turn(i, &mut p.robots[i], &mut p.agents[i], way, out);
        }
    }

    /// The pending turns, one after another in id order.
    fn take_turns_in_id_order(&mut self, turns: &[Turn], out: &mut TurnsOut) {
        let TurnParts {
            world,
            bodies,
            robots,
            agents,
            bodies_now,
            step3,
        } = self.turn_parts();
        let pending = &step3.pending;
        let mut near = Vec::new();
        for (k, &i) in pending.iter().enumerate() {
            // Prefetch what the turns ahead read of their robots and agents, then, once that
            // has arrived, their contact lists.
            if let Some(&ahead) = pending.get(k + 2 * TURNS_READ_AHEAD) {
                let ahead = ahead as usize;
                prefetch(&turns[ahead].near);
                prefetch_turn(&robots[ahead], &agents[ahead]);
            }
            if let Some(first) = pending
                .get(k + TURNS_READ_AHEAD)
                .and_then(|&a| turns[a as usize].near.first())
            {
                prefetch(first);
            }
            let i = i as usize;
            let way = Way::InOrder(InOrder {
                bodies_now,
                bodies: &bodies,
                near: &turns[i].near,
                near_scratch: &mut near,
            });
            world.take_turn(i, &mut robots[i], &mut agents[i], way, out);
        }
    }

    /// Put the turns' events in the report in id order (each robot's in the order raised)
    /// and count the failed strategies.
    fn settle_events(&mut self, out: &mut TurnsOut) {
        self.strategies_failed += out.failed;
        // Stable: a robot's events keep their order.
        out.events.sort_by_key(|&(i, _)| i);
        self.report.events.extend(out.events.drain(..).map(|(_, e)| e));
    }

    /// Address the messages the turns paid for, sender by sender in id order. Blocks of
    /// senders are addressed on all workers, each into its own lists, and the lists joined
    /// in id order: they are those of one pass by id
    /// (`many_senders_are_delivered_in_sender_order`, tests/radio.rs). Returns messages and
    /// bytes sent.
    fn address_sends(&mut self, round: u64, turns: &[Turn], senders: &mut [u32]) -> (u64, u64) {
        let started = Instant::now();
        senders.sort_unstable();
        let t = Instant::now();
        let addressing = Addressing {
            robots: &self.robots,
            types: &self.types,
            turns,
            round,
            radio_limited: self.radio_limited,
        };
        let blocks: Vec<Addressed> = sender_blocks(&mut self.agents, senders)
            .into_par_iter()
            .map(|(first, senders, agents)| addressing.block(first, senders, agents))
            .collect();
        let joined = Instant::now();
        let (mut messages, mut bytes) = (0, 0);
        for block in blocks {
            messages += block.messages;
            bytes += block.bytes;
            self.outgoing.extend(block.outgoing);
            let base = u32::try_from(self.mailbag.len()).expect("fewer than 2^32 messages a round");
            self.fanout.extend(block.fanout.into_iter().map(|f| Fanout {
                bag: base.checked_add(f.bag).expect("fewer than 2^32 messages a round"),
                ..f
            }));
            self.mailbag.extend(block.bag);
        }
        self.phase_times.addressing += joined.duration_since(t);
        self.phase_times.events += t.duration_since(started) + joined.elapsed();
        (messages, bytes)
    }

    /// Put this round's unbudgeted sends in the inboxes, in sending order, in parallel by
    /// receiver. A receiver takes a message if it was alive when the message was sent: a
    /// robot changes only in its own turn, so one before the sender in id order as it is
    /// now, one after it as it was when step 3 began.
    fn fan_out(&mut self, turns: &[Turn]) {
        if self.fanout.is_empty() {
            return;
        }
        let (fanout, robots) = (&self.fanout, &self.robots);
        let alive = |to: usize, from: usize| alive_at_send(robots, turns, to, from);
        // Each broadcast's hearers (listed in step 2, in id order).
        let hearers: Vec<&[RobotId]> = fanout
            .iter()
            .map(|f| match f.to {
                None => &self.agents[f.from as usize].hearers[..],
                Some(_) => &[],
            })
            .collect();
        // Blocks of receivers: each reads every send, and its part of each hearer list.
        let block = self.inboxes.len().div_ceil(4 * rayon::current_num_threads()).max(64);
        self.inboxes.par_chunks_mut(block).enumerate().for_each(|(b, inboxes)| {
            let (lo, hi) = (b * block, b * block + inboxes.len());
            for (f, hearers) in fanout.iter().zip(&hearers) {
                let from = f.from as usize;
                if let Some(to) = f.to {
                    // Checked when sent (in range, alive).
                    let to = to as usize;
                    if (lo..hi).contains(&to) {
                        inboxes[to - lo].push(f.bag);
                    }
                } else {
                    let first = hearers.partition_point(|h| h.index() < lo);
                    for h in hearers[first..].iter().take_while(|h| h.index() < hi) {
                        if alive(h.index(), from) {
                            inboxes[h.index() - lo].push(f.bag);
                        }
                    }
                }
            }
        });
        self.fanout.clear();
    }
}

/// Senders a task addresses in [`Simulation::address_sends`].
const SENDERS_PER_TASK: usize = 64;

/// The sorted `senders` (each robot pays once a round, so none twice) in blocks of
/// [`SENDERS_PER_TASK`], each with the agents from its first sender to its last, apart from
/// every other block's, and the index of that first sender.
fn sender_blocks<'a>(agents: &'a mut [Agent], senders: &'a [u32]) -> Vec<(usize, &'a [u32], &'a mut [Agent])> {
    let mut blocks = Vec::with_capacity(senders.len().div_ceil(SENDERS_PER_TASK));
    let (mut rest, mut start) = (agents, 0);
    for block in senders.chunks(SENDERS_PER_TASK) {
        let (first, last) = (block[0] as usize, block[block.len() - 1] as usize);
        let (mine, after) = std::mem::take(&mut rest)[first - start..].split_at_mut(last + 1 - first);
        blocks.push((first, block, mine));
        (rest, start) = (after, last + 1);
    }
    blocks
}

/// What addressing a round's messages reads: the robots after step 3, where and whether
/// alive each was when it began.
struct Addressing<'a> {
    robots: &'a [Robot],
    types: &'a [RobotType],
    turns: &'a [Turn],
    round: u64,
    radio_limited: bool,
}

/// A block of senders' messages, addressed: with radio budgets, `outgoing`; without,
/// `fanout` with its `bag` indices into this block's `bag`.
#[derive(Default)]
struct Addressed {
    outgoing: Vec<Outgoing>,
    fanout: Vec<Fanout>,
    bag: Vec<Message>,
    messages: u64,
    bytes: u64,
}

impl Addressing<'_> {
    /// Address what the `senders` (in id order; `agents` from index `first` on) paid for.
    fn block(&self, first: usize, senders: &[u32], agents: &mut [Agent]) -> Addressed {
        let mut out = Addressed::default();
        for &i in senders {
            let i = i as usize;
            let agent = &mut agents[i - first];
            let range_m = self.types[self.robots[i].type_index].comm_radius_m;
            let mut paid = std::mem::take(&mut agent.paid_sends);
            for (to, payload) in paid.drain(..) {
                self.send(i, range_m, to, payload, &agent.hearers, &mut out);
            }
            agent.paid_sends = paid;
        }
        out
    }

    /// Address a message of robot `i` to the robots in range at send time (start-of-round
    /// positions) and alive then; a broadcast's are `hearers` (listed in step 2, see
    /// `Agent::hearers`).
    fn send(&self, i: usize, range_m: f64, to: Recipient, payload: Payload, hearers: &[RobotId], out: &mut Addressed) {
        let from = self.robots[i].id;
        let bytes = payload.size_bytes();
        out.messages += 1;
        out.bytes += bytes;
        let message = Message {
            from,
            sent_round: self.round,
            to,
            payload,
        };
        if self.radio_limited {
            out.outgoing.push(Outgoing {
                from: i,
                range_m,
                message,
                bytes,
            });
            return;
        }
        let at = self.turns[i].start;
        let direct: [RobotId; 1];
        let receivers: &[RobotId] = match to {
            Recipient::Broadcast => hearers,
            Recipient::Direct(target) => {
                direct = [target];
                let in_range = self
                    .turns
                    .get(target.index())
                    .is_some_and(|t| target != from && t.start.distance(at) <= range_m);
                if in_range { &direct } else { &[] }
            }
        };
        // Stored once, in the bag the receivers share; each gets its index after step 3.
        if receivers
            .iter()
            .any(|to| alive_at_send(self.robots, self.turns, to.index(), i))
        {
            out.fanout.push(Fanout {
                from: u32::try_from(i).expect("robot indices are u32"),
                bag: u32::try_from(out.bag.len()).expect("fewer than 2^32 messages a round"),
                to: match to {
                    Recipient::Broadcast => None,
                    Recipient::Direct(target) => Some(target.get()),
                },
            });
            out.bag.push(message);
        }
    }
}

/// What step 3's turns borrow of the simulation (see [`Simulation::turn_parts`]).
struct TurnParts<'s> {
    world: TurnWorld<'s>,
    /// The start-of-round robots, to list who could be in a move's way.
    bodies: Bodies<'s>,
    robots: &'s mut [Robot],
    agents: &'s mut [Agent],
    bodies_now: &'s mut [(DVec2, f64)],
    step3: &'s Step3,
}

/// Prefetch what a turn reads of its robot and agent (spread over an agent of about a
/// kilobyte): a hint, it changes nothing.
fn prefetch_turn(robot: &Robot, agent: &Agent) {
    prefetch(robot);
    prefetch(&agent.planned_move);
    prefetch(&agent.action);
    prefetch(&agent.failure);
    prefetch(&agent.mind.output);
}

/// Whether robot `to` was alive when robot `from` had its turn, once every turn of step 3
/// is over: a robot changes only in its own turn, so one before the sender in id order as
/// it is now, one after it as it was when step 3 began.
fn alive_at_send(robots: &[Robot], turns: &[Turn], to: usize, from: usize) -> bool {
    if to < from { robots[to].alive } else { turns[to].alive }
}

/// How step 3 takes a turn when turns go side by side, worked out in step 2.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) enum TurnKind {
    /// It moves from where it starts by its obstacle-free move `free` (step 2's plan): its
    /// step is settled first (see [`SettledMoves`]).
    Moves { free: DVec2 },
    /// It digs, loads or unloads: in id order with the others at treasures.
    AtTreasure,
    /// Nothing in it depends on another robot's turn (or it has no turn in step 3).
    #[default]
    Free,
    /// It would move without step 2's contact list: it would list the robots in its way
    /// itself, so its step cannot be settled ahead, and the round's turns go in id order.
    /// A finite move of a robot that outlives its upkeep always has a list (step 2 plans
    /// every such move with the energy step 3 leaves it): this is a safeguard.
    Unknown,
}

impl TurnKind {
    /// The kind of a live robot's turn, as step 2 leaves it.
    pub(super) fn of(robot: &Robot, agent: &Agent, kind: &RobotType) -> Self {
        match agent.action {
            Action::MoveTo { .. } if let Some(p) = &agent.planned_move => TurnKind::Moves { free: p.free },
            Action::MoveTo { to } => {
                let wanted = (to - robot.position).length();
                let energy = robot.energy - upkeep(kind, agent.needs).min(robot.energy);
                if wanted.is_finite() && wanted > 0.0 && energy > 1e-12 {
                    TurnKind::Unknown
                } else {
                    TurnKind::Free
                }
            }
            Action::Excavate { .. } | Action::Load { .. } | Action::Unload => TurnKind::AtTreasure,
            Action::Idle => TurnKind::Free,
        }
    }
}

/// Step 3's lists and settled moves, kept from round to round to reuse allocations.
#[derive(Debug, Default)]
pub(crate) struct Step3 {
    /// The robots whose turn step 3 takes this round, in id order, when they go in id
    /// order.
    pending: Vec<u32>,
    /// Some turn this round is [`TurnKind::Unknown`] (set by step 2).
    pub(super) unknown: bool,
    /// The robots whose turns are at treasures, in id order.
    at_treasures: Vec<u32>,
    moves: SettledMoves,
}

impl Step3 {
    /// Lists for `n` robots.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            moves: SettledMoves::new(n),
            ..Self::default()
        }
    }

    /// What step 2 sets of each robot for step 3 (see [`Step2Marks`]).
    pub(super) fn step2_marks(&mut self) -> (Step2Marks<'_>, &mut [u16], &mut [Slot]) {
        self.moves.step2_marks()
    }

    /// The robots left for step 3, alive and not resolved in step 2, into `pending`.
    fn list_pending(&mut self, turns: &[Turn]) {
        self.pending.clear();
        self.pending.extend(
            turns
                .iter()
                .enumerate()
                .filter(|(_, t)| t.alive && !t.alone)
                .map(|(i, _)| u32::try_from(i).expect("robot ids are u32")),
        );
    }
}
