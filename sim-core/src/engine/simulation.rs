//! A simulation run: its world, robots and agents, set up from a validated [`Scenario`].
//! The round loop itself is in `round/`; observers drive it through
//! `Simulation::run`, defined in the io layer.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use glam::DVec2;
use rand::SeedableRng;
use rayon::prelude::*;

use crate::Result;
use crate::agent::{DataModule, Mind, Needs, RobotRng, Strategy};
use crate::engine::round::{ExploredBuffers, Step3, TurnKind};
use crate::engine::scenario::{Group, Scenario, ScenarioParts};
use crate::spatial::{
    BlockMemo, CellSet, Disc, Grid, KnownMap, LazyNavGraph, NavGraph, ObstacleMap, RobotId, RobotIndex, TreasureId,
    TreasureIndex,
};
use crate::world::{
    Action, ExploredMilestones, Link, MapData, Message, Payload, Recipient, Robot, RobotType, RoundMetrics,
    RoundReport, TreasureState,
};

/// A message sent in step 3 without radio budgets, for [`Simulation::inboxes`] after it:
/// bagged as `mailbag[bag]` by robot index `from`, to `to` (a robot index) or, if `None`,
/// to the sender's hearers. Step 3 only notes it; the receivers' inboxes are filled in
/// parallel afterwards, receiver by receiver, in sending order.
#[derive(Clone, Copy, Debug)]
pub(super) struct Fanout {
    pub(super) from: u32,
    pub(super) bag: u32,
    pub(super) to: Option<u32>,
}

/// Known cells of the last map merged from each sender.
pub(super) type MergedFrom = HashMap<RobotId, u64, foldhash::fast::FixedState>;

/// A robot's brain: its strategy and mind, owned by the robot alone.
pub(super) struct Agent {
    pub(super) strategy: Box<dyn Strategy>,
    pub(super) needs: Needs,
    pub(super) mind: Mind,
    pub(super) action: Action,
    /// Known cells of the last map merged from each sender: a map that has not grown since
    /// is already contained in ours (maps only grow), so merging it again is skipped.
    pub(super) merged_from: MergedFrom,
    /// This round's move with obstacles already accounted for, worked out in parallel in
    /// step 2 (see [`PlannedMove`]).
    pub(super) planned_move: Option<PlannedMove>,
    /// If it broadcasts this round (and radios have no budget): the robots in its
    /// communication range at the start of the round, by id, listed in parallel in step 2
    /// (step 3 addresses the broadcasts to those still alive). Empty otherwise.
    pub(super) hearers: Vec<RobotId>,
    /// Why its strategy failed this round (it panicked): step 3 disables the robot.
    pub(super) failure: Option<String>,
    /// The messages its turn in step 3 paid for, in order, until they are addressed after
    /// the round's turns (empty otherwise).
    pub(super) paid_sends: Vec<(Recipient, Payload)>,
}

/// What step 2 leaves of a robot's turn for the rest of the round, apart from its agent:
/// the round's sequential parts read a few bytes a robot here instead of a robot's whole
/// agent. Written in steps 1 and 2, read-only for the rest of the round;
/// `map_explored_once_and_every_free_cell_credited_once` and
/// `reports_list_changed_maps_and_first_sightings` (tests/kernel.rs) check the round's
/// accounting built from it.
#[derive(Clone, Debug, Default)]
#[allow(clippy::struct_excessive_bools)] // Independent facts of one round, each read by its own pass.
pub(super) struct Turn {
    /// Where it stood at the start of the round.
    pub(super) start: DVec2,
    /// It was alive at the start of the round, and so when step 3 began (step 2 disables
    /// nobody): a send reaches a robot alive at send time, so this for robots after the
    /// sender in id order.
    pub(super) alive: bool,
    /// Its view radius, if it perceived this round (alive and sensing): its view then
    /// counts for the collective explored map.
    pub(super) sensed_m: Option<f64>,
    /// It keeps a known map (then `new_squares` is all its view can add to the collective
    /// map).
    pub(super) has_known: bool,
    /// Its known map changed this round.
    pub(super) known_changed: bool,
    /// Cells its own view added to its known map this round: the only cells it can be
    /// first to explore (what it knew before was seen, by it or another, in an earlier
    /// round), so the collective map is updated from these instead of from its view disc.
    pub(super) new_squares: Vec<CellSet>,
    /// Heap bytes of its known map after step 2 (steps 3 and 4 do not change it).
    pub(super) known_bytes: usize,
    /// It saw treasures or raised events: the round's report takes something from its
    /// agent (see `record_discoveries`; a changed known map is read from `known_changed`,
    /// without touching the agent).
    pub(super) news: bool,
    /// Resolved in step 2, nothing in its turn depending on another robot (see
    /// `resolve_alone`).
    pub(super) alone: bool,
    /// With a planned move (see `Agent::planned_move`): the robots that could be in its way
    /// (see `Bodies::near_move`), listed in step 2 for step 3's contact test.
    pub(super) near: Vec<u32>,
    /// How step 3 takes its turn side by side with others.
    pub(super) kind: TurnKind,
    /// Its broadcasts' hearers are to be listed after step 2 (the view-sized index was not
    /// built for this round: no strategy perceives robots).
    pub(super) hearers_pending: bool,
    /// How long its strategy took to decide, when over the limit.
    pub(super) slow: Option<Duration>,
}

