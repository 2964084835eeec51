//! [`RerunObserver`]: sim-core's [`Observer`] over a [`rerun::RecordingStream`].
//!
//! Entities (time on the sequence timeline [`TIMELINE`]; 2D ones flipped, see [`crate::layers`]):
//!
//! | entity | what | when |
//! |---|---|---|
//! | `world` | `AnnotationContext`: one class per robot type (+ "disabled") | static |
//! | `world/obstacles/raster`, `world/obstacles/boxes` | obstacle raster; exact outlines if ≤ 50k | static |
//! | `world/home` | home base | static |
//! | `world/treasures` | remaining treasures, radius by remaining quantity | logged rounds where one changed |
//! | `world/robots` | robots (class id = type) + detail columns `type`, `energy`, `alive`, `action`, `outcome`, `goal_x`/`goal_y`, `load`, `x`/`y` (world coordinates) | logged rounds |
//! | `world/paths`, `world/links` | planned paths; message links of the round (an even sample of at most `max_links`, chained into trails) | logged rounds |
//! | `world/explored` | collective explored region (raster) | every `explored_every` logged rounds |
//! | `world/known/<id>` | one robot's known region, coarse (swarms of at most `known_per_robot_max` robots) | every `known_every` rounds, if its coarse region changed |
//! | `world/known/<type>` | the known regions of all robots of a type, each box with its `robot` (larger swarms) | every `known_every` rounds, if one of them changed |
//! | `world3d/…` | ground, obstacle boxes with heights, robots on the plane | static / logged rounds |
//! | `metrics/<column>` | one `Scalars` per metrics CSV column ([`metric_entities`]) | every round (sent in columns) |
//! | `events` | `TextLog` of the round's events | every round with events |
//!
//! The simulation thread copies each round into a frame; a logging thread builds the
//! archetypes (see [`RerunObserver`]).

use sim_core::engine::{CoreLoan, Simulation};
use sim_core::glam::DVec2;
use sim_core::io::{Observer, ObserverError};
use sim_core::spatial::{Aabb, RegionQuadtree};
use sim_core::world::{Event, Link, METRICS_COUNT, Outcome, Robot, RobotType, RoundMetrics, RoundReport};

use crate::layers::{self, Raster, draw_order, to_2d};
use crate::priority::{LoggingWait, StarvationWatch};
use crate::viewer::ViewerLink;

/// The sequence timeline every per-round entity is logged on.
pub const TIMELINE: &str = "round";

/// Metrics CSV column → entity path (`metrics/<chart>`), for every column but `round` (the
/// timeline itself): read from sim-core's one metrics table, so charts and CSV agree.
pub fn metric_entities() -> impl Iterator<Item = (&'static str, String)> {
    RoundMetrics::default()
        .series()
        .map(|(column, chart, _)| (column, format!("metrics/{chart}")))
}

/// Number of charted metrics.
const CHARTED: usize = METRICS_COUNT - 1;

/// Most communication links drawn in one round by default: a dense swarm delivers O(n²)
/// messages a round, and beyond a few thousand lines the view is a solid blot while the
/// recording grows with every line.
pub const DEFAULT_MAX_LINKS: usize = 5_000;

/// Default of [`LogOptions::known_per_robot_max`]. Beyond a hundred robots a list of
/// per-robot entities is no longer something to click through, and each entity costs Rerun a
/// chunk with its own schema whenever it is logged.
pub const DEFAULT_KNOWN_PER_ROBOT_MAX: usize = 100;

/// World frames that may wait for the logging thread before the simulation waits (or, for a
/// live viewer, skips a round's world).
pub const QUEUE_ROUNDS: usize = 4;

/// How much the observer logs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogOptions {
    /// Log the world every `log_every` rounds (metrics and events: every round; the last round
    /// always).
    pub log_every: u64,
    /// Re-log the collective explored raster every this many rounds (rounded up to a logged
    /// round).
    pub explored_every: u64,
    /// Per-robot known regions: `None` = off; `Some(k)` = every k rounds, for robots whose map
    /// changed since they were last logged.
    pub known_every: Option<u64>,
    /// Most communication links drawn a round: an even sample of the round's distinct
    /// sender–receiver pairs (the `messages` chart keeps the full count).
    pub max_links: usize,
    /// Swarms of at most this many robots log each robot's known region as its own entity
    /// (`world/known/<id>`, to toggle one by one); larger ones log one entity per robot type
    /// (`world/known/<type>`), whose boxes carry the robot's id in a `robot` column.
    pub known_per_robot_max: usize,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self {
            log_every: 1,
            explored_every: 10,
            known_every: Some(20),
            max_links: DEFAULT_MAX_LINKS,
            known_per_robot_max: DEFAULT_KNOWN_PER_ROBOT_MAX,
        }
    }
}

/// How long the logging thread may go without finishing a frame before a live viewer counts
/// as stalled (paused, frozen, or its network gone quiet) under [`WhenBehind::SkipWorld`].
pub const STALL_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1);

/// What the simulation does when the logging thread falls [`QUEUE_ROUNDS`] behind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WhenBehind {
    /// Wait for it: nothing is lost (right for `.rrd` files, whose writer always catches up).
    Wait,
    /// Wait for it while it makes progress, so a live viewer that keeps up, however slowly,
    /// sees every logged round; once it has finished no frame for [`STALL_TIMEOUT`] (a paused
    /// or frozen viewer), leave out the world of the rounds played meanwhile (their metrics
    /// and events are still queued), so the run never hangs on its viewer. The world of the
    /// last round played is always queued (at the end of the run if it was left out).
    SkipWorld,
}

/// When the logging thread last finished a frame, shared with the simulation thread.
#[derive(Debug)]
struct Progress {
    epoch: std::time::Instant,
    /// Nanoseconds after `epoch`.
    last_ns: std::sync::atomic::AtomicU64,
}

impl Progress {
    fn new() -> Self {
        Self {
            epoch: std::time::Instant::now(),
            last_ns: std::sync::atomic::AtomicU64::new(0),
        }
    }

    fn tick(&self) {
        let ns = self.epoch.elapsed().as_nanos() as u64;
        self.last_ns.store(ns, std::sync::atomic::Ordering::Relaxed);
    }

    /// Time since the last finished frame (or since the start).
    fn idle(&self) -> std::time::Duration {
        let last = std::time::Duration::from_nanos(self.last_ns.load(std::sync::atomic::Ordering::Relaxed));
        self.epoch.elapsed().saturating_sub(last)
    }
}

/// Logs a simulation to Rerun.
///
/// The simulation thread only copies what a round shows into a frame (a private type); a
/// logging thread turns frames into Rerun archetypes and logs them, so the serialisation
/// overlaps the next round (whose resolve phase leaves a core idle). Log errors
/// (serialisation, a file that cannot be written) stop the run like any observer error; a
/// live viewer that goes away ends the logging, not the run (see
/// [`RerunObserver::with_viewer`]).
pub struct RerunObserver {
    rec: rerun::RecordingStream,
    opts: LogOptions,
    when_behind: WhenBehind,
    frames: Option<crossbeam_channel::Sender<Frame>>,
    progress: std::sync::Arc<Progress>,
    worker: Option<LoggingThread>,
    last_explored_round: Option<u64>,
    last_known_round: Option<u64>,
    /// Robots whose known map changed since their region was last logged.
    known_dirty: Vec<bool>,
    logged_rounds: u64,
    skipped_rounds: u64,
    /// The round of the last world handed to the logging thread, and of the last world left
    /// out: the end of a run logs the world of its last round if it is not there.
    world_round: Option<u64>,
    skipped_round: Option<u64>,
    /// Wall time spent in this observer on the simulation's thread during the rounds.
    busy: std::time::Duration,
    /// Wall time the end of the run waited for the logging thread and the stream.
    closing: std::time::Duration,
    /// Wall time the logging thread spent logging (known once it has finished).
    worker_busy: std::time::Duration,
    /// The round's pollers' cores, lent to the logging thread while it has worlds to log.
    core_loan: Option<std::sync::Arc<CoreLoan>>,
    /// Tells the user when the run waits for logging that other programs starve.
    starvation: StarvationWatch,
    /// The file the stream writes, if it writes one.
    file: Option<std::path::PathBuf>,
    /// The live stream's link to its viewer, if it streams to one.
    viewer: Option<ViewerLink>,
    /// The round at which the viewer was found gone, and why: nothing is logged after it.
    viewer_lost: Option<(u64, String)>,
}

impl RerunObserver {
    /// An observer logging to `rec` with `opts`; it waits for a logging thread that falls
    /// behind ([`WhenBehind::Wait`], see [`RerunObserver::with_when_behind`]).
    pub fn new(rec: rerun::RecordingStream, opts: LogOptions) -> Self {
        Self {
            rec,
            opts: LogOptions {
                log_every: opts.log_every.max(1),
                explored_every: opts.explored_every.max(1),
                known_every: opts.known_every.map(|k| k.max(1)),
                max_links: opts.max_links,
                known_per_robot_max: opts.known_per_robot_max,
            },
            when_behind: WhenBehind::Wait,
            frames: None,
            progress: std::sync::Arc::new(Progress::new()),
            worker: None,
            last_explored_round: None,
            last_known_round: None,
            known_dirty: Vec::new(),
            logged_rounds: 0,
            skipped_rounds: 0,
            world_round: None,
            skipped_round: None,
            busy: std::time::Duration::ZERO,
            closing: std::time::Duration::ZERO,
            worker_busy: std::time::Duration::ZERO,
            core_loan: None,
            starvation: StarvationWatch::default(),
            file: None,
            viewer: None,
            viewer_lost: None,
        }
    }

