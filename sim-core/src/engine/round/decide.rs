//! Step 2: every live robot's strategy decides one action and its messages, in parallel;
//! each robot owns its strategy and data, nothing shared is written.

use std::cell::RefCell;
use std::panic::AssertUnwindSafe;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use glam::DVec2;
use rayon::prelude::*;

use super::contact::{Bodies, trim_to_obstacles};
use super::perceive::{Snapshot, hand_out, perceive};
use super::resolve::TurnKind;
use super::turn::{move_within_means, publish_plan, resolve_alone, upkeep};
use crate::agent::{Ctx, StrategyFailure, WorldView};
use crate::engine::simulation::{Agent, PlannedMove, Simulation, Turn};
use crate::spatial::{KnownMap, ObstacleMap, RobotId, RobotIndex};
use crate::world::{Action, HomeBase, Message, Recipient, Robot, RobotType};

/// The most robots one parallel task takes. Rayon splits a slice in halves only while
/// workers are idle, so uncapped, workers end up with a few large runs of robots; robots
/// differ in cost (a crowd of explorers merging maps beside idle diggers), so one worker is
/// left with the last run while the others wait. Small runs balance them. A task writes
/// only its own robots' data, so the split changes no result:
/// `results_do_not_depend_on_the_thread_count` (tests/kernel.rs).
pub(super) const ROBOTS_PER_TASK: usize = 16;

impl Simulation {
    /// Steps 1 and 2, in parallel over robots. Returns whether some turn has news (see
    /// `Turn::news`).
    pub(super) fn perceive_and_decide(&mut self, round: u64, mailbag: Option<&Arc<Vec<Message>>>) -> bool {
        let step = Step2 {
            round,
            seed: self.seed,
            world: WorldView::new(&self.map.obstacles, &self.nav, self.map.home, &self.types)
                .with_time_planning(self.time_planning),
            snapshot: Snapshot {
                type_of: &self.type_of,
                treasures: &self.treasures,
                treasure_index: &self.treasure_index,
                robot_index: &self.robot_index,
            },
            types: &self.types,
            obstacles: &self.map.obstacles,
            bodies: Bodies::new(&self.body_index, self.max_radius_m, self.max_speed_m),
            limit: self.decide_limit,
            // Without strategies that perceive robots the view-sized index is built only when
            // someone broadcasts: their hearers are listed after this pass.
            robot_index: self.robot_index_eager.then_some(&self.robot_index),
            radio_limited: self.radio_limited,
            home: self.map.home,
            alone_allowed: self.resolve_alone,
            planning_ns: AtomicU64::new(0),
            pending: AtomicBool::new(false),
            any_news: AtomicBool::new(false),
            unknown: AtomicBool::new(false),
        };
        let held = AtomicBool::new(false);
        let (marks, roles, slots) = self.step3.step2_marks();
        self.agents
            .par_iter_mut()
            .zip(self.robots.par_iter_mut())
            .zip(self.turns.par_iter_mut())
            .zip(self.bodies_now.par_iter_mut())
            .zip(self.inboxes.par_iter_mut())
            .zip(roles.par_iter_mut().zip(slots.par_iter_mut()))
            .with_max_len(ROBOTS_PER_TASK)
            .for_each(|(((((agent, robot), turn), body), picks), (role, slot))| {
                // Last round's messages first: only this robot's perception reads them.
                if let Some(bag) = mailbag
                    && hand_out(agent, picks, bag)
                {
                    held.store(true, Ordering::Relaxed);
                }
                step.robot_turn(agent, robot, turn, body);
                marks.mark(turn, role, slot);
            });
        if mailbag.is_some() {
            self.inboxes_held = held.into_inner();
        }
        let Step2 {
            planning_ns,
            pending,
            any_news,
            unknown,
            ..
        } = step;
        self.step3.unknown = unknown.into_inner();
        if pending.into_inner() {
            self.list_pending_hearers();
        }
        self.phase_times.planning += Duration::from_nanos(planning_ns.into_inner());
        if self.decide_limit.is_some() {
            let slow = self
                .turns
                .iter()
                .zip(&self.robots)
                .filter_map(|(t, r)| t.slow.map(|took| (r.id, took)));
            self.report.slow_decisions.extend(slow);
        }
        any_news.into_inner()
    }

