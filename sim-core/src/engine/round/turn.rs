//! One robot's turn in step 3: it pays its upkeep, its action is checked and carried out
//! (speed, energy, obstacles, other robots, abilities, reach, capacity), and its messages
//! are paid for. The same code takes turns in id order and side by side.

use std::sync::{Mutex, PoisonError};

use glam::DVec2;

use super::contact::{Bodies, trim_to_obstacles};
use crate::agent::{Needs, StrategyOutput};
use crate::engine::simulation::Agent;
use crate::spatial::{ObstacleMap, TreasureId};
use crate::world::{Action, Event, HomeBase, MapData, Outcome, REACH_M, Robot, RobotType, TreasureState};

/// What step 3's turns collect for the round, merged in id order after them.
#[derive(Debug, Default)]
pub(super) struct TurnsOut {
    /// Events raised, with the raising robot's index, each robot's in order.
    pub(super) events: Vec<(u32, Event)>,
    /// Robots that paid for messages (see `Agent::paid_sends`).
    pub(super) senders: Vec<u32>,
    /// Strategies that failed.
    pub(super) failed: u32,
}

impl TurnsOut {
    pub(super) fn merge(mut self, other: Self) -> Self {
        self.merge_from(other);
        self
    }

    pub(super) fn merge_from(&mut self, mut other: Self) {
        self.events.append(&mut other.events);
        self.senders.append(&mut other.senders);
        self.failed += other.failed;
    }
}

/// What every turn of step 3 reads, and the treasures they dig and carry. A turn writes
/// only its own robot, agent and body, and the treasures its action names; turns at
/// treasures go one after another.
pub(super) struct TurnWorld<'a> {
    types: &'a [RobotType],
    home: HomeBase,
    obstacles: &'a ObstacleMap,
    treasures: Mutex<&'a mut Vec<TreasureState>>,
}

/// A move in id order: every robot's body where it stands now (robots before it where
/// their moves ended, robots after it where they started), to test and then to note where
/// it ends; its contact list from step 2; and the start-of-round robots, to list who could
/// be in its way when step 2 did not (into `near_scratch`).
pub(super) struct InOrder<'b, 'a> {
    pub(super) bodies_now: &'b mut [(DVec2, f64)],
    pub(super) bodies: &'b Bodies<'a>,
    pub(super) near: &'b [u32],
    pub(super) near_scratch: &'b mut Vec<u32>,
}

/// How a turn's move meets the robots in its way.
pub(super) enum Way<'b, 'a> {
    /// In id order (see [`InOrder`]).
    InOrder(InOrder<'b, 'a>),
    /// Settled ahead (see [`SettledMoves`](super::moves::SettledMoves)): its step, if it
    /// moves, and its body.
    Settled(Option<DVec2>, &'b mut (DVec2, f64)),
}

impl<'a> TurnWorld<'a> {
    pub(super) fn new(types: &'a [RobotType], map: &'a MapData, treasures: &'a mut Vec<TreasureState>) -> Self {
        Self {
            types,
            home: map.home,
            obstacles: &map.obstacles,
            treasures: Mutex::new(treasures),
        }
    }

    /// Robot `i`'s turn.
    #[inline]
    pub(super) fn take_turn(&self, i: usize, robot: &mut Robot, agent: &mut Agent, way: Way, out: &mut TurnsOut) {
        if !robot.alive {
            return;
        }
        if let Some(reason) = agent.failure.take() {
            fail(i, robot, agent, reason, out);
            return;
        }
        let kind = &self.types[robot.type_index];
        let action = agent.action;
        spend(i, robot, upkeep(kind, agent.needs), out);
        let outcome = if robot.alive {
            self.apply(i, robot, agent, kind, action, way, out)
        } else {
            Outcome::Refused
        };
        // Most turns send nothing: their outbox is left alone.
        if !agent.mind.output.outbox().is_empty() {
            pay_for_sends(i, robot, agent, kind, out);
        }
        end_of_turn(robot, kind, &self.home, (action, outcome));
    }

    /// Check and carry out one action.
    #[allow(clippy::too_many_arguments)] // The turn's parts, each borrowed apart.
    #[inline]
    fn apply(
        &self,
        i: usize,
        robot: &mut Robot,
        agent: &mut Agent,
        kind: &RobotType,
        action: Action,
        way: Way,
        out: &mut TurnsOut,
    ) -> Outcome {
        match action {
            Action::Idle => Outcome::Done,
            Action::MoveTo { to } => self.apply_move(i, robot, agent, kind, to, way, out),
            Action::Excavate { treasure } => {
                let mut treasures = self.treasures.lock().unwrap_or_else(PoisonError::into_inner);
                excavate(i, robot, kind, &mut treasures, treasure, out)
            }
            Action::Load { treasure } => {
                let mut treasures = self.treasures.lock().unwrap_or_else(PoisonError::into_inner);
                load(robot, kind, &mut treasures, treasure)
            }
            Action::Unload => {
                if robot.cargo.is_empty() || !self.home.contains(robot.position) {
                    return Outcome::Refused;
                }
                let mut treasures = self.treasures.lock().unwrap_or_else(PoisonError::into_inner);
                unload(i, robot, &mut treasures, out);
                Outcome::Done
            }
        }
    }