    /// The stream writes the file `path`: should Rerun report that writing it failed (a full
    /// disk, say; see [`crate::rerun_errors`]), the rounds end with that error, and the end
    /// of the run does not wait for the stream.
    #[must_use]
    pub fn with_file(mut self, path: std::path::PathBuf) -> Self {
        self.file = Some(path);
        self
    }

    /// The stream goes to a live viewer, `link` its connection (see
    /// [`crate::viewer::open`]): should the viewer go away (closed, crashed, or its
    /// connection reset), the round that finds it so says so on stderr, and the run goes on
    /// without logging, nor waiting for the stream at its end. A connection that goes quiet
    /// without a reset looks like a stalled viewer (see [`WhenBehind`]).
    #[must_use]
    pub fn with_viewer(mut self, link: ViewerLink) -> Self {
        self.viewer = Some(link);
        self
    }

    /// The round at which the live viewer was found gone, if it went (see
    /// [`RerunObserver::with_viewer`]).
    pub fn viewer_lost_at(&self) -> Option<u64> {
        self.viewer_lost.as_ref().map(|(round, _)| *round)
    }

    /// Lend `loan` to the logging thread from each logged world until it has logged all it
    /// was given (see [`sim_core::engine::with_hot_workers_lending`]): with hot workers
    /// polling on every core, the logging thread would otherwise wait for the scheduler to
    /// take a core from one, and the round for the one it took.
    pub fn with_core_loan(mut self, loan: std::sync::Arc<CoreLoan>) -> Self {
        self.core_loan = Some(loan);
        self
    }

    /// Count `opening`, the wait for the stream to open (begun before
    /// [`crate::viewer::open`]), among the run's waits for its logging: opening a file at
    /// the lowest priority is the first of them.
    #[must_use]
    pub fn with_opening(mut self, opening: &LoggingWait) -> Self {
        self.starvation.end(opening);
        self
    }

    /// What to do when the logging thread falls behind (default [`WhenBehind::Wait`]).
    pub fn with_when_behind(mut self, when_behind: WhenBehind) -> Self {
        self.when_behind = when_behind;
        self
    }

    /// The recording stream; once it has been closed at the end of the run, a disabled one.
    pub fn recording(&self) -> &rerun::RecordingStream {
        &self.rec
    }

    /// Rounds whose world state was logged so far (round 0, the start, included).
    pub fn logged_rounds(&self) -> u64 {
        self.logged_rounds
    }

    /// Rounds whose world was left out because a live viewer fell behind
    /// ([`WhenBehind::SkipWorld`]).
    pub fn skipped_rounds(&self) -> u64 {
        self.skipped_rounds
    }

    /// Wall time spent logging on the simulation's thread during the rounds so far (copying
    /// each logged round, and waiting when the logging thread is behind).
    pub fn busy(&self) -> std::time::Duration {
        self.busy
    }

    /// Wall time the end of the run waited for the logging thread to finish and the stream
    /// to be flushed and closed (known after [`Observer::on_finish`]).
    pub fn closing(&self) -> std::time::Duration {
        self.closing
    }

    /// Wall time the logging thread spent building and logging archetypes (known after
    /// [`Observer::on_finish`]); Rerun's own encoder and writer threads come on top.
    pub fn worker_busy(&self) -> std::time::Duration {
        self.worker_busy
    }

    /// Whether the world is logged after `round` of a run of `total` rounds.
    pub fn is_logged_round(&self, round: u64, total: u64) -> bool {
        round.is_multiple_of(self.opts.log_every) || round >= total
    }

    /// A copy of what the world shows after this round: rows and copies, so that the
    /// logging thread does the rest (rasters, coarse regions, sorting links) beside the next
    /// round. On a worker of the round's pool (the CLI's runs), two workers make the copies.
    ///
    /// `with_links`: the round's deliveries are drawn (none at the start); `last`: this is
    /// the last round the run plays, so the explored area and known regions are logged
    /// whether or not they are due.
    fn snapshot_world(&mut self, sim: &Simulation, with_links: bool, last: bool) -> World {
        let final_round = last || sim.round() >= sim.total_rounds();
        let max_links = self.opts.max_links;
        // The robots and types are shared with the other worker; the simulation is not `Sync`.
        let (robots, types) = (sim.robots(), sim.types());
        let ((robots, paths), (treasures, links)) = beside_on_pool(
            || (robot_rows(robots, types), planned_paths(robots)),
            || {
                let links =
                    with_links.then(|| sample_pairs(|stride| sim.links_every(stride), sim.link_count(), max_links));
                (treasure_rows(sim), links)
            },
        );
        let explored = self.explored_if_due(sim, final_round);
        let known = self.known_if_due(sim, final_round);
        World {
            robots,
            treasures,
            paths,
            links,
            explored,
            known,
            cell_m: sim.obstacles().grid().cell_m(),
        }
    }

    /// A copy of the collective explored map's tree, every `explored_every` rounds and at the
    /// final round (`None` in between).
    fn explored_if_due(&mut self, sim: &Simulation, final_round: bool) -> Option<RegionQuadtree> {
        let round = sim.round();
        let due = final_round
            || self
                .last_explored_round
                .is_none_or(|r| round >= r + self.opts.explored_every);
        if !due {
            return None;
        }
        self.last_explored_round = Some(round);
        Some(sim.explored().tree().clone())
    }

    /// The coarse regions of the known maps that changed since they were last logged, every
    /// `known_every` rounds and at the final round (`None` in between or when known regions
    /// are off). Worked out here, on the round's workers, so that a frame carries a few dozen
    /// boxes a robot, not a tree of thousands of nodes.
    fn known_if_due(&mut self, sim: &Simulation, final_round: bool) -> Option<Vec<ChangedKnown>> {
        let round = sim.round();
        match self.opts.known_every {
            Some(every) if final_round || self.last_known_round.is_none_or(|r| round >= r + every) => {
                self.last_known_round = Some(round);
                let mut changed = Vec::new();
                for robot in sim.robots() {
                    let dirty = self.known_dirty.get_mut(robot.id.index());
                    if let Some(d) = dirty.filter(|d| **d) {
                        *d = false;
                        if let Some(map) = sim.known_map(robot.id) {
                            changed.push((robot.id.index(), map.tree()));
                        }
                    }
                }
                Some(map_on_pool(&changed, |&(i, tree)| {
                    (i, layers::coarse_known_boxes(tree))
                }))
            }
            _ => None,
        }
    }

    /// Hand `frame` to the logging thread, waiting or leaving its world out when the thread
    /// is [`QUEUE_ROUNDS`] behind (see [`WhenBehind`]).
    fn send(&mut self, mut frame: Frame, final_round: bool) -> Result<(), ObserverError> {
        let Some(tx) = &self.frames else {
            return Err(ObserverError::from("the Rerun logging thread is not running"));
        };
        if self.when_behind == WhenBehind::SkipWorld && !final_round && frame.world.is_some() {
            // The queue is unbounded here (metrics and events always go through): wait for a
            // logging thread that is behind but moving, skip the world while it is stalled.
            while tx.len() >= QUEUE_ROUNDS {
                if self.progress.idle() >= STALL_TIMEOUT {
                    frame.world = None;
                    self.skipped_rounds += 1;
                    self.skipped_round = Some(frame.round);
                    // A stalled logging thread has no use for the cores: the rounds take
                    // them back until a world is logged again.
                    if let Some(loan) = &self.core_loan {
                        loan.give_back();
                    }
                    break;
                }
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
        }
        if frame.world.is_some() {
            self.logged_rounds += 1;
            self.world_round = Some(frame.round);
            if let Some(loan) = &self.core_loan {
                loan.lend();
            }
        }
        // The queue is full only when the logging thread is behind: only then is the wait
        // timed (a read of `/proc`), to tell a starved thread.
        frame = match tx.try_send(frame) {
            Ok(()) => return Ok(()),
            Err(crossbeam_channel::TrySendError::Full(f)) => f,
            Err(crossbeam_channel::TrySendError::Disconnected(_)) => return self.logging_thread_stopped(),
        };
        let wait = LoggingWait::begin();
        let mut unsent = Some(frame);
        let sent = self.starvation.wait_through(&wait, |timeout| {
            let frame = unsent.take().expect("a frame not yet sent is put back");
            match tx.send_timeout(frame, timeout) {
                Ok(()) => Some(true),
                Err(crossbeam_channel::SendTimeoutError::Timeout(frame)) => {
                    unsent = Some(frame);
                    None
                }
                Err(crossbeam_channel::SendTimeoutError::Disconnected(_)) => Some(false),
            }
        });
        if !sent {
            return self.logging_thread_stopped();
        }
        self.starvation.end(&wait);
        Ok(())
    }

    /// The logging thread stopped taking frames: its result says why.
    fn logging_thread_stopped(&mut self) -> Result<(), ObserverError> {
        self.frames = None;
        self.join_worker()?;
        Err(ObserverError::from("the Rerun logging thread stopped"))
    }

    /// Let go of a live stream whose viewer takes no data. Dropping the last handle of a
    /// `RecordingStream` joins Rerun's sender thread, which waits for ever on a paused viewer
    /// (its gRPC queue is full and the connection stays open): one handle is leaked instead,
    /// and the stream's threads end with the process.
    fn abandon_stream(&self) {
        std::mem::forget(self.rec.clone());
    }

    /// How long metric values may wait before they are sent: as long as the stream's batcher
    /// holds rows ([`crate::viewer::file_batching`] for a file,
    /// [`crate::viewer::live_batching`] for a live viewer, whose charts then move five times a
    /// second).
    fn metrics_window(&self) -> std::time::Duration {
        match self.when_behind {
            WhenBehind::Wait => crate::viewer::file_batching().flush_tick,
            WhenBehind::SkipWorld => crate::viewer::live_batching().flush_tick,
        }
    }

    /// Wait for the logging thread (after its queue was closed) and take its result.
    fn join_worker(&mut self) -> Result<(), ObserverError> {
        if let Some(worker) = self.worker.take() {
            match worker.handle.join() {
                Ok(Ok(busy)) => self.worker_busy = busy,
                Ok(Err(e)) => return Err(e.into()),
                Err(_) => return Err(ObserverError::from("the Rerun logging thread panicked")),
            }
        }
        Ok(())
    }
}

/// `a` (offered to the pool's other workers) beside `b` (on this thread) when called on a
/// rayon worker, such as the pool running the rounds; one after the other elsewhere (no pool
/// is started for them).
fn beside_on_pool<A: Send, B>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B) -> (A, B) {
    if rayon::current_thread_index().is_none() {
        return (a(), b());
    }
    let mut out_a = None;
    let out_b = rayon::in_place_scope(|scope| {
        scope.spawn(|_| out_a = Some(a()));
        b()
    });
    (out_a.expect("the scope ran `a`"), out_b)
}