impl Turn {
    /// A fresh turn for a robot standing at `start`, `alive` or not (`has_known` and the
    /// buffer of squares' capacity are kept).
    pub(super) fn begin(&mut self, start: DVec2, alive: bool) {
        self.start = start;
        self.alive = alive;
        self.sensed_m = None;
        self.known_changed = false;
        self.news = false;
        self.alone = false;
        self.near.clear();
        self.kind = TurnKind::Free;
        self.hearers_pending = false;
        self.slow = None;
        self.new_squares.clear();
    }
}

/// A move's obstacle test done ahead of step 3: the robot standing at `from` moving by `d`
/// (already trimmed to speed and energy) with a body of `radius_m` gets as far as `free`
/// before an obstacle. It depends on nothing another robot does, so step 2 works it out in
/// parallel; step 3 uses it only if its own `from`, `d` and radius are exactly these.
#[derive(Clone, Copy, Debug)]
pub(super) struct PlannedMove {
    pub(super) from: DVec2,
    pub(super) d: DVec2,
    pub(super) radius_m: f64,
    pub(super) free: DVec2,
}

impl PlannedMove {
    /// Whether this plan was made for exactly these inputs (bit for bit, so that using it
    /// can never change a result).
    pub(super) fn is_for(&self, from: DVec2, d: DVec2, radius_m: f64) -> bool {
        let bits = |v: DVec2| (v.x.to_bits(), v.y.to_bits());
        bits(self.from) == bits(from) && bits(self.d) == bits(d) && self.radius_m.to_bits() == radius_m.to_bits()
    }
}

/// A message sent this round, before budgeted delivery.
#[derive(Clone, Debug)]
pub(super) struct Outgoing {
    /// Sender's index.
    pub(super) from: usize,
    /// Its reach (the sender's communication radius).
    pub(super) range_m: f64,
    pub(super) message: Message,
    pub(super) bytes: u64,
}

/// A running simulation. Its state changes only through its own methods (set-up here, the
/// round steps in `round/`).
#[allow(clippy::struct_excessive_bools)] // Independent settings and facts of a run, each read by its own step.
pub struct Simulation {
    pub(super) name: String,
    pub(super) seed: u64,
    /// Robots disabled because their strategy failed.
    pub(super) strategies_failed: u32,
    /// Decisions slower than this are reported (`None`: not timed).
    pub(super) decide_limit: Option<Duration>,
    /// Whether strategies' planning is timed (see [`PhaseTimes::planning`]).
    pub(super) time_planning: bool,
    /// Turns that depend on nobody are resolved in step 2 (see `resolve_alone`).
    pub(super) resolve_alone: bool,
    pub(super) rounds: u64,
    pub(super) round: u64,
    pub(super) map: Arc<MapData>,
    pub(super) nav: LazyNavGraph,
    /// Shared so the resolve loop can hold a type while it mutates the simulation.
    pub(super) types: Arc<[RobotType]>,
    pub(super) groups: Vec<Group>,
    pub(super) robots: Vec<Robot>,
    /// Each robot's type index (as in `robots`, which step 2 writes while robots perceive).
    pub(super) type_of: Vec<usize>,
    pub(super) agents: Vec<Agent>,
    pub(super) treasures: Vec<TreasureState>,
    pub(super) treasure_index: TreasureIndex,
    /// Start-of-round positions in cells of the widest view or radio range (perception,
    /// messages); built only for rounds that need it (see `robot_index_eager`).
    pub(super) robot_index: RobotIndex,
    /// Some strategy perceives robots: the view-sized index is built every round. Otherwise
    /// only for rounds in which someone broadcasts, after step 2.
    pub(super) robot_index_eager: bool,
    /// Each robot's turn this round (see [`Turn`]).
    pub(super) turns: Vec<Turn>,
    /// Some robot holds last round's messages: the next delivery must take them back.
    pub(super) inboxes_held: bool,
    /// The same positions in cells of the widest body-contact reach (collisions): in a
    /// crowd, a 20 m cell holds hundreds of robots that a 0.75 m contact test need not see.
    pub(super) body_index: RobotIndex,
    /// Messages sent this round, each once, to deliver at the start of the next.
    pub(super) mailbag: Vec<Message>,
    /// Per robot, the messages of `mailbag` it will read (indices, in sending order).
    pub(super) inboxes: Vec<Vec<u32>>,
    /// This round's unbudgeted sends, to put in the inboxes after step 3 (see
    /// [`Fanout`]).
    pub(super) fanout: Vec<Fanout>,
    /// Step 3's lists (see [`Step3`]).
    pub(super) step3: Step3,
    /// The union of everything every robot has seen.
    pub(super) explored: KnownMap,
    pub(super) explored_free_cells: u64,
    /// When the explored fraction first reached 50, 90 and 98 %.
    pub(super) milestones: ExploredMilestones,
    /// Each robot's view disc last marked in `explored`.
    pub(super) explored_views: Vec<Option<Disc>>,
    /// The explored-map update's buffers, kept to reuse their allocations.
    pub(super) explored_buffers: ExploredBuffers,
    /// Each robot's terms of the metrics' floating-point sums: energy (0 when dead),
    /// distance, overlap (see `gather_metric_terms`).
    pub(super) metric_terms: Vec<[f64; 3]>,
    /// Blocks of `explored` known to be explored (see [`BlockMemo`]).
    pub(super) explored_memo: BlockMemo,
    pub(super) total_free_cells: u64,
    pub(super) report: RoundReport,
    pub(super) max_radius_m: f64,
    pub(super) max_speed_m: f64,
    /// Whether some robot type has a finite radio budget: messages are then delivered by
    /// [`deliver_within_budget`](Self::deliver_within_budget) after the resolve step.
    pub(super) radio_limited: bool,
    /// Each robot's position and body radius as step 3 meets it, written in step 2 (after
    /// any turn resolved there) and as step 3 moves robots: what a move's contact test
    /// reads of the robots in its way, 24 bytes each rather than a whole [`Robot`].
    pub(super) bodies_now: Vec<(DVec2, f64)>,
    /// How step 3 shares its turns among workers (see [`TurnSharing`]).
    pub(super) turn_sharing: TurnSharing,
    /// Messages sent this round, waiting for budgeted delivery (sender order).
    pub(super) outgoing: Vec<Outgoing>,
    /// Wall time spent in each step of the rounds so far.
    pub(super) phase_times: PhaseTimes,
}

