//! Step 3: the physical unit, robot by robot in id order. It charges energy and refuses or
//! trims what is illegal (speed, energy, obstacles, other robots, abilities, capacity), then
//! applies the rest; messages are addressed to whoever was in range at send time.

use std::sync::Arc;

use glam::DVec2;
use rayon::prelude::*;

use crate::agent::Needs;
use crate::agent::StrategyOutput;
use crate::cache::prefetch;
use crate::engine::simulation::{Agent, Fanout, Outgoing, Simulation, Turn};
use crate::spatial::{IndexEntry, ObstacleMap, RobotId, RobotIndex, TreasureId, point_segment_distance_squared};
use crate::world::{
    Action, Event, HomeBase, Message, Outcome, Payload, REACH_M, Recipient, Robot, RobotType, TreasureState,
};

/// How many turns ahead step 3 prefetches a robot's contact list (and twice as many, its
/// robot and agent). Prefetches are hints: they change no result.
const TURNS_READ_AHEAD: usize = 4;

impl Simulation {
    /// Step 3: the physical unit, robot by robot in id order. Returns messages and bytes sent.
    ///
    /// Robots whose turn depends on no other robot (see [`resolve_alone`]) had it in step 2,
    /// in parallel; the rest have theirs here, in id order. The result is that of one pass
    /// in id order: `turns_resolved_alone_give_the_id_order_run` (tests/kernel.rs).
    pub(super) fn resolve(&mut self, round: u64, turns: &[Turn]) -> (u64, u64) {
        let started = std::time::Instant::now();
        let (mut messages, mut bytes) = (0, 0);
        // Held apart from `self` so the loop can mutate the simulation while it reads a type
        // (one reference-count update a round, not one a robot).
        let types = Arc::clone(&self.types);
        let home = self.map.home;
        // The robots left for this step (alive, not resolved alone), from the turns alone:
        // the loop reads and prefetches only their robots and agents.
        let mut pending = std::mem::take(&mut self.step3_robots);
        pending.clear();
        pending.extend(
            turns
                .iter()
                .enumerate()
                .filter(|(_, t)| t.alive && !t.alone)
                .map(|(i, _)| u32::try_from(i).expect("robot ids are u32")),
        );
        for (k, &i) in pending.iter().enumerate() {
            let i = i as usize;
            // Prefetch what the turns ahead read of their robots and agents (spread over an
            // agent of about a kilobyte), then, once that has arrived, their contact lists.
            if let Some(&ahead) = pending.get(k + 2 * TURNS_READ_AHEAD) {
                let ahead = ahead as usize;
                prefetch(&self.robots[ahead]);
                let agent = &self.agents[ahead];
                prefetch(&agent.planned_near);
                prefetch(&agent.planned_move);
                prefetch(&agent.action);
                prefetch(&agent.failure);
                prefetch(&agent.mind.output);
            }
            if let Some(first) = pending
                .get(k + TURNS_READ_AHEAD)
                .and_then(|&a| self.agents[a as usize].planned_near.first())
            {
                prefetch(first);
            }
            if !self.robots[i].alive {
                continue;
            }
            if let Some(reason) = self.agents[i].failure.take() {
                self.fail(i, reason);
                continue;
            }
            let kind = &types[self.robots[i].type_index];
            let action = self.agents[i].action;
            self.spend(i, upkeep(kind, self.agents[i].needs));
            let outcome = if self.robots[i].alive {
                self.apply(i, kind, action)
            } else {
                Outcome::Refused
            };
            // Most turns send nothing: their outbox is left alone.
            if !self.agents[i].mind.output.outbox().is_empty() {
                let (sent, size) = self.send_outbox(i, kind, round, turns);
                messages += sent;
                bytes += size;
            }
            end_of_turn(&mut self.robots[i], kind, &home, (action, outcome));
        }
        self.step3_robots = pending;
        let t = std::time::Instant::now();
        self.phase_times.in_order += t.duration_since(started);
        self.fan_out(turns);
        self.phase_times.fan_out += t.elapsed();
        (messages, bytes)
    }