/// `f` of each item, in order: spread over the pool's workers when called on a rayon worker,
/// one after the other elsewhere (no pool is started for them).
fn map_on_pool<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    use rayon::prelude::*;
    if rayon::current_thread_index().is_some() {
        items.par_iter().map(f).collect()
    } else {
        items.iter().map(f).collect()
    }
}

/// The logging thread ([`log_frames`]) and the end of its work.
struct LoggingThread {
    handle: std::thread::JoinHandle<rerun::RecordingStreamResult<std::time::Duration>>,
    /// Never sent on; disconnected once the thread's closure has returned or unwound, so
    /// that the end of a run waits for the thread without polling.
    ended: crossbeam_channel::Receiver<()>,
}

impl LoggingThread {
    /// Whether the thread's work ends within `timeout` (at once if it has ended).
    fn ends_within(&self, timeout: std::time::Duration) -> bool {
        matches!(
            self.ended.recv_timeout(timeout),
            Err(crossbeam_channel::RecvTimeoutError::Disconnected)
        )
    }
}

/// One round as the logging thread needs it: owned copies, no references into the simulation.
struct Frame {
    round: u64,
    /// Metric values in [`metric_entities`] order (none for round 0).
    metrics: Option<[f64; CHARTED]>,
    /// The round's events: (is a warning, text).
    events: Vec<(bool, String)>,
    /// The world, on logged rounds.
    world: Option<World>,
}

struct World {
    robots: Vec<RobotRow>,
    treasures: Vec<TreasureRow>,
    paths: Paths,
    /// The round's sampled deliveries as (sender, receiver), before thinning (none at the
    /// start): see [`sample_pairs`].
    links: Option<Vec<(u32, u32)>>,
    /// The collective explored map, on rounds its raster is due.
    explored: Option<RegionQuadtree>,
    /// The known maps that changed, on rounds known regions are due.
    known: Option<Vec<ChangedKnown>>,
    cell_m: f64,
}

/// A robot (by index) whose known map changed, and its coarse region
/// ([`layers::coarse_known_boxes`]).
type ChangedKnown = (usize, Vec<Aabb>);

struct RobotRow {
    id: u32,
    type_index: usize,
    class: u16,
    alive: bool,
    position: DVec2,
    z_m: f32,
    energy: f64,
    action: &'static str,
    outcome: Outcome,
    goal: Option<DVec2>,
    load: u32,
}

#[derive(PartialEq)]
struct TreasureRow {
    position: DVec2,
    remaining: u32,
    found: bool,
}

struct KnownRegion {
    entity: rerun::EntityPath,
    class: u16,
    boxes: Vec<Aabb>,
    /// The robot of each box (empty for a per-robot entity).
    robots: Vec<u32>,
}

/// One row per robot: what the world shows of it.
fn robot_rows(robots: &[Robot], types: &[RobotType]) -> Vec<RobotRow> {
    robots
        .iter()
        .map(|r| RobotRow {
            id: r.id.get(),
            type_index: r.type_index,
            class: class_of(types, r.type_index, r.alive),
            alive: r.alive,
            position: r.position,
            z_m: types[r.type_index].radius_m as f32,
            energy: r.energy,
            action: r.last_action.0.name(),
            outcome: r.last_action.1,
            goal: r.goal,
            load: r.load(),
        })
        .collect()
}

/// One row per treasure with units left.
fn treasure_rows(sim: &Simulation) -> Vec<TreasureRow> {
    sim.treasures()
        .iter()
        .filter(|t| t.buried + t.loose > 0)
        .map(|t| TreasureRow {
            position: t.position,
            remaining: t.buried + t.loose,
            found: t.found_round.is_some(),
        })
        .collect()
}

/// The planned paths of the live robots that have one, as one list of points: a vector per
/// path would cost an allocation per robot each logged round on the simulation thread.
#[derive(Default)]
struct Paths {
    /// Class id of each path.
    classes: Vec<u16>,
    /// Number of points of each path.
    lengths: Vec<usize>,
    /// The 2D points of every path in turn, each from the robot along its path.
    points: Vec<[f32; 2]>,
}

fn planned_paths(robots: &[Robot]) -> Paths {
    let mut paths = Paths::default();
    for r in robots.iter().filter(|r| r.alive && !r.path.is_empty()) {
        paths.classes.push(r.type_index as u16);
        paths.lengths.push(r.path.len() + 1);
        paths.points.push(to_2d(r.position));
        paths.points.extend(r.path.iter().map(|&p| to_2d(p)));
    }
    paths
}

/// Every `stride`-th delivery of the round, as (sender, receiver), from `every(stride)`,
/// with the stride that leaves about `2 max` of the `count` deliveries: a dense swarm
/// delivers O(n²) messages a round. The first step of [`sample_links`]; cheap enough for the
/// simulation's thread.
pub fn sample_pairs<I: Iterator<Item = Link>>(
    every: impl FnOnce(usize) -> I,
    count: usize,
    max: usize,
) -> Vec<(u32, u32)> {
    if max == 0 {
        return Vec::new();
    }
    let stride = count.div_ceil(2 * max).max(1);
    let mut pairs = Vec::with_capacity(count.div_ceil(stride));
    // `for_each` lets the flattened iterator run its inner loops itself.
    every(stride).for_each(|l| pairs.push((l.from.get(), l.to.get())));
    pairs
}

/// Up to `max` distinct undirected pairs (lower id first) of `pairs`, spread evenly over
/// them. The second step of [`sample_links`], on the logging thread.
pub fn thin_pairs(pairs: &[(u32, u32)], max: usize) -> Vec<(u32, u32)> {
    let mut keys = distinct_pairs(pairs);
    if keys.len() > max {
        let n = keys.len();
        keys = (0..max).map(|i| keys[i * n / max]).collect();
    }
    keys
}

/// The distinct pairs of `pairs` as (lower id, higher id), by lower id, each lower id's in
/// the order first met: grouped by lower id ([`group_by`]), duplicates dropped by
/// remembering, for each higher id, the last lower id it was met with. O(pairs + largest
/// id), without a comparison sort of the round's ten thousand pairs.
fn distinct_pairs(pairs: &[(u32, u32)]) -> Vec<(u32, u32)> {
    let Some(top) = pairs.iter().map(|&(a, b)| a.max(b)).max() else {
        return Vec::new();
    };
    let ids = top as usize + 1;
    let by_lower: Vec<(u32, u32)> = pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    let (start, higher) = group_by(&by_lower, ids);
    // `met_with[high]`: 1 + the lower id `high` was last met with (0: never).
    let mut met_with = vec![0u32; ids];
    let mut distinct = Vec::with_capacity(pairs.len());
    for (low, w) in start.windows(2).enumerate() {
        let mark = low as u32 + 1;
        for &high in &higher[w[0] as usize..w[1] as usize] {
            let met = &mut met_with[high as usize];
            if *met != mark {
                *met = mark;
                distinct.push((low as u32, high));
            }
        }
    }
    distinct
}