/// How step 3 shares its turns among the workers. The outcome is always that of one pass
/// in robot id order.
///
/// ```
/// use sim_core::engine::TurnSharing;
///
/// // 10,000 robots side by side on 2 workers or more; 1,000 robots from 3 workers; 100
/// // robots in id order.
/// assert!(TurnSharing::Auto.side_by_side(10_000, 2));
/// assert!(!TurnSharing::Auto.side_by_side(10_000, 1));
/// assert!(!TurnSharing::Auto.side_by_side(1_000, 2));
/// assert!(TurnSharing::Auto.side_by_side(1_000, 4));
/// assert!(!TurnSharing::Auto.side_by_side(100, 16));
/// assert!(TurnSharing::SideBySide.side_by_side(10, 1));
/// assert_eq!("side-by-side".parse::<TurnSharing>().unwrap(), TurnSharing::SideBySide);
/// assert!("sideways".parse::<TurnSharing>().is_err());
/// assert_eq!(TurnSharing::InOrder.to_string(), "in-order");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TurnSharing {
    /// Every turn in id order, on one thread: the least work.
    InOrder,
    /// Side by side on 3 workers or more in runs of at least [`SIDE_BY_SIDE_MIN_ROBOTS`]
    /// robots, and on 2 workers in runs of at least [`SIDE_BY_SIDE_MIN_ROBOTS_ON_TWO`]; in
    /// id order otherwise.
    #[default]
    Auto,
    /// Side by side whatever the workers and robots: the moves settled by strips of the map,
    /// a worker a strip, then every turn at once, those at treasures in id order (see
    /// `round/moves.rs`). It does about a fifth more work than the pass in id order
    /// (settling a move, then taking its turn), which the workers share.
    SideBySide,
}

/// [`TurnSharing::Auto`] shares turns on 3 workers or more in runs of at least this many
/// robots: with fewer there are movers for one strip only, and handing the rest of the
/// turns out costs about what it saves.
pub const SIDE_BY_SIDE_MIN_ROBOTS: usize = 512;

/// [`TurnSharing::Auto`] shares turns on 2 workers in runs of at least this many robots.
/// Two workers share the extra work of side by side only where step 3 is a large part of
/// the round, in crowds of thousands (see BENCHMARKS.md, "Scaling").
pub const SIDE_BY_SIDE_MIN_ROBOTS_ON_TWO: usize = 4096;

impl std::str::FromStr for TurnSharing {
    type Err = crate::Error;

    /// `auto`, `in-order` or `side-by-side` (as command lines spell them).
    fn from_str(s: &str) -> crate::Result<Self> {
        [TurnSharing::Auto, TurnSharing::InOrder, TurnSharing::SideBySide]
            .into_iter()
            .find(|t| t.to_string() == s)
            .ok_or_else(|| {
                crate::Error::InvalidParameter(format!("turns go 'auto', 'in-order' or 'side-by-side', got '{s}'"))
            })
    }
}

impl std::fmt::Display for TurnSharing {
    /// As command lines spell it (what [`FromStr`](std::str::FromStr) reads back).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TurnSharing::InOrder => "in-order",
            TurnSharing::Auto => "auto",
            TurnSharing::SideBySide => "side-by-side",
        })
    }
}

impl TurnSharing {
    /// Whether a round of `robots` robots on a pool of `workers` takes its turns side by
    /// side.
    pub fn side_by_side(self, robots: usize, workers: usize) -> bool {
        match self {
            TurnSharing::InOrder => false,
            TurnSharing::Auto => match workers {
                0 | 1 => false,
                2 => robots >= SIDE_BY_SIDE_MIN_ROBOTS_ON_TWO,
                _ => robots >= SIDE_BY_SIDE_MIN_ROBOTS,
            },
            TurnSharing::SideBySide => true,
        }
    }
}