    /// Send what robot `i` queued this round, in order, while it lives and can pay for
    /// each message. Returns messages and bytes sent.
    fn send_outbox(&mut self, i: usize, kind: &RobotType, round: u64, turns: &[Turn]) -> (u64, u64) {
        let (mut messages, mut bytes) = (0, 0);
        let mut outbox = self.agents[i].mind.output.take_outbox();
        for (to, payload) in outbox.drain(..) {
            if !self.robots[i].alive || self.robots[i].energy < kind.energy_per_message {
                break;
            }
            self.spend(i, kind.energy_per_message);
            let size = payload.size_bytes();
            self.send(i, kind, round, to, payload, turns);
            messages += 1;
            bytes += size;
            self.robots[i].stats.messages_sent += 1;
            self.robots[i].stats.message_bytes += size;
        }
        self.agents[i].mind.output.give_back_outbox(outbox);
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
        let alive = |to: usize, from: usize| if to < from { robots[to].alive } else { turns[to].alive };
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

    /// Disable a robot whose strategy failed, for good, dropping what it queued this round.
    fn fail(&mut self, i: usize, reason: String) {
        drop(self.agents[i].mind.output.take_outbox());
        let r = &mut self.robots[i];
        r.alive = false;
        r.last_action = (Action::Idle, Outcome::Refused);
        self.strategies_failed += 1;
        self.report.events.push(Event::StrategyFailed { robot: r.id, reason });
    }

    /// Charge energy; a robot that runs dry is disabled for good.
    fn spend(&mut self, i: usize, amount: f64) {
        if !charge(&mut self.robots[i], amount) {
            self.disable_dry(i);
        }
    }

    /// Disable a robot that [`charge`] left dry, for good.
    fn disable_dry(&mut self, i: usize) {
        let r = &mut self.robots[i];
        r.energy = 0.0;
        r.alive = false;
        self.report.events.push(Event::RobotDisabled { robot: r.id });
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
                if !kind.can_excavate() || t.buried == 0 || self.robots[i].energy < kind.energy_per_excavation {
                    return Outcome::Refused;
                }
                self.spend(i, kind.energy_per_excavation);
                let t = &mut self.treasures[treasure.index()];
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
                self.treasures[treasure.index()].loose -= amount;
                let cargo = &mut self.robots[i].cargo;
                match cargo.iter_mut().find(|c| c.0 == treasure) {
                    Some(c) => c.1 += amount,
                    None => cargo.push((treasure, amount)),
                }
                // `t` is the treasure as it was: units left lying because the cargo is full
                // mean the load was cut short.
                if amount < t.loose {
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
                    let t = &mut self.treasures[treasure.index()];
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
    fn reachable_treasure(&self, i: usize, kind: &RobotType, id: TreasureId) -> Option<TreasureState> {
        let t = *self.treasures.get(id.index())?;
        (t.position.distance(self.robots[i].position) <= kind.radius_m + REACH_M).then_some(t)
    }

    /// A move, trimmed to speed, energy, obstacles and other robots, in that order.
    fn apply_move(&mut self, i: usize, kind: &RobotType, to: DVec2) -> Outcome {
        let from = self.robots[i].position;
        let wanted = (to - from).length();
        if !wanted.is_finite() {
            return Outcome::Refused;
        }
        if wanted == 0.0 {
            return Outcome::Done;
        }
        let d = move_within_means(from, to, kind, self.robots[i].energy);
        // Other robots: halve the move until the end position overlaps nobody. Who could be
        // in the way depends only on the start of the round and the obstacle-trimmed move,
        // so step 2 listed them with the move's obstacle test; otherwise they are listed
        // here, once for the whole move, not once per halving.
        let mut near = std::mem::take(&mut self.near_scratch);
        let d = match self.agents[i].planned_move.take() {
            Some(p) if p.is_for(from, d, kind.radius_m) => {
                std::mem::swap(&mut near, &mut self.agents[i].planned_near);
                p.free
            }
            _ => {
                let d = trim_to_obstacles(&self.map.obstacles, from, d, kind.radius_m);
                self.bodies().near_move(i, from, d, kind.radius_m, &mut near);
                d
            }
        };
        let mut step = d;
        let mut tries = 0;
        // The robot in the way of one halving is mostly in the way of the next: it is asked
        // first (whether anyone overlaps does not depend on the order asked).
        let mut blocker = 0;
        while step.length() > 1e-9 && self.overlaps_any(&near, from + step, kind.radius_m, &mut blocker) {
            step *= 0.5;
            tries += 1;
            if tries > 8 {
                step = DVec2::ZERO;
            }
        }
        self.near_scratch = near;
        let (outcome, alive) = walk(&mut self.robots[i], from, step, wanted, kind);
        self.bodies_now[i].0 = self.robots[i].position;
        if !alive {
            self.disable_dry(i);
        }
        outcome
    }

    /// The start-of-round robots, for listing who could be in a move's way.
    pub(super) fn bodies(&self) -> Bodies<'_> {
        Bodies::new(&self.body_index, self.max_radius_m, self.max_speed_m)
    }

    /// Whether a disc at `p` would overlap one of `near` where it stands now; `near[first]`
    /// is asked first, and `first` is left at the one found.
    fn overlaps_any(&self, near: &[u32], p: DVec2, radius: f64, first: &mut usize) -> bool {
        let overlaps = |j: u32| {
            let (at, r) = self.bodies_now[j as usize];
            let rr = radius + r;
            at.distance_squared(p) < rr * rr
        };
        if near.get(*first).is_some_and(|&j| overlaps(j)) {
            return true;
        }
        match near.iter().position(|&j| overlaps(j)) {
            Some(k) => {
                *first = k;
                true
            }
            None => false,
        }
    }

    /// Address a message to the robots in range at send time (start-of-round positions).
    fn send(&mut self, i: usize, kind: &RobotType, round: u64, to: Recipient, payload: Payload, turns: &[Turn]) {
        let from = self.robots[i].id;
        let at = turns[i].start;
        let bytes = payload.size_bytes();
        let message = Message {
            from,
            sent_round: round,
            to,
            payload: Arc::new(payload),
        };
        if self.radio_limited {
            self.outgoing.push(Outgoing {
                from: i,
                range_m: kind.comm_radius_m,
                message,
                bytes,
            });
            return;
        }
        let direct: [RobotId; 1];
        let receivers: &[RobotId] = match to {
            // Listed in step 2 (see `Agent::hearers`).
            Recipient::Broadcast => &self.agents[i].hearers,
            Recipient::Direct(target) => {
                direct = [target];
                let in_range = turns
                    .get(target.index())
                    .is_some_and(|t| target != from && t.start.distance(at) <= kind.comm_radius_m);
                if in_range { &direct } else { &[] }
            }
        };
        // Stored once, in the bag the receivers share; each gets its index after step 3.
        if receivers.iter().any(|to| self.robots[to.index()].alive) {
            let bag = u32::try_from(self.mailbag.len()).expect("fewer than 2^32 messages a round");
            self.fanout.push(Fanout {
                from: u32::try_from(i).expect("robot indices are u32"),
                bag,
                to: match to {
                    Recipient::Broadcast => None,
                    Recipient::Direct(target) => Some(target.get()),
                },
            });
            self.mailbag.push(message);
        }
    }
}

/// Take `amount` of energy from a robot (as much as it has); `false` if that leaves it
/// dry, which disables it (the caller's part, with its event).
fn charge(r: &mut Robot, amount: f64) -> bool {
    let paid = amount.min(r.energy);
    r.energy -= paid;
    r.stats.energy_used += paid;
    r.energy > 1e-12
}

/// Take the step `step` from `from` of a move that asked for `wanted` metres, paying for it:
/// its outcome (refused when too short to count, nothing paid then), and `false` if paying
/// left the robot dry (disabling it is the caller's part). Both the id-order path and
/// [`resolve_alone`] end moves here, so they agree to the last rounding.
fn walk(r: &mut Robot, from: DVec2, step: DVec2, wanted: f64, kind: &RobotType) -> (Outcome, bool) {
    let moved = step.length();
    if moved <= 1e-12 {
        return (Outcome::Refused, true);
    }
    r.position = from + step;
    r.stats.distance_m += moved;
    let alive = charge(r, moved * kind.energy_per_m);
    let outcome = if (moved - wanted).abs() > 1e-9 {
        Outcome::Trimmed
    } else {
        Outcome::Done
    };
    (outcome, alive)
}

/// The end of a robot's turn in step 3: recharge at home, and the action viewers show. (Its
/// goal and path were published in step 2: [`publish_plan`].)
pub(super) fn end_of_turn(r: &mut Robot, kind: &RobotType, home: &HomeBase, last: (Action, Outcome)) {
    if r.alive && home.contains(r.position) {
        r.energy = (r.energy + kind.recharge_per_round).min(kind.energy_capacity);
    }
    r.last_action = last;
}

/// What viewers show of a robot's plan: the goal and path its strategy published this
/// round. Set in step 2, in parallel, for every robot whose strategy decided (those are
/// the robots whose turn ends in step 3 or [`resolve_alone`]), rather than in the
/// sequential step 3; nothing reads them before the round ends.
/// `published_goals_and_paths_reach_every_robot_that_decided` (tests/resolve.rs) checks it.
pub(super) fn publish_plan(r: &mut Robot, output: &StrategyOutput) {
    r.goal = output.goal();
    r.path.clear();
    r.path.extend_from_slice(output.path());
}

/// Resolve a robot's turn ahead of the id order (in step 2, right after it decided) if
/// nothing in it depends on another robot: it is idle, or moves with nobody within reach of
/// its move (step 2's list); it sends nothing, touches no treasure, did not fail, and keeps
/// enough energy to stay alive (so it raises no event). Returns `false`, changing nothing,
/// otherwise.
///
/// The outcome is the one the id order gives. Its own turn reads no other robot: nobody was
/// near its move (step 2's list, [`Bodies::near_move`]: robots before it farther than the
/// radii plus the top speed, so ending farther than the radii; robots after it, which the
/// order leaves where they started, farther than the radii). And no other robot's turn
/// depends on whether this one has moved yet: that matters only to robots before it, which
/// all started farther than the radii plus the top speed from this one's move, so move
/// farther than the two radii from both where this one started and where it ends. The
/// arithmetic is that of the id-order path ([`walk`]).
/// `turns_resolved_alone_give_the_id_order_run` (tests/kernel.rs) checks it.
pub(super) fn resolve_alone(r: &mut Robot, agent: &mut Agent, kind: &RobotType, home: &HomeBase) -> bool {
    if agent.failure.is_some() || !agent.mind.output.outbox().is_empty() {
        return false;
    }
    let up = upkeep(kind, agent.needs);
    let after_upkeep = r.energy - up.min(r.energy);
    if after_upkeep <= 1e-12 {
        return false;
    }
    let from = r.position;
    // The move, when there is one: its obstacle-free part and its length asked for.
    let step = match agent.action {
        Action::Idle => None,
        Action::MoveTo { to } => {
            let wanted = (to - from).length();
            if wanted.is_finite() && wanted > 0.0 {
                let d = move_within_means(from, to, kind, after_upkeep);
                match &agent.planned_move {
                    Some(p) if p.is_for(from, d, kind.radius_m) && agent.planned_near.is_empty() => {
                        Some((p.free, wanted))
                    }
                    _ => return false,
                }
            } else {
                None
            }
        }
        Action::Excavate { .. } | Action::Load { .. } | Action::Unload => return false,
    };
    let moved = step.map_or(0.0, |(free, _)| free.length());
    if moved > 1e-12 && after_upkeep - (moved * kind.energy_per_m).min(after_upkeep) <= 1e-12 {
        return false;
    }
    let alive = charge(r, up);
    debug_assert!(alive, "checked above");
    let outcome = match (agent.action, step) {
        (Action::MoveTo { to }, None) if !(to - from).length().is_finite() => Outcome::Refused,
        (_, None) => Outcome::Done,
        (_, Some((free, wanted))) => {
            let (outcome, alive) = walk(r, from, free, wanted, kind);
            debug_assert!(alive, "checked above");
            outcome
        }
    };
    agent.planned_move = None;
    end_of_turn(r, kind, home, (agent.action, outcome));
    true
}

/// Energy a live robot pays every round whatever it does: living, and sensing if its strategy
/// perceives anything.
pub(super) fn upkeep(kind: &RobotType, needs: Needs) -> f64 {
    let sense = if needs.senses() { kind.energy_per_sense } else { 0.0 };
    kind.energy_idle + sense
}

/// The move from `from` towards `to` trimmed to the robot's speed and to what `energy`
/// pays for. `to` must differ from `from` and be finite.
pub(super) fn move_within_means(from: DVec2, to: DVec2, kind: &RobotType, energy: f64) -> DVec2 {
    let mut d = to - from;
    let wanted = d.length();
    let mut len = wanted.min(kind.speed_m_per_round);
    if kind.energy_per_m > 0.0 {
        len = len.min(energy / kind.energy_per_m);
    }
    d *= len / wanted;
    d
}

/// The robots where they stood at the start of the round (the contact-sized index), for
/// listing who could be in a move's way.
pub(super) struct Bodies<'a> {
    index: &'a RobotIndex,
    max_radius_m: f64,
    max_speed_m: f64,
}

impl<'a> Bodies<'a> {
    pub(super) fn new(index: &'a RobotIndex, max_radius_m: f64, max_speed_m: f64) -> Self {
        Self {
            index,
            max_radius_m,
            max_speed_m,
        }
    }