/// A counting sort: the values of `items` (bucket, value) grouped by bucket, each bucket's
/// in the order given, with where each bucket starts (`buckets + 1` offsets, the last the
/// total). Buckets are below `buckets`. O(items + buckets).
fn group_by<T: Copy + Default>(items: &[(u32, T)], buckets: usize) -> (Vec<u32>, Vec<T>) {
    let mut start = vec![0u32; buckets + 1];
    for &(b, _) in items {
        start[b as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start[..buckets].to_vec();
    let mut grouped = vec![T::default(); items.len()];
    for &(b, v) in items {
        let at = &mut fill[b as usize];
        grouped[*at as usize] = v;
        *at += 1;
    }
    (start, grouped)
}

/// Up to `max` distinct undirected pairs (lower id first) of the round's deliveries, spread
/// evenly over them: deliveries are first thinned by a stride, then the distinct pairs by
/// even spacing. Deterministic. `count` is how many links there are, `every(stride)` every
/// `stride`-th of them from the first.
pub fn sample_links<I: Iterator<Item = Link>>(
    every: impl FnOnce(usize) -> I,
    count: usize,
    max: usize,
) -> Vec<(u32, u32)> {
    thin_pairs(&sample_pairs(every, count, max), max)
}

/// The class id of a robot of type `type_index` (disabled robots share one extra class).
fn class_of(types: &[RobotType], type_index: usize, alive: bool) -> u16 {
    if alive { type_index as u16 } else { types.len() as u16 }
}

/// Colours of robot types, cycled.
const TYPE_COLORS: [[u8; 3]; 6] = [
    [80, 220, 120],
    [255, 170, 40],
    [90, 170, 255],
    [240, 90, 200],
    [250, 240, 90],
    [160, 120, 255],
];

fn log_annotations(rec: &rerun::RecordingStream, sim: &Simulation) -> rerun::RecordingStreamResult<()> {
    let mut classes: Vec<rerun::datatypes::ClassDescriptionMapElem> = sim
        .types()
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let [r, g, b] = TYPE_COLORS[i % TYPE_COLORS.len()];
            (i as u16, t.name.as_str(), rerun::datatypes::Rgba32::from_rgb(r, g, b)).into()
        })
        .collect();
    classes.push(
        (
            sim.types().len() as u16,
            "disabled",
            rerun::datatypes::Rgba32::from_rgb(120, 120, 120),
        )
            .into(),
    );
    let ctx = rerun::AnnotationContext::new(classes);
    rec.log_static("world", &ctx)?;
    rec.log_static("world3d", &ctx)
}

/// The logging thread: each frame's metrics, events and world as Rerun archetypes.
/// Returns its busy time.
fn log_frames(
    rec: &rerun::RecordingStream,
    frames: &crossbeam_channel::Receiver<Frame>,
    mut logger: Logger,
    progress: &Progress,
    loan: Option<&CoreLoan>,
) -> rerun::RecordingStreamResult<std::time::Duration> {
    // The cores go back when the queue is empty, and whenever this thread stops.
    let _give_back = GiveBackOnDrop(loan);
    let mut busy = std::time::Duration::ZERO;
    for frame in frames {
        let t0 = std::time::Instant::now();
        // Rerun's time cursor is per thread: this thread sets its own.
        rec.set_time_sequence(TIMELINE, frame.round as i64);
        if let Some(values) = &frame.metrics {
            logger.metrics.push(frame.round, values);
        }
        if logger.metrics.is_due() {
            logger.metrics.send(rec)?;
        }
        log_events(rec, &frame.events)?;
        if let Some(world) = frame.world {
            logger.log_world(rec, world)?;
        }
        busy += t0.elapsed();
        progress.tick();
        if frames.is_empty() {
            loan.map(CoreLoan::give_back);
        }
    }
    // The queue closed: the run ended (or stopped), so nothing may stay buffered.
    logger.metrics.send(rec)?;
    Ok(busy)
}

/// Gives the loan back when dropped.
struct GiveBackOnDrop<'a>(Option<&'a CoreLoan>);

impl Drop for GiveBackOnDrop<'_> {
    fn drop(&mut self) {
        self.0.map(CoreLoan::give_back);
    }
}

/// The metric values of the rounds not sent yet, a column per metric, sent as one chunk per
/// metric with `send_columns`: a row per metric and round through `log` costs Rerun's batcher
/// more than the values themselves (20 rows a round).
struct MetricColumns {
    entities: Vec<rerun::EntityPath>,
    rounds: Vec<i64>,
    /// `values[m][i]`: metric `m` after `rounds[i]`.
    values: Vec<Vec<f64>>,
    /// Rounds are sent once this long has passed since the last send (or when
    /// [`MetricColumns::MAX_ROUNDS`] wait), so a live viewer's charts stay current.
    window: std::time::Duration,
    last_sent: std::time::Instant,
}

impl MetricColumns {
    /// Most rounds held before they are sent, whatever the window.
    const MAX_ROUNDS: usize = 4096;

    fn new(window: std::time::Duration) -> Self {
        Self {
            entities: metric_entities().map(|(_, path)| path.into()).collect(),
            rounds: Vec::new(),
            values: vec![Vec::new(); CHARTED],
            window,
            last_sent: std::time::Instant::now(),
        }
    }

    fn push(&mut self, round: u64, values: &[f64; CHARTED]) {
        self.rounds.push(round as i64);
        for (column, v) in self.values.iter_mut().zip(values) {
            column.push(*v);
        }
    }

    fn is_due(&self) -> bool {
        !self.rounds.is_empty() && (self.rounds.len() >= Self::MAX_ROUNDS || self.last_sent.elapsed() >= self.window)
    }

    /// Send the held rounds, one chunk per metric.
    fn send(&mut self, rec: &rerun::RecordingStream) -> rerun::RecordingStreamResult<()> {
        self.last_sent = std::time::Instant::now();
        if self.rounds.is_empty() {
            return Ok(());
        }
        let rounds = std::mem::take(&mut self.rounds);
        for (entity, column) in self.entities.iter().zip(&mut self.values) {
            let times = rerun::TimeColumn::new_sequence(TIMELINE, rounds.iter().copied());
            let scalars = rerun::Scalars::new(std::mem::take(column)).columns_of_unit_batches()?;
            rec.send_columns(entity.clone(), [times], scalars)?;
        }
        Ok(())
    }
}

/// What the logging thread keeps from frame to frame, and what it needs of the run.
struct Logger {
    type_names: Vec<String>,
    grid: sim_core::spatial::Grid,
    max_links: usize,
    known_per_robot_max: usize,
    robot_columns: RobotColumns,
    /// Each robot's coarse region as last logged: a finer change that leaves it the same is
    /// not logged again.
    known_logged: Vec<Vec<Aabb>>,
    explored: Option<Raster>,
    metrics: MetricColumns,
    /// The treasure rows as last logged.
    treasures_logged: Option<Vec<TreasureRow>>,
}

impl Logger {
    fn new(sim: &Simulation, opts: &LogOptions, metrics_window: std::time::Duration) -> Self {
        Self {
            type_names: sim.types().iter().map(|t| t.name.clone()).collect(),
            grid: *sim.obstacles().grid(),
            max_links: opts.max_links,
            known_per_robot_max: opts.known_per_robot_max,
            robot_columns: RobotColumns::default(),
            known_logged: vec![Vec::new(); sim.robots().len()],
            explored: None,
            metrics: MetricColumns::new(metrics_window),
            treasures_logged: None,
        }
    }

    /// Log one round's world.
    fn log_world(&mut self, rec: &rerun::RecordingStream, mut world: World) -> rerun::RecordingStreamResult<()> {
        log_robots(rec, &world.robots, &self.type_names, &mut self.robot_columns)?;
        // Treasures change only when one is found or dug: the viewer keeps the last rows.
        if self.treasures_logged.as_ref() != Some(&world.treasures) {
            log_treasures(rec, &world.treasures, world.cell_m)?;
            self.treasures_logged = Some(std::mem::take(&mut world.treasures));
        }
        log_paths(rec, &world.paths)?;
        if let Some(pairs) = &world.links {
            self.log_links(rec, pairs, &world.robots)?;
        }
        if let Some(tree) = &world.explored {
            self.log_explored(rec, tree)?;
        }
        if let Some(changed) = world.known.take() {
            for region in self.known_regions(changed, &world.robots) {
                log_known_region(rec, &region)?;
            }
        }
        Ok(())
    }

    /// The round's links: an even sample of `pairs`, at most `max_links`, drawn as trails.
    fn log_links(
        &self,
        rec: &rerun::RecordingStream,
        pairs: &[(u32, u32)],
        robots: &[RobotRow],
    ) -> rerun::RecordingStreamResult<()> {
        let known = |&(a, b): &(u32, u32)| (a as usize) < robots.len() && (b as usize) < robots.len();
        let pairs: Vec<(u32, u32)> = thin_pairs(pairs, self.max_links).into_iter().filter(known).collect();
        let trails = Trails::cover(&pairs, robots.len());
        let points: Vec<[f32; 2]> = trails
            .robots
            .iter()
            .map(|&id| to_2d(robots[id as usize].position))
            .collect();
        rec.log("world/links", &strips(&points, trails.lengths.iter().copied()))
    }

    /// The collective explored region as a raster.
    fn log_explored(
        &mut self,
        rec: &rerun::RecordingStream,
        tree: &RegionQuadtree,
    ) -> rerun::RecordingStreamResult<()> {
        let raster = self
            .explored
            .get_or_insert_with(|| Raster::for_grid(&self.grid, layers::MAX_EXPLORED_PX));
        raster.fill_from(tree, true);
        let image = rerun::Image::from_l8(raster.to_l8(), [raster.width, raster.height]);
        rec.log(
            "world/explored",
            &[
                &raster.transform_2d() as &dyn rerun::AsComponents,
                &image.with_opacity(0.3).with_draw_order(draw_order::EXPLORED),
            ],
        )
    }