/// Wall time a simulation spent in each step of its rounds so far (see
/// [`Simulation::phase_times`]): where a run's time goes, for finding what to make faster.
/// Like every wall time, it differs from run to run; nothing in a run depends on it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Steps 1 and 2 (parallel): perceiving, reading messages, deciding, planning moves.
    pub perceive_decide: Duration,
    /// Step 3 (by robot id), with the collective explored map marked alongside.
    pub resolve: Duration,
    /// Delivering the round's messages within radio budgets (parallel by receiver).
    pub deliver: Duration,
    /// Everything else: taking last round's messages as one bag, crediting discoveries,
    /// rebuilding the robot indexes, metrics.
    pub other: Duration,
    /// Of `resolve`: the turns taken in id order (one thread; see [`TurnSharing`]).
    pub in_order: Duration,
    /// Of `resolve`, when turns go side by side: sorting them (movers by strip, turns at
    /// treasures) and taking those at treasures, in id order (one thread).
    pub ordering: Duration,
    /// Of `resolve`, when turns go side by side: settling the moves and taking the other
    /// turns (all workers).
    pub side_by_side: Duration,
    /// Of `resolve`: putting the turns' events in the report in id order, sorting the
    /// senders, and joining their messages' lists in id order (one thread).
    pub events: Duration,
    /// Of `resolve`: addressing the messages, blocks of senders on all workers.
    pub addressing: Duration,
    /// Rounds whose step 3 took its turns side by side (see [`TurnSharing`]); the others
    /// took them in id order.
    pub rounds_side_by_side: u64,
    /// Of `resolve`: putting the unbudgeted sends in the inboxes (parallel by receiver).
    pub fan_out: Duration,
    /// Beside `resolve`: updating the collective explored map (sorting out the views that
    /// may add to it on all workers, then `explored_marking`).
    pub explored: Duration,
    /// Of `explored`: marking the views sorted out, in id order (one thread).
    pub explored_marking: Duration,
    /// Of `other`: taking last round's messages as one shared bag (one thread; the
    /// receivers' inboxes are filled from it in step 2's parallel pass).
    pub inboxes: Duration,
    /// Of `other`: crediting first sightings and the strategies' events (one thread).
    pub discoveries: Duration,
    /// Of `other`: rebuilding the robot indexes (two, side by side; each robot's cell and
    /// place worked out on all workers, then `indexes_in_order`), beside the gathering of
    /// the metrics' terms in `crediting`: on several workers the two overlap.
    pub indexes: Duration,
    /// Of `indexes`: counting the buckets and placing the robots in them (one thread).
    pub indexes_in_order: Duration,
    /// Of `other`: crediting explored cells to the robots, then gathering the metrics' terms
    /// beside `indexes` (both on all workers).
    pub crediting: Duration,
    /// Of `other`: summing the metrics' terms in id order (one thread).
    pub metrics: Duration,
    /// Of steps 1 and 2, the time strategies spent planning routes and frontiers through
    /// [`Ctx::timed_planning`](crate::agent::Ctx::timed_planning), summed over threads (CPU
    /// time, not wall time): zero unless [`Simulation::with_time_planning`] is on.
    pub planning: Duration,
}

impl Simulation {
    /// Set up a run of a validated scenario: place the robots where the scenario put them,
    /// hand each its strategy, build the indexes and the navigation graph.
    pub fn new(scenario: Scenario) -> Result<Self> {
        let mut parts = scenario.into_parts();
        let (treasures, treasure_index) = place_treasures(&parts.map)?;
        let (robots, agents) = place_robots(&mut parts);
        let placed = Placed {
            robots,
            agents,
            treasures,
            treasure_index,
        };
        let mut sim = Self::assemble(parts, placed);
        sim.prepare_first_round();
        Ok(sim)
    }

    /// Run name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Run seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Report decisions that take longer than `limit` (in the round report's
    /// `slow_decisions`); `None` does not time them. Default: [`DEFAULT_DECIDE_LIMIT`].
    /// Decisions are timed with the system's coarse monotonic clock (a few milliseconds'
    /// resolution, cheaper than a precise clock read), so limits under about ten
    /// milliseconds are approximate.
    pub fn with_decide_limit(mut self, limit: Option<Duration>) -> Self {
        self.decide_limit = limit;
        self
    }

    /// Time the built-in tactics' route and frontier planning (into
    /// [`PhaseTimes::planning`]): two clock reads per planning, which the kernel does not
    /// pay unless asked. Default: off. Results do not depend on it.
    pub fn with_time_planning(mut self, on: bool) -> Self {
        self.time_planning = on;
        self
    }

    /// Whether a robot whose turn depends on no other robot (idle, or moving with nobody
    /// within reach; no messages, no treasure, no energy running out) has its turn resolved
    /// in step 2, in parallel, instead of in step 3's pass in id order. Default: `true`.
    /// Results are the same either way (`false` is there to check that, and to profile):
    /// `turns_resolved_alone_give_the_id_order_run` (tests/kernel.rs).
    pub fn with_turns_resolved_alone(mut self, enabled: bool) -> Self {
        self.resolve_alone = enabled;
        self
    }

    /// How step 3 shares its turns among workers. Default: [`TurnSharing::Auto`]. Results
    /// are the same whatever the choice: `turns_side_by_side_give_the_id_order_run`
    /// (tests/kernel.rs).
    pub fn with_turn_sharing(mut self, sharing: TurnSharing) -> Self {
        self.turn_sharing = sharing;
        self
    }

