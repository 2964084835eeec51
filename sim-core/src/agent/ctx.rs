//! [`Ctx`]: everything a strategy sees and may do in one round.

use std::sync::Arc;

use glam::DVec2;

use crate::agent::perception::{DataModule, Perception, SeenRobot, SeenTreasure};
use crate::spatial::{KnownMap, LazyNavGraph, NavGraph, ObstacleMap, RobotId, Terrain};
use crate::world::{Action, HomeBase, Inbox, Outcome, Payload, Recipient, Robot, RobotType, StrategyEvent};

/// The unchanging world a strategy may consult.
#[derive(Clone, Copy, Debug)]
pub struct WorldView<'a> {
    obstacles: &'a ObstacleMap,
    nav: &'a LazyNavGraph,
    home: HomeBase,
    types: &'a [RobotType],
    /// Whether [`Ctx::timed_planning`] reads the clock.
    time_planning: bool,
}

impl<'a> WorldView<'a> {
    /// A view of the kernel's obstacles (a strategy reads them only inside its known region,
    /// through [`Ctx`]), the navigation graph of those obstacles (built when first asked
    /// for), the home base and the run's robot types.
    pub fn new(obstacles: &'a ObstacleMap, nav: &'a LazyNavGraph, home: HomeBase, types: &'a [RobotType]) -> Self {
        Self {
            obstacles,
            nav,
            home,
            types,
            time_planning: false,
        }
    }

    /// The same view, with [`Ctx::timed_planning`] timing the planning it wraps when `on`.
    #[must_use]
    pub fn with_time_planning(self, on: bool) -> Self {
        Self {
            time_planning: on,
            ..self
        }
    }
}

/// What a strategy leaves behind in a round besides its action: messages to send, the goal
/// and path it publishes, and events for the log. The kernel reads and clears it.
#[derive(Clone, Debug, Default)]
pub struct StrategyOutput {
    outbox: Vec<(Recipient, Payload)>,
    goal: Option<DVec2>,
    path: Vec<DVec2>,
    events: Vec<StrategyEvent>,
}

impl StrategyOutput {
    /// Messages asked for this round, in order.
    pub fn outbox(&self) -> &[(Recipient, Payload)] {
        &self.outbox
    }
    /// Take the messages (leaves the outbox empty).
    pub fn take_outbox(&mut self) -> Vec<(Recipient, Payload)> {
        std::mem::take(&mut self.outbox)
    }
    /// Give back the outbox's list, emptied, after [`take_outbox`](Self::take_outbox): the
    /// next round's messages reuse it instead of allocating a fresh list.
    pub(crate) fn give_back_outbox(&mut self, mut list: Vec<(Recipient, Payload)>) {
        if self.outbox.is_empty() && self.outbox.capacity() < list.capacity() {
            list.clear();
            self.outbox = list;
        }
    }
    /// The published goal (kept from round to round until changed).
    pub fn goal(&self) -> Option<DVec2> {
        self.goal
    }
    /// The published path (kept from round to round until changed).
    pub fn path(&self) -> &[DVec2] {
        &self.path
    }
    /// Events reported this round.
    pub fn events(&self) -> &[StrategyEvent] {
        &self.events
    }
    /// Forget this round's messages and events (goal and path stay).
    pub fn begin_round(&mut self) {
        self.outbox.clear();
        self.events.clear();
    }

    /// Put back the goal and path kept from round to round (a checkpoint restores them).
    pub fn restore(&mut self, goal: Option<DVec2>, path: Vec<DVec2>) {
        self.goal = goal;
        self.path = path;
    }
}

/// One robot's mind as the kernel keeps it: this round's perception, the data module and
/// what the strategy left behind.
#[derive(Clone, Debug)]
pub struct Mind {
    /// This round's perceptions.
    pub perception: Perception,
    /// What the robot remembers.
    pub data: DataModule,
    /// Messages, goal, path and events from the strategy.
    pub output: StrategyOutput,
}

impl Mind {
    /// An empty mind around a data module.
    pub fn new(data: DataModule) -> Self {
        Self {
            perception: Perception::default(),
            data,
            output: StrategyOutput::default(),
        }
    }
}

/// A robot's random generator for one round (xoshiro256++: seeded and drawn from in a few
/// nanoseconds, as every robot seeds one every round). Draw from it with [`rand::Rng`]'s
/// methods, e.g. `ctx.rng.random_bool(0.1)`; it is seeded from (run seed, robot, round), so
/// a run is the same on any number of threads.
pub type RobotRng = rand_xoshiro::Xoshiro256PlusPlus;

/// Everything a strategy sees and may do in one round.
pub struct Ctx<'a> {
    /// Current round (1-based).
    pub round: u64,
    /// This robot's state at the start of the round.
    pub me: &'a Robot,
    /// This robot's type.
    pub kind: &'a RobotType,
    perception: &'a Perception,
    /// The data module.
    pub data: &'a mut DataModule,
    world: WorldView<'a>,
    /// Random numbers, seeded from (run seed, robot, round).
    pub rng: RobotRng,
    out: &'a mut StrategyOutput,
    /// Wall time spent in [`timed_planning`](Self::timed_planning) this round, ns (atomic,
    /// not a `Cell`, so that a context stays `Sync` for strategies that share it across
    /// threads).
    planning_ns: std::sync::atomic::AtomicU64,
}

impl<'a> Ctx<'a> {
    /// The context of robot `me` (of type `kind`) in `round`, over `world`, with its `mind`
    /// and random generator. The kernel builds one per robot and round; tests build their
    /// own (see [`TestWorld`](crate::agent::TestWorld)).
    pub fn new(
        round: u64,
        me: &'a Robot,
        kind: &'a RobotType,
        world: WorldView<'a>,
        rng: RobotRng,
        mind: &'a mut Mind,
    ) -> Self {
        let Mind {
            perception,
            data,
            output,
        } = mind;
        Self {
            round,
            me,
            kind,
            perception,
            data,
            world,
            rng,
            out: output,
            planning_ns: std::sync::atomic::AtomicU64::new(0),
        }
    }