    /// The known regions to log: those of the changed robots whose coarse region changed, as
    /// an entity each or, in large swarms, as the whole region set of each type with a change.
    fn known_regions(&mut self, changed: Vec<ChangedKnown>, robots: &[RobotRow]) -> Vec<KnownRegion> {
        let per_robot = robots.len() <= self.known_per_robot_max;
        let mut known = Vec::new();
        let mut type_changed = vec![false; self.type_names.len()];
        for (i, boxes) in changed {
            if self.known_logged[i] == boxes {
                continue;
            }
            self.known_logged[i].clone_from(&boxes);
            let robot = &robots[i];
            if per_robot {
                known.push(KnownRegion {
                    entity: format!("world/known/{}", robot.id).into(),
                    class: robot.type_index as u16,
                    boxes,
                    robots: Vec::new(),
                });
            } else {
                type_changed[robot.type_index] = true;
            }
        }
        for (t, name) in self.type_names.iter().enumerate().filter(|&(t, _)| type_changed[t]) {
            let mut boxes = Vec::new();
            let mut owners = Vec::new();
            for robot in robots.iter().filter(|r| r.type_index == t) {
                let region = &self.known_logged[robot.id as usize];
                boxes.extend_from_slice(region);
                owners.extend(std::iter::repeat_n(robot.id, region.len()));
            }
            known.push(KnownRegion {
                entity: rerun::EntityPath::new(vec!["world".into(), "known".into(), name.as_str().into()]),
                class: t as u16,
                boxes,
                robots: owners,
            });
        }
        known
    }
}

/// The robots' columns as the logging thread last logged them. Rerun shows every component
/// at its latest value, so a column is logged again only when one of its values changed: in
/// most rounds that leaves positions and energy.
#[derive(Default)]
struct RobotColumns {
    classes: Vec<u16>,
    types: Vec<usize>,
    alive: Vec<bool>,
    loads: Vec<u32>,
    goals: Vec<Option<DVec2>>,
    outcomes: Vec<Outcome>,
    actions: Vec<&'static str>,
    /// Labels ("id" or "id +load"), rebuilt with the loads.
    labels: Vec<String>,
}

impl RobotColumns {
    /// Store `now` in `last` and say whether it differs (the first frame always does).
    fn update<T: PartialEq>(last: &mut Vec<T>, now: impl Iterator<Item = T>) -> bool {
        let now: Vec<T> = now.collect();
        if *last == now && !now.is_empty() {
            return false;
        }
        *last = now;
        true
    }
}

/// Log a round's robots: points with their detail columns in 2D, points in 3D; class ids
/// and labels only when they changed since `last`.
fn log_robots(
    rec: &rerun::RecordingStream,
    robots: &[RobotRow],
    type_names: &[String],
    last: &mut RobotColumns,
) -> rerun::RecordingStreamResult<()> {
    let classes_changed = RobotColumns::update(&mut last.classes, robots.iter().map(|r| r.class));
    let loads_changed = RobotColumns::update(&mut last.loads, robots.iter().map(|r| r.load));
    if loads_changed {
        last.labels = robots
            .iter()
            .map(|r| match r.load {
                0 => r.id.to_string(),
                load => format!("{} +{load}", r.id),
            })
            .collect();
    }
    let detail = robot_detail(robots, type_names, last, loads_changed);
    let (positions, positions3d) = robot_positions(robots);
    let mut points = rerun::Points2D::update_fields();
    let mut points3d = rerun::Points3D::update_fields();
    if classes_changed {
        points = points.with_class_ids(last.classes.iter().copied());
        points3d = points3d.with_class_ids(last.classes.iter().copied());
    }
    if loads_changed {
        points = points.with_labels(last.labels.iter().map(String::as_str));
    }
    rec.log(
        "world/robots",
        &[&positions as &dyn rerun::AsComponents, &points, &detail],
    )?;
    rec.log("world3d/robots", &[&positions3d as &dyn rerun::AsComponents, &points3d])
}

/// The robots' detail columns: energy and position every round; type, life, load, goal,
/// outcome and action only when they changed since `last` (which they update), the load
/// when `loads_changed` says so.
fn robot_detail(
    robots: &[RobotRow],
    type_names: &[String],
    last: &mut RobotColumns,
    loads_changed: bool,
) -> rerun::AnyValues {
    use rerun::external::arrow::array::{ArrayRef, BooleanArray, Float64Array, StringArray, UInt32Array};
    use std::sync::Arc;

    let outcome = |o: Outcome| match o {
        Outcome::Done => "done",
        Outcome::Trimmed => "trimmed",
        Outcome::Refused => "refused",
    };
    let f64s = |values: &mut dyn Iterator<Item = Option<f64>>| Arc::new(values.collect::<Float64Array>()) as ArrayRef;
    let dense = |values: &mut dyn Iterator<Item = f64>| Arc::new(Float64Array::from_iter_values(values)) as ArrayRef;
    // Numbers and static strings only: formatting every robot's values each round would cost
    // more than the rest of this function.
    let mut detail = rerun::AnyValues::default();
    if RobotColumns::update(&mut last.types, robots.iter().map(|r| r.type_index)) {
        detail = detail.with_component_from_data(
            "type",
            Arc::new(StringArray::from_iter_values(
                robots.iter().map(|r| type_names[r.type_index].as_str()),
            )) as ArrayRef,
        );
    }
    if RobotColumns::update(&mut last.alive, robots.iter().map(|r| r.alive)) {
        detail = detail.with_component_from_data(
            "alive",
            Arc::new(robots.iter().map(|r| Some(r.alive)).collect::<BooleanArray>()),
        );
    }
    if loads_changed {
        detail = detail.with_component_from_data(
            "load",
            Arc::new(UInt32Array::from_iter_values(robots.iter().map(|r| r.load))),
        );
    }
    if RobotColumns::update(&mut last.goals, robots.iter().map(|r| r.goal)) {
        detail = detail
            .with_component_from_data("goal_x", f64s(&mut robots.iter().map(|r| r.goal.map(|g| g.x))))
            .with_component_from_data("goal_y", f64s(&mut robots.iter().map(|r| r.goal.map(|g| g.y))));
    }
    if RobotColumns::update(&mut last.outcomes, robots.iter().map(|r| r.outcome)) {
        detail = detail.with_component_from_data(
            "outcome",
            Arc::new(StringArray::from_iter_values(robots.iter().map(|r| outcome(r.outcome)))),
        );
    }
    if RobotColumns::update(&mut last.actions, robots.iter().map(|r| r.action)) {
        detail = detail.with_component_from_data(
            "action",
            Arc::new(StringArray::from_iter_values(robots.iter().map(|r| r.action))),
        );
    }
    detail
        .with_component_from_data("energy", dense(&mut robots.iter().map(|r| r.energy)))
        .with_component_from_data("x", dense(&mut robots.iter().map(|r| r.position.x)))
        .with_component_from_data("y", dense(&mut robots.iter().map(|r| r.position.y)))
}

/// The robots' 2D and 3D positions, as component batches of their points.
fn robot_positions(robots: &[RobotRow]) -> (rerun::SerializedComponentBatch, rerun::SerializedComponentBatch) {
    use rerun::external::arrow::array::ArrayRef;
    use std::sync::Arc;

    let positions: Vec<[f32; 2]> = robots.iter().map(|r| to_2d(r.position)).collect();
    let positions = rerun::SerializedComponentBatch::new(
        Arc::new(vectors::<rerun::components::Position2D>(positions.into_flattened())) as ArrayRef,
        rerun::Points2D::descriptor_positions(),
    );
    let positions3d: Vec<[f32; 3]> = robots
        .iter()
        .map(|r| [r.position.x as f32, r.position.y as f32, r.z_m])
        .collect();
    let positions3d = rerun::SerializedComponentBatch::new(
        Arc::new(vectors::<rerun::components::Position3D>(positions3d.into_flattened())) as ArrayRef,
        rerun::Points3D::descriptor_positions(),
    );
    (positions, positions3d)
}

/// The arrow array of a column of fixed-size float vectors `C` (`Vec2D`, `Position2D`,
/// `Position3D`) from their coordinates in turn: one array for the column, where the
/// archetypes' builders convert vector by vector.
fn vectors<C: rerun::Loggable>(coords: Vec<f32>) -> rerun::external::arrow::array::FixedSizeListArray {
    use rerun::external::arrow::array::{FixedSizeListArray, Float32Array};
    use rerun::external::arrow::datatypes::DataType;

    let DataType::FixedSizeList(item, dims) = C::arrow_datatype() else {
        unreachable!("a vector is a fixed-size list of floats")
    };
    FixedSizeListArray::new(item, dims, std::sync::Arc::new(Float32Array::from(coords)), None)
}