    /// Rounds this run lasts.
    pub fn total_rounds(&self) -> u64 {
        self.rounds
    }
    /// Rounds played so far.
    pub fn round(&self) -> u64 {
        self.round
    }
    /// The map.
    pub fn map(&self) -> &MapData {
        &self.map
    }
    /// The map, shared: for observers that read it on a thread of their own. O(1).
    pub fn shared_map(&self) -> Arc<MapData> {
        Arc::clone(&self.map)
    }
    /// The obstacles.
    pub fn obstacles(&self) -> &ObstacleMap {
        &self.map.obstacles
    }
    /// The navigation graph if a strategy (or [`nav`](Self::nav)) has needed it so far.
    pub fn nav_if_built(&self) -> Option<&NavGraph> {
        self.nav.get()
    }
    /// The navigation graph (built now if nobody needed it yet, on the current rayon pool's
    /// workers).
    pub fn nav(&self) -> &NavGraph {
        self.nav.get_or_build_on_all_workers(&self.map.obstacles)
    }
    /// Robot types.
    pub fn types(&self) -> &[RobotType] {
        &self.types
    }
    /// Robot groups.
    pub fn groups(&self) -> &[Group] {
        &self.groups
    }
    /// Robots, by id.
    pub fn robots(&self) -> &[Robot] {
        &self.robots
    }
    /// A 64-bit FNV-1a digest of every robot's position bits, in id order: equal digests
    /// mean the runs ended with every robot in the same place, to the last bit. O(robots).
    pub fn positions_digest(&self) -> u64 {
        self.robots.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, r| {
            let h = (h ^ r.position.x.to_bits()).wrapping_mul(0x0100_0000_01b3);
            (h ^ r.position.y.to_bits()).wrapping_mul(0x0100_0000_01b3)
        })
    }
    /// Treasures, by id.
    pub fn treasures(&self) -> &[TreasureState] {
        &self.treasures
    }
    /// A treasure.
    pub fn treasure(&self, id: TreasureId) -> Option<&TreasureState> {
        self.treasures.get(id.index())
    }
    /// A robot's known map, if its strategy keeps one.
    pub fn known_map(&self, id: RobotId) -> Option<&KnownMap> {
        self.agents.get(id.index())?.mind.data.known.as_ref()
    }
    /// A robot's strategy needs.
    pub fn needs(&self, id: RobotId) -> Option<Needs> {
        self.agents.get(id.index()).map(|a| a.needs)
    }
    /// The union of all robots' views so far.
    pub fn explored(&self) -> &KnownMap {
        &self.explored
    }
    /// Wall time spent in each step of the rounds so far.
    pub fn phase_times(&self) -> PhaseTimes {
        self.phase_times
    }

    /// The last round's report.
    pub fn report(&self) -> &RoundReport {
        &self.report
    }
    /// The deliveries of the last round: each message sent in it and each robot that will
    /// read it at the start of the next (sender → receiver), receiver by receiver, each
    /// receiver's in reading order. Worked out from the inboxes when asked: crowds make
    /// millions a round, and most runs never look. O(links).
    pub fn links(&self) -> impl Iterator<Item = Link> + '_ {
        self.inboxes.iter().enumerate().flat_map(move |(r, picks)| {
            let to = RobotId::new(u32::try_from(r).expect("robot ids are u32"));
            picks.iter().map(move |&k| Link {
                from: self.mailbag[k as usize].from,
                to,
            })
        })
    }

    /// Every `stride`-th of [`links`](Self::links), from the first: `links().step_by(stride)`,
    /// worked out from the inboxes' lengths so that only the links yielded are visited
    /// (a viewer samples a few thousand of the millions a crowd delivers). O(robots + links
    /// yielded). Checked by `links_every_is_links_step_by`.
    pub fn links_every(&self, stride: usize) -> impl Iterator<Item = Link> + '_ {
        let stride = stride.max(1);
        // Index, among all links, of the current receiver's first link.
        let mut start = 0usize;
        self.inboxes.iter().enumerate().flat_map(move |(r, picks)| {
            let skip = start.next_multiple_of(stride) - start;
            start += picks.len();
            let to = RobotId::new(u32::try_from(r).expect("robot ids are u32"));
            picks.iter().skip(skip).step_by(stride).map(move |&k| Link {
                from: self.mailbag[k as usize].from,
                to,
            })
        })
    }

    /// How many [`links`](Self::links) there are.
    pub fn link_count(&self) -> usize {
        self.inboxes.iter().map(Vec::len).sum()
    }

    /// Messages waiting for delivery at the start of the next round, per robot.
    pub fn pending_messages(&self) -> Vec<Vec<&Message>> {
        self.inboxes
            .iter()
            .map(|picks| picks.iter().map(|&k| &self.mailbag[k as usize]).collect())
            .collect()
    }

    /// Total memory held by the robots' known maps, bytes (what the paper's Fig. 4 plots).
    pub fn robot_memory_bytes(&self) -> usize {
        self.agents
            .iter()
            .map(|a| a.mind.data.known.as_ref().map_or(0, KnownMap::memory_bytes))
            .sum()
    }

    /// Metrics for the current state; `known_map_bytes` is [`robot_memory_bytes`](Self::robot_memory_bytes).
    pub(super) fn metrics(
        &mut self,
        round: u64,
        messages: u64,
        message_bytes: u64,
        known_map_bytes: usize,
    ) -> RoundMetrics {
        let tallies = self.gather_metric_terms();
        self.sum_metrics(round, messages, message_bytes, known_map_bytes, tallies)
    }

    /// On all workers: each robot's terms of the metrics' floating-point sums, into
    /// `metric_terms`, and the sums of integers (which no order changes).
    pub(super) fn gather_metric_terms(&mut self) -> Tallies {
        gather_terms(&self.robots, &self.turns, &mut self.metric_terms)
    }

    /// The metrics from the gathered terms: the floating-point sums in id order, on one
    /// thread, so that their bits do not depend on the thread count.
    pub(super) fn sum_metrics(
        &self,
        round: u64,
        messages: u64,
        message_bytes: u64,
        known_map_bytes: usize,
        tallies: Tallies,
    ) -> RoundMetrics {
        let (mut energy, mut distance_m, mut overlap_m) = (0.0, 0.0, 0.0);
        for &[e, d, o] in &self.metric_terms {
            energy += e;
            distance_m += d;
            overlap_m += o;
        }
        let alive = tallies.alive;
        RoundMetrics {
            round,
            explored_fraction: if self.total_free_cells == 0 {
                1.0
            } else {
                self.explored_free_cells as f64 / self.total_free_cells as f64
            },
            treasures_found: self.treasures.iter().filter(|t| t.found_round.is_some()).count() as u32,
            treasures_excavated: self.treasures.iter().filter(|t| t.buried == 0).count() as u32,
            treasures_delivered: self.treasures.iter().filter(|t| t.delivered == t.initial).count() as u32,
            robots_alive: alive,
            mean_energy: if alive == 0 { 0.0 } else { energy / f64::from(alive) },
            messages,
            distance_m,
            units_dug: tallies.units_dug,
            units_delivered: tallies.units_delivered,
            message_bytes,
            strategies_failed: self.strategies_failed,
            known_map_bytes: known_map_bytes as u64,
            overlap_m,
            ..RoundMetrics::default()
        }
    }

    /// The random generator of a robot in a round: a function of (seed, robot, round) only.
    pub(super) fn rng_for(seed: u64, robot: RobotId, round: u64) -> RobotRng {
        let x = Self::mixed_seed(seed, robot, round);
        // `RobotRng::seed_from_u64(x)`'s state (four outputs of a splitmix64 seeded with
        // `x`), without its generic byte-by-byte fill. The test
        // `rng_for_seeds_as_seed_from_u64` holds the two equal.
        let mut splitmix = rand_xoshiro::SplitMix64::seed_from_u64(x);
        let mut state = [0u8; 32];
        for word in state.chunks_exact_mut(8) {
            word.copy_from_slice(&rand::RngCore::next_u64(&mut splitmix).to_le_bytes());
        }
        RobotRng::from_seed(state)
    }

    /// The seed of a robot's generator in a round: (seed, robot, round) mixed by splitmix64
    /// steps.
    fn mixed_seed(seed: u64, robot: RobotId, round: u64) -> u64 {
        let mut x = seed ^ 0x9E37_79B9_7F4A_7C15;
        for v in [u64::from(robot.get()), round] {
            x = x.wrapping_add(v).wrapping_add(0x9E37_79B9_7F4A_7C15);
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^= x >> 31;
        }
        x
    }
}