    /// A move, trimmed to speed, energy, obstacles and other robots, in that order.
    #[allow(clippy::too_many_arguments)] // The turn's parts, each borrowed apart.
    #[inline]
    fn apply_move(
        &self,
        i: usize,
        robot: &mut Robot,
        agent: &mut Agent,
        kind: &RobotType,
        to: DVec2,
        way: Way,
        out: &mut TurnsOut,
    ) -> Outcome {
        let from = robot.position;
        let wanted = (to - from).length();
        if !wanted.is_finite() {
            return Outcome::Refused;
        }
        if wanted == 0.0 {
            return Outcome::Done;
        }
        let (step, body) = match way {
            Way::InOrder(mut way) => {
                let step = self.step_in_order(i, robot, agent, kind, to, &mut way);
                (step, &mut way.bodies_now[i])
            }
            Way::Settled(step, body) => {
                agent.planned_move = None;
                // A robot that outlives its upkeep and moves has a planned move (step 2),
                // which `TurnKind::of` makes a mover whose step is settled.
                (step.expect("a move taken side by side is settled first"), body)
            }
        };
        let (outcome, alive) = walk(robot, from, step, wanted, kind);
        body.0 = robot.position;
        if !alive {
            disable_dry(i, robot, out);
        }
        outcome
    }