/// What does not change from round to round, logged once.
fn log_styles(rec: &rerun::RecordingStream) -> rerun::RecordingStreamResult<()> {
    rec.log_static(
        "world/paths",
        &rerun::LineStrips2D::update_fields()
            // No class (type) name on paths: it clutters the map, and robots carry labels.
            .with_show_labels(false)
            .with_radii([rerun::Radius::new_ui_points(1.0)])
            .with_draw_order(draw_order::PATHS),
    )?;
    rec.log_static(
        "world/links",
        &rerun::LineStrips2D::update_fields()
            .with_colors([rerun::Color::from_unmultiplied_rgba(120, 220, 255, 140)])
            .with_radii([rerun::Radius::new_ui_points(0.75)])
            .with_draw_order(draw_order::LINKS),
    )?;
    rec.log_static(
        "world/robots",
        &rerun::Points2D::update_fields()
            .with_radii([rerun::Radius::new_ui_points(4.0)])
            .with_draw_order(draw_order::ROBOTS),
    )?;
    rec.log_static(
        "world3d/robots",
        &rerun::Points3D::update_fields()
            .with_radii([rerun::Radius::new_ui_points(3.0)])
            .with_show_labels(false),
    )
}

fn log_known_region(rec: &rerun::RecordingStream, region: &KnownRegion) -> rerun::RecordingStreamResult<()> {
    use rerun::external::arrow::array::{ArrayRef, UInt32Array};

    let boxes = layers::boxes_2d(&region.boxes)
        .with_class_ids([region.class])
        .with_show_labels(false)
        .with_draw_order(draw_order::KNOWN);
    if region.robots.is_empty() {
        return rec.log(region.entity.clone(), &boxes);
    }
    let owners = rerun::AnyValues::default().with_component_from_data(
        "robot",
        std::sync::Arc::new(UInt32Array::from(region.robots.clone())) as ArrayRef,
    );
    rec.log(region.entity.clone(), &[&boxes as &dyn rerun::AsComponents, &owners])
}

fn log_treasures(
    rec: &rerun::RecordingStream,
    treasures: &[TreasureRow],
    cell_m: f64,
) -> rerun::RecordingStreamResult<()> {
    let color = |found: bool| {
        if found {
            rerun::Color::from_rgb(255, 215, 0)
        } else {
            rerun::Color::from_unmultiplied_rgba(255, 215, 0, 110)
        }
    };
    let radii: Vec<f32> = treasures
        .iter()
        .map(|t| layers::treasure_radius(t.remaining, cell_m))
        .collect();
    let colors: Vec<rerun::Color> = treasures.iter().map(|t| color(t.found)).collect();
    rec.log(
        "world/treasures",
        &rerun::Points2D::new(treasures.iter().map(|t| to_2d(t.position)))
            .with_radii(radii.iter().copied())
            .with_colors(colors.iter().copied())
            .with_labels(treasures.iter().map(|t| t.remaining.to_string()))
            .with_draw_order(draw_order::TREASURES),
    )?;
    rec.log(
        "world3d/treasures",
        &rerun::Points3D::new(
            treasures
                .iter()
                .map(|t| [t.position.x as f32, t.position.y as f32, 0.2]),
        )
        .with_radii(radii)
        .with_colors(colors),
    )
}

fn log_paths(rec: &rerun::RecordingStream, paths: &Paths) -> rerun::RecordingStreamResult<()> {
    let style = rerun::LineStrips2D::update_fields().with_class_ids(paths.classes.iter().copied());
    let strips = strips(&paths.points, paths.lengths.iter().copied());
    rec.log("world/paths", &[&strips as &dyn rerun::AsComponents, &style])
}

/// Segments between robots chained into trails: each trail is a polyline whose consecutive
/// robots are one segment, so a robot shared by consecutive segments is stored once: about
/// half the points of one strip per segment in a dense round.
///
/// Invariant: the trails' consecutive pairs are exactly the given segments, each once
/// (`trails_draw_every_segment_once`).
#[derive(Debug, Default)]
struct Trails {
    /// The robots of every trail in turn.
    robots: Vec<u32>,
    /// Robots per trail (each at least 2).
    lengths: Vec<usize>,
}

impl Trails {
    /// Trails covering `pairs` (distinct undirected segments between robots below `robots`).
    /// Greedy: walks start at robots with an odd number of unused segments first (a walk
    /// from one ends at another), then anywhere. O(robots + segments).
    fn cover(pairs: &[(u32, u32)], robots: usize) -> Self {
        // The segments at each robot (`at[start[v]..start[v + 1]]`); the ends of segment e
        // are pairs[e].
        let mut ends = Vec::with_capacity(2 * pairs.len());
        for (e, &(a, b)) in (0u32..).zip(pairs) {
            ends.push((a, e));
            ends.push((b, e));
        }
        let (start, at) = group_by(&ends, robots);
        let mut used = vec![false; pairs.len()];
        // Per robot, the first of its segments that may still be unused.
        let mut next = start[..robots].to_vec();
        let mut unused: Vec<u32> = start.windows(2).map(|w| w[1] - w[0]).collect();
        let mut trails = Self::default();
        let odd: Vec<u32> = (0..robots as u32).filter(|&v| unused[v as usize] % 2 == 1).collect();
        let rest = 0..robots as u32;
        for first in odd.into_iter().chain(rest) {
            while unused[first as usize] > 0 {
                let begin = trails.robots.len();
                trails.robots.push(first);
                let mut v = first;
                loop {
                    let row = v as usize;
                    let end = start[row + 1];
                    while next[row] < end && used[at[next[row] as usize] as usize] {
                        next[row] += 1;
                    }
                    if next[row] == end {
                        break;
                    }
                    let e = at[next[row] as usize] as usize;
                    used[e] = true;
                    let (a, b) = pairs[e];
                    unused[a as usize] -= 1;
                    unused[b as usize] -= 1;
                    v = if a == v { b } else { a };
                    trails.robots.push(v);
                }
                trails.lengths.push(trails.robots.len() - begin);
            }
        }
        trails
    }
}

/// The `LineStrip2D` column of strips of `lengths` points taken in turn from `points`, built
/// as one arrow array: the archetype's builder makes a vector per strip, thousands a round.
fn strips(points: &[[f32; 2]], lengths: impl Iterator<Item = usize>) -> rerun::SerializedComponentBatch {
    use rerun::external::arrow::array::{ArrayRef, ListArray};
    use rerun::external::arrow::buffer::OffsetBuffer;
    use rerun::external::arrow::datatypes::DataType;
    use std::sync::Arc;

    let points = vectors::<rerun::datatypes::Vec2D>(points.as_flattened().to_vec());
    let DataType::List(strip_field) = <rerun::components::LineStrip2D as rerun::Loggable>::arrow_datatype() else {
        unreachable!("a LineStrip2D is a list of Vec2D")
    };
    let offsets = OffsetBuffer::from_lengths(lengths);
    let strips = ListArray::new(strip_field, offsets, Arc::new(points), None);
    rerun::SerializedComponentBatch::new(Arc::new(strips) as ArrayRef, rerun::LineStrips2D::descriptor_strips())
}

/// A round's metric values in [`metric_entities`] order.
fn metric_values(report: &RoundReport) -> [f64; CHARTED] {
    let mut values = [0.0; CHARTED];
    for (slot, (_, _, v)) in values.iter_mut().zip(report.metrics.series()) {
        *slot = v;
    }
    values
}

fn log_events(rec: &rerun::RecordingStream, events: &[(bool, String)]) -> rerun::RecordingStreamResult<()> {
    for (warning, text) in events {
        let level = if *warning {
            rerun::TextLogLevel::WARN
        } else {
            rerun::TextLogLevel::INFO
        };
        rec.log("events", &rerun::TextLog::new(text.as_str()).with_level(level))?;
    }
    Ok(())
}

fn log_series_styles(rec: &rerun::RecordingStream) -> rerun::RecordingStreamResult<()> {
    for (column, path) in metric_entities() {
        rec.log_static(path, &rerun::SeriesLines::new().with_names([column]))?;
    }
    Ok(())
}