/// The metrics' sums of integers over the robots, gathered on all workers.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tallies {
    alive: u32,
    units_dug: u64,
    units_delivered: u64,
    /// Heap bytes of the known maps after step 2 (see `Turn::known_bytes`).
    pub(super) known_bytes: usize,
}

impl Tallies {
    fn add(self, other: Self) -> Self {
        Self {
            alive: self.alive + other.alive,
            units_dug: self.units_dug + other.units_dug,
            units_delivered: self.units_delivered + other.units_delivered,
            known_bytes: self.known_bytes + other.known_bytes,
        }
    }
}

/// Robots a task of the passes over every robot outside steps 1 to 3 (crediting, metrics):
/// each robot's share is a few loads and stores.
pub(super) const ROBOTS_A_TASK: usize = 1024;

/// A scenario's robots, agents and treasures, placed for the start of a run.
struct Placed {
    robots: Vec<Robot>,
    agents: Vec<Agent>,
    treasures: Vec<TreasureState>,
    treasure_index: TreasureIndex,
}

/// The map's treasures as run state, indexed by position, with ids in the map's order.
fn place_treasures(map: &MapData) -> Result<(Vec<TreasureState>, TreasureIndex)> {
    let mut treasure_index = TreasureIndex::new(map.obstacles.grid().extent())?;
    let mut treasures = Vec::with_capacity(map.treasures.len());
    for t in &map.treasures {
        let id = treasure_index.insert(t.position, t.quantity)?;
        treasures.push(TreasureState {
            id,
            position: t.position,
            initial: t.quantity,
            buried: t.quantity,
            loose: 0,
            delivered: 0,
            found_round: None,
        });
    }
    Ok((treasures, treasure_index))
}