    /// The step of robot `i`'s move towards `to`, other robots where they stand now.
    #[allow(clippy::too_many_arguments)] // The turn's parts, each borrowed apart.
    #[inline]
    fn step_in_order(
        &self,
        i: usize,
        robot: &Robot,
        agent: &mut Agent,
        kind: &RobotType,
        to: DVec2,
        way: &mut InOrder,
    ) -> DVec2 {
        let from = robot.position;
        let d = move_within_means(from, to, kind, robot.energy);
        // Who could be in the way depends only on the start of the round and the
        // obstacle-trimmed move, so step 2 listed them with the move's obstacle test;
        // otherwise they are listed here, once for the whole move, not once per halving.
        let (d, near) = match agent.planned_move.take() {
            Some(p) if p.is_for(from, d, kind.radius_m) => (p.free, way.near),
            _ => {
                let d = trim_to_obstacles(self.obstacles, from, d, kind.radius_m);
                way.bodies.near_move(i, from, d, kind.radius_m, way.near_scratch);
                (d, way.near_scratch.as_slice())
            }
        };
        let bodies_now = &*way.bodies_now;
        halve_until_free(from, d, kind.radius_m, near.len(), |k| bodies_now[near[k] as usize])
    }
}

/// The part of the obstacle-free move `free` from `from` that a disc of `radius_m` takes
/// among `count` bodies, `body_of(k)` the `k`-th (where it stands, its radius): the move
/// halved until its end overlaps none of them (after 8 halvings, no move). Both ways of
/// taking turns settle moves here, so they agree to the bit.
#[inline]
pub(super) fn halve_until_free(
    from: DVec2,
    free: DVec2,
    radius_m: f64,
    count: usize,
    body_of: impl Fn(usize) -> (DVec2, f64),
) -> DVec2 {
    let overlaps = |p: DVec2, k: usize| {
        let (at, r) = body_of(k);
        let rr = radius_m + r;
        at.distance_squared(p) < rr * rr
    };
    let mut step = free;
    let mut tries = 0;
    // The body in the way of one halving is mostly in the way of the next: it is asked
    // first (whether any overlaps does not depend on the order asked).
    let mut blocker = 0;
    while step.length() > 1e-9 {
        let p = from + step;
        if blocker < count && overlaps(p, blocker) {
        } else if let Some(k) = (0..count).find(|&k| overlaps(p, k)) {
            blocker = k;
        } else {
            break;
        }
        step *= 0.5;
        tries += 1;
        if tries > 8 {
            step = DVec2::ZERO;
        }
    }
    step
}

/// Where a body starting at `from` stands after the step `step`, as [`walk`] moves it.
pub(super) fn end_of_step(from: DVec2, step: DVec2) -> DVec2 {
    if step.length() > 1e-12 { from + step } else { from }
}

/// Dig at a treasure within reach.
fn excavate(
    i: usize,
    robot: &mut Robot,
    kind: &RobotType,
    treasures: &mut [TreasureState],
    treasure: TreasureId,
    out: &mut TurnsOut,
) -> Outcome {
    let Some(t) = reachable_treasure(robot, kind, treasures, treasure) else {
        return Outcome::Refused;
    };
    if !kind.can_excavate() || t.buried == 0 || robot.energy < kind.energy_per_excavation {
        return Outcome::Refused;
    }
    spend(i, robot, kind.energy_per_excavation, out);
    let t = &mut treasures[treasure.index()];
    let dug = kind.excavation_per_round.min(t.buried);
    t.buried -= dug;
    t.loose += dug;
    robot.stats.units_dug += u64::from(dug);
    if t.buried == 0 {
        out.events.push((
            u32::try_from(i).expect("robot indices are u32"),
            Event::TreasureExcavated { treasure, by: robot.id },
        ));
    }
    if dug < kind.excavation_per_round {
        Outcome::Trimmed
    } else {
        Outcome::Done
    }
}

/// Load loose units of a treasure within reach, as many as the cargo holds.
fn load(robot: &mut Robot, kind: &RobotType, treasures: &mut [TreasureState], treasure: TreasureId) -> Outcome {
    let Some(t) = reachable_treasure(robot, kind, treasures, treasure) else {
        return Outcome::Refused;
    };
    let room = kind.carry_capacity.saturating_sub(robot.load());
    let amount = room.min(t.loose);
    if amount == 0 {
        return Outcome::Refused;
    }
    treasures[treasure.index()].loose -= amount;
    match robot.cargo.iter_mut().find(|c| c.0 == treasure) {
        Some(c) => c.1 += amount,
        None => robot.cargo.push((treasure, amount)),
    }
    // `t` is the treasure as it was: units left lying because the cargo is full mean the
    // load was cut short.
    if amount < t.loose {
        Outcome::Trimmed
    } else {
        Outcome::Done
    }
}

/// Deliver the whole cargo of a robot at home.
fn unload(i: usize, robot: &mut Robot, treasures: &mut [TreasureState], out: &mut TurnsOut) {
    for (treasure, amount) in std::mem::take(&mut robot.cargo) {
        let t = &mut treasures[treasure.index()];
        t.delivered += amount;
        robot.stats.units_delivered += u64::from(amount);
        if t.delivered == t.initial {
            out.events.push((
                u32::try_from(i).expect("robot indices are u32"),
                Event::TreasureDelivered { treasure, by: robot.id },
            ));
        }
    }
}

/// The treasure, if it exists and lies within the robot's reach.
fn reachable_treasure(
    robot: &Robot,
    kind: &RobotType,
    treasures: &[TreasureState],
    id: TreasureId,
) -> Option<TreasureState> {
    let t = *treasures.get(id.index())?;
    (t.position.distance(robot.position) <= kind.radius_m + REACH_M).then_some(t)
}

/// Pay, in order, for what robot `i` queued this round while it lives and can pay for
/// each message; the paid ones wait in `Agent::paid_sends` to be addressed after the
/// turns.
fn pay_for_sends(i: usize, robot: &mut Robot, agent: &mut Agent, kind: &RobotType, out: &mut TurnsOut) {
    let mut outbox = agent.mind.output.take_outbox();
    let mut paid = 0;
    for (_, payload) in &outbox {
        if !robot.alive || robot.energy < kind.energy_per_message {
            break;
        }
        spend(i, robot, kind.energy_per_message, out);
        let size = payload.size_bytes();
        robot.stats.messages_sent += 1;
        robot.stats.message_bytes += size;
        paid += 1;
    }
    outbox.truncate(paid);
    if paid > 0 {
        out.senders.push(u32::try_from(i).expect("robot indices are u32"));
    }
    std::mem::swap(&mut agent.paid_sends, &mut outbox);
    agent.mind.output.give_back_outbox(outbox);
}

/// Disable a robot whose strategy failed, for good, dropping what it queued this round.
fn fail(i: usize, robot: &mut Robot, agent: &mut Agent, reason: String, out: &mut TurnsOut) {
    drop(agent.mind.output.take_outbox());
    robot.alive = false;
    robot.last_action = (Action::Idle, Outcome::Refused);
    out.failed += 1;
    out.events.push((
        u32::try_from(i).expect("robot indices are u32"),
        Event::StrategyFailed {
            robot: robot.id,
            reason,
        },
    ));
}

/// Charge energy; a robot that runs dry is disabled for good.
fn spend(i: usize, robot: &mut Robot, amount: f64, out: &mut TurnsOut) {
    if !charge(robot, amount) {
        disable_dry(i, robot, out);
    }
}

/// Disable a robot that [`charge`] left dry, for good.
fn disable_dry(i: usize, robot: &mut Robot, out: &mut TurnsOut) {
    robot.energy = 0.0;
    robot.alive = false;
    out.events.push((
        u32::try_from(i).expect("robot indices are u32"),
        Event::RobotDisabled { robot: robot.id },
    ));
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
pub(super) fn resolve_alone(r: &mut Robot, agent: &mut Agent, near: &[u32], kind: &RobotType, home: &HomeBase) -> bool {
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
                    Some(p) if p.is_for(from, d, kind.radius_m) && near.is_empty() => Some((p.free, wanted)),
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