    /// Run `plan` (a route or frontier search), adding its wall time to this round's
    /// [`planning_ns`](Self::planning_ns) when the run times planning (the kernel's
    /// `Simulation::with_time_planning`, a layer up); otherwise just run it. The built-in
    /// tactics plan through this, so that navigation time per robot-round can be measured
    /// (`smartteams-bench kernel`).
    pub fn timed_planning<T>(&self, plan: impl FnOnce() -> T) -> T {
        if !self.world.time_planning {
            return plan();
        }
        let started = std::time::Instant::now();
        let planned = plan();
        let took = u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.planning_ns.fetch_add(took, std::sync::atomic::Ordering::Relaxed);
        planned
    }

    /// Wall time spent planning this round through [`timed_planning`](Self::timed_planning),
    /// in nanoseconds (0 when the run does not time planning).
    pub fn planning_ns(&self) -> u64 {
        self.planning_ns.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Robots in view (empty unless the strategy needs robots).
    pub fn robots_in_view(&self) -> &'a [SeenRobot] {
        &self.perception.robots
    }
    /// Treasures in view (empty unless the strategy needs treasures).
    pub fn treasures_in_view(&self) -> &'a [SeenTreasure] {
        &self.perception.treasures
    }
    /// Messages delivered this round (empty unless the strategy needs messages).
    pub fn messages(&self) -> &'a Inbox {
        &self.perception.inbox
    }
    /// Own position.
    pub fn position(&self) -> DVec2 {
        self.me.position
    }
    /// The home base.
    pub fn home(&self) -> HomeBase {
        self.world.home
    }
    /// The run's robot types.
    pub fn types(&self) -> &'a [RobotType] {
        self.world.types
    }
    /// What came of last round's action.
    pub fn last_outcome(&self) -> Outcome {
        self.me.last_action.1
    }
    /// The known map (if the strategy keeps one).
    pub fn known(&self) -> Option<&KnownMap> {
        self.data.known.as_ref()
    }
    /// The navigation graph (plan only through nodes your known map touches). The first
    /// call in a run builds it.
    pub fn nav(&self) -> &'a NavGraph {
        self.world.nav.get_or_build(self.world.obstacles)
    }

    /// The terrain this robot plans routes in (the map, its known map and its radius), for
    /// the graph's searches; `None` if it keeps no known map.
    pub fn terrain(&self) -> Option<Terrain<'_>> {
        Some(Terrain {
            obstacles: self.world.obstacles,
            known: self.data.known.as_ref()?,
            radius_m: self.kind.radius_m,
        })
    }

    /// Whether a disc of this robot's size could move from `a` to `b` — answered from the
    /// kernel's map, and only if both ends lie in known terrain (robots never learn about
    /// obstacles they have not seen). `None` when they don't.
    pub fn can_move(&self, a: DVec2, b: DVec2) -> Option<bool> {
        let known = self.data.known.as_ref()?;
        (known.is_known(a) && known.is_known(b))
            .then(|| self.world.obstacles.is_swept_disc_free(a, b, self.kind.radius_m))
    }

    /// Whether the point is free, if it is in known terrain.
    pub fn is_free(&self, p: DVec2) -> Option<bool> {
        let known = self.data.known.as_ref()?;
        known
            .is_known(p)
            .then(|| self.world.obstacles.is_disc_free(p, self.kind.radius_m))
    }

    /// Move towards a point (the kernel trims to speed and obstacles).
    pub fn move_towards(&self, to: DVec2) -> Action {
        Action::MoveTo { to }
    }
    /// Move by an offset (scaled to the robot's speed if longer).
    pub fn move_by(&self, d: DVec2) -> Action {
        let len = d.length();
        let step = if len > self.kind.speed_m_per_round {
            d * (self.kind.speed_m_per_round / len)
        } else {
            d
        };
        Action::MoveTo {
            to: self.me.position + step,
        }
    }

    /// Send to every robot in communication range (delivered next round).
    pub fn broadcast(&mut self, payload: Payload) {
        self.out.outbox.push((Recipient::Broadcast, payload));
    }
    /// Send to one robot, if it is in range.
    pub fn send(&mut self, to: RobotId, payload: Payload) {
        self.out.outbox.push((Recipient::Direct(to), payload));
    }
    /// Share the known map with everyone in range.
    pub fn broadcast_known_map(&mut self) {
        if let Some(k) = &mut self.data.known {
            // With its content hashes, so that receivers skip what they hold alike.
            k.complete_hashes();
            let map = Arc::new(k.clone());
            self.broadcast(Payload::KnownMap(map));
        }
    }
    /// The goal this robot publishes (kept from round to round until changed).
    pub fn goal(&self) -> Option<DVec2> {
        self.out.goal
    }
    /// Publish the current goal (for viewers and team mates).
    pub fn set_goal(&mut self, goal: Option<DVec2>) {
        self.out.goal = goal;
    }
    /// Report an event for the run's event log (group changes, notes).
    pub fn report(&mut self, event: StrategyEvent) {
        self.out.events.push(event);
    }
    /// Publish the planned path (for viewers).
    pub fn set_path(&mut self, path: &[DVec2]) {
        self.out.path.clear();
        self.out.path.extend_from_slice(path);
    }
}

/// A context can be shared across threads (a strategy may plan in parallel with it).
const _: () = {
    const fn sync<T: Sync>() {}
    sync::<Ctx<'static>>();
};