/// The scenario's robots at their starts, group by group, each with an agent holding its
/// strategy (the strategies and starts are taken out of `parts`).
fn place_robots(parts: &mut ScenarioParts) -> (Vec<Robot>, Vec<Agent>) {
    let grid = *parts.map.obstacles.grid();
    let mut robots = Vec::with_capacity(parts.starts.len());
    let mut agents = Vec::with_capacity(parts.starts.len());
    let mut strategies = std::mem::take(&mut parts.strategies).into_iter();
    let mut starts = std::mem::take(&mut parts.starts).into_iter();
    for (gi, g) in parts.groups.iter().enumerate() {
        let kind = &parts.types[g.type_index];
        for _ in 0..g.count {
            let (Some(strategy), Some(position)) = (strategies.next(), starts.next()) else {
                unreachable!("a scenario has a strategy and a start for every robot");
            };
            let id = RobotId::new(robots.len() as u32);
            robots.push(Robot::new(id, g.type_index, gi, position, kind));
            agents.push(new_agent(strategy, grid));
        }
    }
    (robots, agents)
}

/// A robot's agent before its first round: its strategy, with a data module that keeps a
/// known map if the strategy needs one.
fn new_agent(strategy: Box<dyn Strategy>, grid: Grid) -> Agent {
    let needs = strategy.needs();
    let (tr, rr) = strategy.retention();
    Agent {
        strategy,
        needs,
        mind: Mind::new(DataModule::new(needs.known_map.then(|| KnownMap::new(grid)), tr, rr)),
        action: Action::Idle,
        merged_from: HashMap::default(),
        planned_move: None,
        hearers: Vec::new(),
        failure: None,
        paid_sends: Vec::new(),
    }
}

impl Simulation {
    /// The simulation around the placed robots and treasures, before its first round.
    fn assemble(parts: ScenarioParts, placed: Placed) -> Self {
        let grid = *parts.map.obstacles.grid();
        let n = placed.robots.len();
        let total_free_cells = parts.map.obstacles.tree().count_cells(false);
        let max_speed_m = parts.types.iter().map(|t| t.speed_m_per_round).fold(0.0, f64::max);
        let radio_limited = parts.types.iter().any(|t| t.radio_bytes_per_round < u64::MAX);
        let robot_index_eager = placed.agents.iter().any(|a| a.needs.robots);
        Self {
            name: parts.name,
            seed: parts.seed,
            strategies_failed: 0,
            decide_limit: Some(DEFAULT_DECIDE_LIMIT),
            time_planning: false,
            resolve_alone: true,
            phase_times: PhaseTimes::default(),
            rounds: parts.rounds,
            round: 0,
            nav: LazyNavGraph::new(),
            types: parts.types.into(),
            groups: parts.groups,
            type_of: placed.robots.iter().map(|r| r.type_index).collect(),
            robots: placed.robots,
            agents: placed.agents,
            treasures: placed.treasures,
            treasure_index: placed.treasure_index,
            // Both visit robots in an order nothing depends on (perception and hearers are
            // sorted by id, contact lists only asked whether anyone overlaps).
            robot_index: RobotIndex::dense_when_compact(),
            robot_index_eager,
            turns: vec![Turn::default(); n],
            inboxes_held: false,
            body_index: RobotIndex::dense_when_compact(),
            mailbag: Vec::new(),
            inboxes: vec![Vec::new(); n],
            fanout: Vec::new(),
            step3: Step3::new(n),
            explored: KnownMap::new(grid),
            explored_free_cells: 0,
            milestones: ExploredMilestones::default(),
            explored_views: vec![None; n],
            explored_buffers: ExploredBuffers::default(),
            metric_terms: Vec::new(),
            explored_memo: BlockMemo::default(),
            total_free_cells,
            report: RoundReport::default(),
            max_radius_m: parts.max_radius_m,
            max_speed_m,
            radio_limited,
            outgoing: Vec::new(),
            bodies_now: vec![(DVec2::ZERO, 0.0); n],
            turn_sharing: TurnSharing::default(),
            map: parts.map,
        }
    }

    /// Ready the run for its first round: index the robots, build the navigation graph if a
    /// strategy plans routes, and report the metrics of the starting state.
    fn prepare_first_round(&mut self) {
        self.rebuild_robot_indexes();
        // Strategies that plan routes would build the graph in their first round; build it
        // here instead, so that set-up time is set-up time. Without them it is never built.
        if self.agents.iter().any(|a| a.needs.obstacles) {
            self.nav();
        }
        self.report.metrics = self.metrics(0, 0, 0, self.robot_memory_bytes());
    }
}

impl Simulation {
    /// Index the robots' current positions: the contact-sized index always, the view-sized
    /// one when some strategy perceives robots (otherwise step 2 builds it from the start
    /// positions if someone broadcasts).
    pub(super) fn rebuild_robot_indexes(&mut self) {
        self.index_rebuild_and_terms().0.run();
    }

    /// The end of a round on all workers: the robot indexes rebuilt beside the metrics' terms
    /// gathered. Both read the robots as step 3 left them and write apart, so a worker
    /// without a share of one takes a share of the other instead of waiting for it. Returns
    /// the tallies and how long each took.
    pub(super) fn rebuild_indexes_beside_metric_terms(&mut self) -> (Tallies, Duration, Duration) {
        let (rebuild, turns, terms) = self.index_rebuild_and_terms();
        let robots = rebuild.robots;
        let (((), indexes_took), (tallies, terms_took)) = rayon::join(
            || timed(|| rebuild.run()),
            || timed(|| gather_terms(robots, turns, terms)),
        );
        (tallies, indexes_took, terms_took)
    }