    /// The hearers of the broadcasts step 2 left pending (see `Turn::hearers_pending`), on
    /// the view-sized index, built now.
    fn list_pending_hearers(&mut self) {
        self.rebuild_robot_index_at_start();
        let index = &self.robot_index;
        self.agents
            .par_iter_mut()
            .zip(self.turns.par_iter())
            .zip(self.robots.par_iter())
            .with_max_len(ROBOTS_PER_TASK)
            .filter(|((_, turn), _)| turn.hearers_pending)
            .for_each(|((agent, turn), robot)| {
                let range_m = self.types[robot.type_index].comm_radius_m;
                hearers(index, robot.id, turn.start, range_m, &mut agent.hearers);
            });
    }
}

/// The robots other than `robot` within `range_m` of where it stands (the start-of-round
/// index), by id: who hears its broadcasts. In step 2, in parallel, rather than in the
/// sequential step 3.
fn hearers(index: &RobotIndex, id: RobotId, at: DVec2, range_m: f64, out: &mut Vec<RobotId>) {
    thread_local! {
        /// A bit per robot, all clear between calls.
        static HEARD: RefCell<Vec<u64>> = const { RefCell::new(Vec::new()) };
    }
    index.for_each_within(at, range_m, |other, _| {
        if other != id {
            out.push(other);
        }
    });
    if out.len() <= 32 {
        out.sort_unstable();
        return;
    }
    // In a crowd, hundreds: put them in id order by a bit per robot, read back word by
    // word, rather than by a sort.
    HEARD.with(|heard| {
        let mut bits = heard.borrow_mut();
        let words = out.iter().map(|id| id.index() / 64 + 1).max().unwrap_or(0);
        if bits.len() < words {
            bits.resize(words, 0);
        }
        for id in out.iter() {
            bits[id.index() / 64] |= 1 << (id.index() % 64);
        }
        out.clear();
        for (w, word) in bits.iter_mut().enumerate().take(words) {
            while *word != 0 {
                let b = word.trailing_zeros() as usize;
                *word &= *word - 1;
                out.push(RobotId::new(u32::try_from(w * 64 + b).expect("robot ids are u32")));
            }
        }
    });
}

/// What every robot's steps 1 and 2 share in a round.
struct Step2<'a> {
    round: u64,
    seed: u64,
    world: WorldView<'a>,
    snapshot: Snapshot<'a>,
    types: &'a [RobotType],
    obstacles: &'a ObstacleMap,
    bodies: Bodies<'a>,
    limit: Option<Duration>,
    robot_index: Option<&'a RobotIndex>,
    radio_limited: bool,
    home: HomeBase,
    alone_allowed: bool,
    planning_ns: AtomicU64,
    pending: AtomicBool,
    any_news: AtomicBool,
    /// Some turn is [`TurnKind::Unknown`].
    unknown: AtomicBool,
}