    /// The robots (other than `i`) that could touch a disc of `radius` ending anywhere on
    /// the move `d` from `from`, with step 3's id order: robot `i` moves after those before
    /// it and before those after it. One before it has moved at most `max_speed_m`, so one
    /// touching an end point `p` started within `radius + max_radius_m + max_speed_m` of
    /// `p`, hence within that of the move's segment; one after it still stands where it
    /// started, so within `radius + max_radius_m`.
    ///
    /// Robots that [`resolve_alone`] moved ahead of the order are no exception: one after
    /// `i` in a list could not have been alone, as `i` started within the reach of its move.
    /// `a_move_meets_robots_before_it_where_they_moved_and_after_it_where_they_stand`
    /// (tests/resolve.rs) checks both reaches.
    pub(super) fn near_move(&self, i: usize, from: DVec2, d: DVec2, radius: f64, near: &mut Vec<u32>) {
        near.clear();
        let reach = radius + self.max_radius_m + self.max_speed_m;
        // Wider by far more than any rounding: listing one robot too many changes nothing.
        let widen = |r: f64| (r * (1.0 + 1e-9)).powi(2);
        let (moved, standing) = (widen(reach), widen(radius + self.max_radius_m));
        let (to, mid) = (from + d, from + 0.5 * d);
        let r = reach + 0.5 * d.length();
        let r2 = r * r;
        let i = u32::try_from(i).expect("robot indices are u32");
        let sift = Sift {
            i,
            mid,
            r2,
            from,
            to,
            moved,
            standing,
        };
        // At most three rows when the index's cells are as wide as its queries (see
        // `rebuild_robot_indexes`); a fourth for rounding.
        let mut runs = [(0, 0); 4];
        if let Some(n) = self.index.dense_runs_near(mid, r, &mut runs) {
            let entries = self.index.entries();
            for &(a, b) in &runs[..n] {
                sift.run(&entries[a as usize..b as usize], None, near);
            }
        } else {
            self.index
                .for_each_run_near(mid, r, |_, run, cell| sift.run(run, cell, near));
        }
    }
}

/// The tests of [`Bodies::near_move`] for robot `i`'s move from `from` to `to`.
struct Sift {
    i: u32,
    /// The move's middle and the squared radius around it of the first, cheap test.
    mid: DVec2,
    r2: f64,
    from: DVec2,
    to: DVec2,
    /// Squared reach from the move of robots before `i` (which may have moved) and after it.
    moved: f64,
    standing: f64,
}

impl Sift {
    /// Append to `near` the robots of `run` (of `cell`, see
    /// [`RobotIndex::for_each_run_near`]) that could touch the move.
    ///
    /// The robots are tested without a branch per robot, as in a crowd each test goes
    /// either way. Two passes over each chunk of up to 64 robots: the cheap disc test
    /// first, into a bit per robot, then the segment test (a division) only on the robots
    /// kept, each appended and kept or not by its length.
    #[inline]
    fn run(&self, run: &[IndexEntry], cell: Option<(i32, i32)>, near: &mut Vec<u32>) {
        for chunk in run.chunks(64) {
            let mut in_disc = 0u64;
            for (k, e) in chunk.iter().enumerate() {
                // Bitwise on purpose: every test is made, none is a branch.
                #[allow(clippy::needless_bitwise_bool)]
                let keep = cell.is_none_or(|c| e.cell == c)
                    & (e.position.distance_squared(self.mid) <= self.r2)
                    & (e.id.get() != self.i);
                in_disc |= u64::from(keep) << k;
            }
            while in_disc != 0 {
                let e = &chunk[in_disc.trailing_zeros() as usize];
                in_disc &= in_disc - 1;
                let id = e.id.get();
                let within = if id < self.i { self.moved } else { self.standing };
                let touches = point_segment_distance_squared(e.position, self.from, self.to) <= within;
                near.push(id);
                near.truncate(near.len() - usize::from(!touches));
            }
        }
    }
}

/// The part of move `d` from `from` that a disc of `radius_m` sweeps free of obstacles: all
/// of it, or the largest free fraction found by bisection.
pub(super) fn trim_to_obstacles(obstacles: &ObstacleMap, from: DVec2, d: DVec2, radius_m: f64) -> DVec2 {
    if obstacles.is_swept_disc_free(from, from + d, radius_m) {
        return d;
    }
    d * obstacles.swept_disc_free_fraction(from, d, radius_m)
}