impl Observer for RerunObserver {
    fn on_start(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        let t0 = std::time::Instant::now();
        self.rec.set_time_sequence(TIMELINE, 0);
        log_annotations(&self.rec, sim)?;
        log_series_styles(&self.rec)?;
        log_styles(&self.rec)?;
        self.known_dirty = vec![true; sim.robots().len()];

        let (tx, rx) = match self.when_behind {
            WhenBehind::Wait => crossbeam_channel::bounded(QUEUE_ROUNDS),
            WhenBehind::SkipWorld => crossbeam_channel::unbounded(),
        };
        let rec = self.rec.clone();
        let logger = Logger::new(sim, &self.opts, self.metrics_window());
        let progress = std::sync::Arc::clone(&self.progress);
        let loan = self.core_loan.clone();
        progress.tick();
        let map = sim.shared_map();
        let (ended_tx, ended) = crossbeam_channel::bounded(0);
        let handle = std::thread::Builder::new()
            .name("rerun-observer".into())
            .spawn(move || {
                // Dropped when this closure returns or unwinds: see `LoggingThread::ended`.
                let _ended: crossbeam_channel::Sender<()> = ended_tx;
                crate::priority::lower_priority();
                // The map's raster and outlines are built here, beside the first rounds.
                layers::log_static_map(&rec, &map)?;
                drop(map);
                log_frames(&rec, &rx, logger, &progress, loan.as_deref())
            })?;
        self.worker = Some(LoggingThread { handle, ended });
        self.frames = Some(tx);
        let world = self.snapshot_world(sim, false, false);
        self.send(
            Frame {
                // A resumed run starts at its checkpoint's round.
                round: sim.round(),
                metrics: None,
                events: Vec::new(),
                world: Some(world),
            },
            false,
        )?;
        self.busy += t0.elapsed();
        Ok(())
    }

    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        if let Some(failed) = write_failure(self.file.as_deref()) {
            return Err(failed);
        }
        if self.viewer_gone(report.round) {
            return Ok(());
        }
        let t0 = std::time::Instant::now();
        for id in &report.known_changed {
            if let Some(d) = self.known_dirty.get_mut(id.index()) {
                *d = true;
            }
        }
        let final_round = report.round >= sim.total_rounds();
        let world = self
            .is_logged_round(report.round, sim.total_rounds())
            .then(|| self.snapshot_world(sim, true, false));
        let events = report
            .events
            .iter()
            .map(|e| {
                (
                    matches!(e, Event::RobotDisabled { .. } | Event::StrategyFailed { .. }),
                    format!("round {}: {e}", report.round),
                )
            })
            .collect();
        self.send(
            Frame {
                round: report.round,
                metrics: Some(metric_values(report)),
                events,
                world,
            },
            final_round,
        )?;
        self.busy += t0.elapsed();
        Ok(())
    }

    fn on_finish(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        let t0 = std::time::Instant::now();
        if self.viewer_gone(sim.round()) {
            self.leave_lost_viewer();
            self.closing = t0.elapsed();
            return Ok(());
        }
        self.log_last_round(sim)?;
        // Closing the queue lets the logging thread finish what is queued and stop.
        self.frames = None;
        let wait = LoggingWait::begin();
        match self.when_behind {
            WhenBehind::Wait => {
                if let Some(worker) = &self.worker {
                    self.starvation
                        .wait_through(&wait, |timeout| worker.ends_within(timeout).then_some(()));
                }
                self.join_worker()?;
            }
            WhenBehind::SkipWorld => {
                // A paused viewer can block the logging thread for ever: give it a while,
                // then leave it (it holds its own handle on the stream).
                let left = FINISH_TIMEOUT.saturating_sub(t0.elapsed());
                if self.worker.as_ref().is_none_or(|w| w.ends_within(left)) {
                    self.join_worker()?;
                } else {
                    self.worker = None;
                    // Starved of the CPU, the logging thread is behind, not the viewer.
                    if !self.starvation.check(&wait) {
                        eprintln!("warning: the Rerun viewer is not taking data; the last rounds may not reach it");
                    }
                    self.abandon_stream();
                    return Ok(());
                }
            }
        }
        // Transport trouble (a viewer gone) must not fail a finished run: report and go on.
        // A file that could not be written is the run's error.
        let flushed = match self.when_behind {
            WhenBehind::Wait => {
                let mut flushed = self.flush_file(&wait);
                if write_failure(self.file.as_deref()).is_none() {
                    flushed = flushed.map(|()| self.close_file(&wait));
                }
                if let Some(failed) = write_failure(self.file.as_deref()) {
                    // Rerun's stream may never finish a flush or a close after its writer
                    // stopped: it is left, and ends with the process.
                    self.abandon_stream();
                    self.closing = t0.elapsed();
                    return Err(failed);
                }
                flushed
            }
            WhenBehind::SkipWorld => self.flush_live(),
        };
        match flushed {
            Err(e) => {
                // A viewer that went while the stream was flushed is told as one gone.
                if !self.viewer_gone(sim.round()) {
                    eprintln!("warning: could not flush the Rerun stream: {e}");
                }
                if self.when_behind == WhenBehind::SkipWorld {
                    self.abandon_stream();
                }
            }
            Ok(()) if self.when_behind == WhenBehind::SkipWorld => self.close_live(),
            Ok(()) => {}
        }
        self.closing = t0.elapsed();
        Ok(())
    }
}

impl RerunObserver {
    /// Whether the live viewer is gone: known before, or found now, at `round` (said once,
    /// on stderr; the logging thread is then told to stop, and its sends fail at once). A
    /// read of the connection's state a round while the viewer is there.
    fn viewer_gone(&mut self, round: u64) -> bool {
        if self.viewer_lost.is_some() {
            return true;
        }
        let Some(reason) = self.viewer.as_ref().and_then(ViewerLink::lost) else {
            return false;
        };
        eprintln!(
            "warning: round {round}: the Rerun viewer stopped taking the stream ({reason}); the run goes on without it"
        );
        self.viewer_lost = Some((round, reason));
        self.frames = None;
        true
    }

    /// End the logging to a viewer that is gone: the logging thread is waited for (a
    /// while at most) and the stream is left, not flushed.
    fn leave_lost_viewer(&mut self) {
        if self.worker.as_ref().is_none_or(|w| w.ends_within(FINISH_TIMEOUT)) {
            // A logging error after the viewer went is of no use to anyone.
            let _ = self.join_worker();
        }
        self.worker = None;
        self.abandon_stream();
    }

    /// Log the world of the run's last round if it is not logged: a run stopped by a signal
    /// between rounds `--log-every` logs, or whose live viewer was behind at its last round,
    /// still shows where it stopped (a run that plays all its rounds logs its final round
    /// anyway).
    fn log_last_round(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        let round = sim.round();
        if self.frames.is_none() || self.world_round == Some(round) {
            return Ok(());
        }
        if self.skipped_round == Some(round) {
            self.skipped_rounds -= 1;
        }
        let world = self.snapshot_world(sim, true, true);
        let frame = Frame {
            round,
            // The round's metrics and events went with its own frame.
            metrics: None,
            events: Vec::new(),
            world: Some(world),
        };
        self.send(frame, true)
    }

    /// Flush a file's stream until it is written, or the writer fails (a full disk, say):
    /// closing the stream would wait as long, and a flush says why it failed. A flush still
    /// going when the run's waits for its logging (`wait`, begun when the rounds ended, and
    /// those before) add up to [`crate::priority::STARVED_AFTER`] asks whether the logging
    /// is starved, and asks again until it ends.
    fn flush_file(&mut self, wait: &LoggingWait) -> Result<(), String> {
        let flushed = on_thread("rerun-flush", self.flush_job(std::time::Duration::MAX))
            .map_err(|e| format!("cannot start the flush: {e}"))?;
        let file = self.file.as_deref();
        self.starvation
            .wait_through(wait, |timeout| match flushed.recv_timeout(timeout) {
                Ok(result) => Some(result),
                // A writer that failed may leave the flush waiting for ever; the caller says why.
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                    write_failure(file).map(|_| Err("the recording could not be written".to_owned()))
                }
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => {
                    Some(Err("the flush's thread panicked".to_owned()))
                }
            })
    }

    /// Close a file's stream and wait until the file is whole: dropping the stream's last
    /// handle writes what the writer holds and the file's footer, so the run reports a
    /// complete recording. A close still going when the run's waits add up to
    /// [`crate::priority::STARVED_AFTER`] asks whether the logging is starved, as
    /// [`RerunObserver::flush_file`] does.
    fn close_file(&mut self, wait: &LoggingWait) {
        let rec = std::mem::replace(&mut self.rec, rerun::RecordingStream::disabled());
        // Should no thread start, the closure and the stream are dropped here, at once.
        let Ok(closed) = on_thread("rerun-close", move || drop(rec)) else {
            return;
        };
        let file = self.file.as_deref();
        self.starvation.wait_through(wait, |timeout| {
            // Ended, or its thread gone: either way the close is over. A writer that failed
            // meanwhile may leave it waiting for ever: it is left, to end with the process.
            let waiting = matches!(
                closed.recv_timeout(timeout),
                Err(crossbeam_channel::RecvTimeoutError::Timeout)
            );
            (!waiting || write_failure(file).is_some()).then_some(())
        });
    }

    /// Flush a live stream, waiting at most [`FINISH_TIMEOUT`] (see [`on_thread_within`]).
    fn flush_live(&self) -> Result<(), String> {
        let flushed = on_thread_within(
            "rerun-flush",
            FINISH_TIMEOUT + std::time::Duration::from_secs(1),
            self.flush_job(FINISH_TIMEOUT),
        );
        match flushed {
            Ok(Some(result)) => result,
            Ok(None) => Err("the viewer took no data".to_owned()),
            Err(e) => Err(format!("cannot start the flush: {e}")),
        }
    }

    /// A flush of the stream waiting at most `timeout`, to run on a thread of its own. It
    /// lets go of its handle before it returns: the caller then holds the last one (see
    /// `close_file` and `close_live`), not a thread the process may not wait for.
    fn flush_job(&self, timeout: std::time::Duration) -> impl FnOnce() -> Result<(), String> + Send + 'static {
        let rec = self.rec.clone();
        move || {
            let result = rec.flush_with_timeout(timeout).map_err(|e| e.to_string());
            drop(rec);
            result
        }
    }

    /// Close a flushed live stream, waiting at most [`FINISH_TIMEOUT`] (see
    /// [`on_thread_within`]). A flush only hands the messages to the gRPC connection;
    /// dropping the stream's last handle ends the connection once the viewer has taken them
    /// all. Done here, the run cannot end (and its process exit) with the last rounds still
    /// on their way.
    fn close_live(&mut self) {
        let rec = std::mem::replace(&mut self.rec, rerun::RecordingStream::disabled());
        if !matches!(
            on_thread_within("rerun-close", FINISH_TIMEOUT, move || drop(rec)),
            Ok(Some(()))
        ) {
            eprintln!(
                "warning: the Rerun viewer did not take the end of the recording; the last rounds may not reach it"
            );
        }
    }
}