impl Step2<'_> {
    /// One robot's steps 1 and 2, and what the sequential steps will read of its turn.
    #[inline]
    fn robot_turn(&self, agent: &mut Agent, robot: &mut Robot, turn: &mut Turn, body: &mut (DVec2, f64)) {
        turn.begin(robot.position, robot.alive);
        agent.mind.output.begin_round();
        agent.planned_move = None;
        if robot.alive {
            self.perceive_and_decide(agent, robot, turn);
        } else {
            agent.action = Action::Idle;
        }
        *body = (robot.position, self.types[robot.type_index].radius_m);
        turn.known_bytes = agent.mind.data.known.as_ref().map_or(0, KnownMap::memory_bytes);
        turn.news = !agent.mind.perception.treasures.is_empty() || !agent.mind.output.events().is_empty();
        if turn.news {
            self.any_news.store(true, Ordering::Relaxed);
        }
    }

    /// A live robot perceives and its strategy decides; a panic disables it (step 3 logs
    /// why), and nothing it did this round is kept.
    #[inline]
    fn perceive_and_decide(&self, agent: &mut Agent, robot: &mut Robot, turn: &mut Turn) {
        let kind = &self.types[robot.type_index];
        turn.sensed_m = agent.needs.senses().then_some(kind.view_radius_m);
        perceive(agent, turn, robot, kind, &self.snapshot, self.round);
        let rng = Simulation::rng_for(self.seed, robot.id, self.round);
        let mut ctx = Ctx::new(self.round, robot, kind, self.world, rng, &mut agent.mind);
        let strategy = &mut agent.strategy;
        // A coarse clock (a few milliseconds' resolution, cheaper than a precise one) is
        // ample for limits of tens of milliseconds.
        let started = self.limit.map(|_| coarsetime::Instant::now());
        let decided = std::panic::catch_unwind(AssertUnwindSafe(|| strategy.decide(&mut ctx)));
        let planned_ns = ctx.planning_ns();
        if planned_ns > 0 {
            self.planning_ns.fetch_add(planned_ns, Ordering::Relaxed);
        }
        turn.slow = started
            .map(|t| Duration::from(t.elapsed()))
            .filter(|&took| self.limit.is_some_and(|limit| took > limit));
        match decided {
            Ok(action) => self.take(agent, robot, turn, kind, action),
            Err(payload) => {
                agent.action = Action::Idle;
                agent.failure = Some(panic_message(payload.as_ref()));
            }
        }
    }

    /// What follows a decision in step 2: the move's obstacle test and contact list, the
    /// hearers of its broadcasts, and the whole turn of a robot that depends on nobody.
    #[inline]
    fn take(&self, agent: &mut Agent, robot: &mut Robot, turn: &mut Turn, kind: &RobotType, action: Action) {
        agent.action = action;
        publish_plan(robot, &agent.mind.output);
        agent.planned_move = plan_move(agent, robot, kind, self.obstacles, &self.bodies, &mut turn.near);
        agent.hearers.clear();
        let broadcasts = agent
            .mind
            .output
            .outbox()
            .iter()
            .any(|(to, _)| *to == Recipient::Broadcast);
        if broadcasts && !self.radio_limited {
            if let Some(index) = self.robot_index {
                hearers(index, robot.id, turn.start, kind.comm_radius_m, &mut agent.hearers);
            } else {
                turn.hearers_pending = true;
                self.pending.store(true, Ordering::Relaxed);
            }
        }
        // Step 3 for a robot whose turn depends on nobody, while its data are at hand.
        turn.alone = self.alone_allowed && resolve_alone(robot, agent, &turn.near, kind, &self.home);
        if !turn.alone {
            turn.kind = TurnKind::of(robot, agent, kind);
            if matches!(turn.kind, TurnKind::Unknown) {
                self.unknown.store(true, Ordering::Relaxed);
            }
        }
    }
}

/// What a panic said (its message, when it was a string).
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(StrategyFailure(reason)) = payload.downcast_ref::<StrategyFailure>() {
        return format!("its strategy failed: {reason}");
    }
    match (payload.downcast_ref::<&str>(), payload.downcast_ref::<String>()) {
        (Some(s), _) => format!("its strategy panicked: {s}"),
        (_, Some(s)) => format!("its strategy panicked: {s}"),
        _ => "its strategy panicked".to_owned(),
    }
}

/// The obstacle test of this round's move, if it is one, done here in parallel rather than
/// in the sequential step 3: with the energy step 3 will leave the robot before it moves
/// (upkeep is charged first), the same trim to speed and energy, the same bisection; and
/// the robots that could be in its way (into `near`).
// Inlined into step 2's per-robot closure, its only caller: left to itself the compiler
// flips between inlining it or not as the queries under it change size.
#[inline]
fn plan_move(
    agent: &Agent,
    robot: &Robot,
    kind: &RobotType,
    obstacles: &ObstacleMap,
    bodies: &Bodies,
    near: &mut Vec<u32>,
) -> Option<PlannedMove> {
    let Action::MoveTo { to } = agent.action else {
        return None;
    };
    let from = robot.position;
    let wanted = (to - from).length();
    if !wanted.is_finite() || wanted == 0.0 {
        return None;
    }
    let energy = robot.energy - upkeep(kind, agent.needs).min(robot.energy);
    if energy <= 1e-12 {
        return None;
    }
    let d = move_within_means(from, to, kind, energy);
    let free = trim_to_obstacles(obstacles, from, d, kind.radius_m);
    bodies.near_move(robot.id.index(), from, free, kind.radius_m, near);
    Some(PlannedMove {
        from,
        d,
        radius_m: kind.radius_m,
        free,
    })
}