    /// The rebuild of the robot indexes, and the turns and terms the metrics' gathering
    /// reads and writes, borrowed apart.
    fn index_rebuild_and_terms(&mut self) -> (IndexRebuild<'_>, &[Turn], &mut Vec<[f64; 3]>) {
        let (view_cell_m, body_cell_m) = self.index_cells_m();
        let rebuild = IndexRebuild {
            robots: &self.robots,
            view_cell_m,
            body_cell_m,
            robot_index: self.robot_index_eager.then_some(&mut self.robot_index),
            body_index: &mut self.body_index,
        };
        (rebuild, &self.turns, &mut self.metric_terms)
    }

    /// The cells of the view-sized and the contact-sized robot indexes, metres. The latter's
    /// are about the radius of the widest contact query (`Bodies::near_move`: two radii and
    /// a move around the middle of a move), so that a query covers about 3 × 3 cells:
    /// smaller cells mean more cells a query, larger ones more robots a cell.
    fn index_cells_m(&self) -> (f64, f64) {
        let reach = 2.0 * self.max_radius_m + 2.0 * self.max_speed_m;
        (index_cell_m(&self.types), reach.clamp(0.25, 64.0))
    }

    /// How long the last rebuild of the robot indexes spent on one thread.
    pub(super) fn robot_indexes_in_order_time(&self) -> Duration {
        let view = if self.robot_index_eager {
            self.robot_index.in_order_time()
        } else {
            Duration::ZERO
        };
        self.body_index.in_order_time() + view
    }

    /// Build the view-sized index from the start-of-round positions (for a round whose
    /// broadcasts need it when it is not built every round).
    pub(super) fn rebuild_robot_index_at_start(&mut self) {
        let view_cell_m = index_cell_m(&self.types);
        let (turns, robots) = (&self.turns, &self.robots);
        self.robot_index
            .rebuild_from(robots.len(), |i| (robots[i].id, turns[i].start), view_cell_m);
    }
}

/// How long one strategy may take to decide one round before it is reported: a hundred
/// milliseconds is thousands of times what the built-in strategies need, and long enough for
/// a strategy that plans a route across a large map.
pub const DEFAULT_DECIDE_LIMIT: Duration = Duration::from_millis(100);

/// The robot indexes to rebuild from the robots' positions (the view-sized one only when
/// some strategy perceives robots).
struct IndexRebuild<'a> {
    robots: &'a [Robot],
    view_cell_m: f64,
    body_cell_m: f64,
    robot_index: Option<&'a mut RobotIndex>,
    body_index: &'a mut RobotIndex,
}

impl IndexRebuild<'_> {
    /// Rebuild them; the two are independent, so built side by side.
    fn run(self) {
        let robots = self.robots;
        let robot = |i: usize| (robots[i].id, robots[i].position);
        let n = robots.len();
        let (body_index, body_cell_m) = (self.body_index, self.body_cell_m);
        if let Some(robot_index) = self.robot_index {
            rayon::join(
                || robot_index.rebuild_from(n, robot, self.view_cell_m),
                || body_index.rebuild_from(n, robot, body_cell_m),
            );
        } else {
            body_index.rebuild_from(n, robot, body_cell_m);
        }
    }
}

/// On all workers: each robot's terms of the metrics' floating-point sums, into `terms`,
/// and the sums of integers (which no order changes).
fn gather_terms(robots: &[Robot], turns: &[Turn], terms: &mut Vec<[f64; 3]>) -> Tallies {
    terms.resize(robots.len(), [0.0; 3]);
    robots
        .par_iter()
        .zip(terms)
        .zip(turns)
        .with_min_len(ROBOTS_A_TASK)
        .map(|((r, term), turn)| {
            // A dead robot's energy term is +0.0, which leaves any sum's bits as they are.
            *term = [
                if r.alive { r.energy } else { 0.0 },
                r.stats.distance_m,
                r.stats.overlap_m,
            ];
            Tallies {
                alive: u32::from(r.alive),
                units_dug: r.stats.units_dug,
                units_delivered: r.stats.units_delivered,
                known_bytes: turn.known_bytes,
            }
        })
        .reduce(Tallies::default, Tallies::add)
}

/// `f()` and how long it took.
fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let t = std::time::Instant::now();
    (f(), t.elapsed())
}

/// Cell size for the robot index: the typical query radius.
pub(super) fn index_cell_m(types: &[RobotType]) -> f64 {
    types
        .iter()
        .map(|t| t.view_radius_m.max(t.comm_radius_m))
        .fold(1.0, f64::max)
        .min(64.0)
}

#[cfg(test)]
mod tests {
    use rand::{RngCore, SeedableRng};

    use super::Simulation;
    use crate::agent::RobotRng;
    use crate::spatial::RobotId;

    /// The robots' generators, seeded without the generic fill, draw what `seed_from_u64`
    /// of the same mixed seed draws.
    #[test]
    fn rng_for_seeds_as_seed_from_u64() {
        for (seed, robot, round) in [(0, 0, 0), (1, 7, 3), (u64::MAX, 999, 1_000_000), (42, 0, u64::MAX)] {
            let robot = RobotId::new(robot);
            let mut fast = Simulation::rng_for(seed, robot, round);
            let mut reference = RobotRng::seed_from_u64(Simulation::mixed_seed(seed, robot, round));
            for _ in 0..8 {
                assert_eq!(fast.next_u64(), reference.next_u64());
            }
        }
    }
}