/// The run's error when Rerun reported that writing `file` failed (see
/// [`crate::rerun_errors`]); `None` without a file or a report.
fn write_failure(file: Option<&std::path::Path>) -> Option<ObserverError> {
    let file = file?;
    let reason = crate::rerun_errors::file_write_failure(file)?;
    Some(
        format!(
            "cannot write the recording {}: {reason}; it holds the rounds written before",
            file.display()
        )
        .into(),
    )
}

/// What `f` returns, run on a thread of its own named `name`, if it ends within `timeout`;
/// `Ok(None)` if it does not, and the thread is left behind. Rerun's flush and close wait for
/// ever on a viewer that takes no data (its batcher is stuck sending).
fn on_thread_within<T: Send + 'static>(
    name: &str,
    timeout: std::time::Duration,
    f: impl FnOnce() -> T + Send + 'static,
) -> std::io::Result<Option<T>> {
    Ok(on_thread(name, f)?.recv_timeout(timeout).ok())
}

/// Run `f` on a thread of its own named `name`; the receiver gets what it returns, once
/// it has returned.
fn on_thread<T: Send + 'static>(
    name: &str,
    f: impl FnOnce() -> T + Send + 'static,
) -> std::io::Result<crossbeam_channel::Receiver<T>> {
    let (done, finished) = crossbeam_channel::bounded(1);
    std::thread::Builder::new().name(name.to_owned()).spawn(move || {
        let _ = done.send(f());
    })?;
    Ok(finished)
}

/// How long the end of a run waits for a live viewer to take the rest of the recording.
const FINISH_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

#[cfg(test)]
mod tests {
    use super::*;
    use sim_core::spatial::RobotId;
    use std::collections::BTreeSet;

    fn link(from: u32, to: u32) -> Link {
        Link {
            from: RobotId::new(from),
            to: RobotId::new(to),
        }
    }

    /// Every robot of `n` broadcasts to every other: n(n−1) deliveries, n(n−1)/2 pairs.
    fn all_to_all(n: u32) -> Vec<Link> {
        (0..n)
            .flat_map(|a| (0..n).filter(move |&b| b != a).map(move |b| link(a, b)))
            .collect()
    }

    #[test]
    fn few_links_are_all_drawn_once() {
        let links = [link(3, 1), link(1, 3), link(2, 5), link(5, 2), link(2, 5)];
        assert_eq!(
            sample_links(|k| links.iter().copied().step_by(k), links.len(), 10),
            vec![(1, 3), (2, 5)]
        );
        assert_eq!(
            sample_links(|k| links.iter().copied().step_by(k), links.len(), 0),
            vec![]
        );
        assert_eq!(sample_links(|_| std::iter::empty(), 0, 10), vec![]);
    }

    #[test]
    fn a_dense_round_is_sampled_evenly_within_the_cap() {
        // 200 robots all in range: 39,800 deliveries, 19,900 distinct pairs.
        let links = all_to_all(200);
        let all: BTreeSet<(u32, u32)> = links
            .iter()
            .map(|l| (l.from.get().min(l.to.get()), l.from.get().max(l.to.get())))
            .collect();
        assert_eq!(all.len(), 19_900);
        let sample = sample_links(|k| links.iter().copied().step_by(k), links.len(), 1_000);
        assert!(sample.len() <= 1_000 && sample.len() >= 900, "{} pairs", sample.len());
        let distinct: BTreeSet<_> = sample.iter().copied().collect();
        assert_eq!(distinct.len(), sample.len(), "no pair twice");
        assert!(distinct.is_subset(&all), "only real pairs");
        // Even: every quarter of the senders shows up, not just the first ones (a prefix of
        // the deliveries would hold robot 0's and 1's links only).
        for quarter in 0..4 {
            let lo = quarter * 50;
            assert!(
                sample.iter().any(|&(_, b)| (lo..lo + 50).contains(&b)),
                "no link reaches robots {lo}..{}",
                lo + 50
            );
        }
        assert!(sample.iter().filter(|&&(a, _)| a == 0).count() < 100);
        // Deterministic.
        assert_eq!(
            sample,
            sample_links(|k| links.iter().copied().step_by(k), links.len(), 1_000)
        );
    }

    /// The segments a cover draws: consecutive robots of each trail, lower id first.
    fn drawn(trails: &Trails) -> Vec<(u32, u32)> {
        let mut drawn = Vec::new();
        let mut from = 0;
        for &len in &trails.lengths {
            assert!(len >= 2, "a trail of {len} robots");
            for w in trails.robots[from..from + len].windows(2) {
                drawn.push((w[0].min(w[1]), w[0].max(w[1])));
            }
            from += len;
        }
        assert_eq!(from, trails.robots.len());
        drawn.sort_unstable();
        drawn
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..Default::default() })]

        #[test]
        fn trails_draw_every_segment_once(
            robots in 1usize..40,
            raw in proptest::collection::vec((0u32..40, 0u32..40), 0..200),
        ) {
            let mut pairs: Vec<(u32, u32)> = raw
                .into_iter()
                .map(|(a, b)| (a % robots as u32, b % robots as u32))
                .map(|(a, b)| (a.min(b), a.max(b)))
                .collect();
            pairs.sort_unstable();
            pairs.dedup();
            let trails = Trails::cover(&pairs, robots);
            proptest::prop_assert_eq!(drawn(&trails), pairs.clone());
            proptest::prop_assert_eq!(trails.robots.len(), pairs.len() + trails.lengths.len());
        }
    }

    #[test]
    fn trails_of_a_dense_round_share_most_points() {
        // 200 robots all in range, sampled as a round's links are: at most 5,000 pairs.
        let links = all_to_all(200);
        let pairs = sample_links(|k| links.iter().copied().step_by(k), links.len(), 5_000);
        let trails = Trails::cover(&pairs, 200);
        let mut sorted = pairs.clone();
        sorted.sort_unstable();
        assert_eq!(drawn(&trails), sorted);
        // One strip per segment would take 2 points a segment.
        assert!(
            trails.robots.len() * 10 < pairs.len() * 2 * 6,
            "{} points for {} segments",
            trails.robots.len(),
            pairs.len()
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(11), ..Default::default() })]

        #[test]
        fn distinct_pairs_are_each_pair_once_by_lower_id(
            raw in proptest::collection::vec((0u32..300, 0u32..300), 0..500),
        ) {
            let got = distinct_pairs(&raw);
            let mut expected: Vec<(u32, u32)> = raw.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
            expected.sort_unstable();
            expected.dedup();
            proptest::prop_assert!(got.windows(2).all(|w| w[0].0 <= w[1].0), "not by lower id: {:?}", got);
            let mut sorted = got.clone();
            sorted.sort_unstable();
            proptest::prop_assert_eq!(sorted, expected);
        }
    }

    /// A sink that takes every message and notes when Rerun lets go of it, which it does
    /// when the stream's last handle is dropped.
    struct DropNoted(std::sync::Arc<std::sync::atomic::AtomicBool>);

    impl rerun::sink::LogSink for DropNoted {
        fn send(&self, _msg: rerun::log::LogMsg) {}

        fn flush_blocking(&self, _timeout: std::time::Duration) -> Result<(), rerun::sink::SinkFlushError> {
            Ok(())
        }
    }

    impl Drop for DropNoted {
        fn drop(&mut self) {
            self.0.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    }

    /// Five random walkers in an empty 20 m square, for `rounds` rounds.
    fn walkers(rounds: u64) -> Simulation {
        use sim_core::engine::{Group, ScenarioBuilder};
        use sim_core::spatial::{Grid, ObstacleMap};
        use sim_core::world::{HomeBase, MapData};
        let grid = Grid::from_size_m(DVec2::ZERO, 0.5, 20.0, 20.0).unwrap();
        let map = MapData {
            obstacles: ObstacleMap::from_fn(grid, |_, _| false),
            home: HomeBase::Disc {
                center: DVec2::splat(10.0),
                radius_m: 1.0,
            },
            treasures: Vec::new(),
        };
        let registry = sim_core::agent::StrategyRegistry::with_builtins();
        let scenario = ScenarioBuilder::new(std::sync::Arc::new(map))
            .with_rounds(rounds)
            .with_types(vec![RobotType::explorer()])
            .with_group(Group::new("random_walk", 0, 5))
            .build(&registry)
            .unwrap();
        Simulation::new(scenario).unwrap()
    }

    #[test]
    fn a_live_stream_is_closed_by_the_end_of_the_run() {
        let closed = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let rec = rerun::RecordingStreamBuilder::new("closing").buffered().unwrap();
        rec.set_sink(Box::new(DropNoted(std::sync::Arc::clone(&closed))));
        let mut observer = RerunObserver::new(rec, LogOptions::default()).with_when_behind(WhenBehind::SkipWorld);
        let mut sim = walkers(5);
        observer.on_start(&sim).unwrap();
        while sim.round() < sim.total_rounds() {
            sim.step();
            observer.on_round(&sim, sim.report()).unwrap();
        }
        observer.on_finish(&sim).unwrap();
        // Closed here, by the run's own thread: the process may exit next.
        assert!(
            closed.load(std::sync::atomic::Ordering::SeqCst),
            "the stream was still open"
        );
        drop(observer);
    }
}
