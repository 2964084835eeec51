//! Strategies (paper §4.3): one robot's decision process, plugged in by name.
//!
//! A strategy implements [`Strategy`]: it says which perceptions it [`needs`](Strategy::needs)
//! (the kernel computes nothing else for it) and, every round, [`decides`](Strategy::decide)
//! one elementary [`Action`] from a [`Ctx`] that holds its perceptions, its data module, the
//! map within its known region, its messages and a seeded random generator. Strategies are
//! created by name from a [`StrategyRegistry`], so an XML config can assign them to robot
//! groups and a user crate can add its own without touching the simulator.
//!
//! The paper's `MyStrategy` in Rust:
//!
//! ```
//! use sim_core::strategy::{Ctx, Strategy};
//! use sim_core::tactics::{CollisionAvoidance, Tactic};
//! use sim_core::{Action, glam::DVec2};
//!
//! #[derive(Default)]
//! struct MyStrategy { coll: CollisionAvoidance }
//!
//! impl Strategy for MyStrategy {
//!     fn decide(&mut self, ctx: &mut Ctx) -> Action {
//!         if let Some(a) = self.coll.suggest(ctx) { return a; }
//!         match ctx.treasures_in_view().first() {
//!             Some(t) => ctx.move_towards(t.position),
//!             None => ctx.move_by(DVec2::new(0.0, 1.0)),
//!         }
//!     }
//! }
//! ```

pub mod builtin;

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::DVec2;
use rand_chacha::ChaCha8Rng;

use crate::known_map::KnownMap;
use crate::mapfile::HomeBase;
use crate::memory::{MemoryList, Retention};
use crate::messages::{Message, Payload, Recipient, Sighting};
use crate::model::{Action, Outcome, Robot, RobotType};
use crate::nav::NavGraph;
use crate::obstacle_map::ObstacleMap;
use crate::robot_index::RobotId;
use crate::treasure_index::TreasureId;

/// The perceptions a strategy asks for. The kernel neither computes nor stores the others.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(clippy::struct_excessive_bools)] // one switch per component of the data module
pub struct Needs {
    /// Keep a known map (marked with the view disc every round; merged from messages).
    pub known_map: bool,
    /// Read obstacles (within the known region) and plan on the navigation graph.
    pub obstacles: bool,
    /// See robots in the view radius.
    pub robots: bool,
    /// See treasures in the view radius.
    pub treasures: bool,
    /// Receive messages.
    pub messages: bool,
}

impl Needs {
    /// Everything.
    pub const ALL: Needs = Needs {
        known_map: true,
        obstacles: true,
        robots: true,
        treasures: true,
        messages: true,
    };
    /// Nothing: a blind robot (no sensing energy either).
    pub const NONE: Needs = Needs {
        known_map: false,
        obstacles: false,
        robots: false,
        treasures: false,
        messages: false,
    };

    /// Whether any sensing happens (costs `energy_per_sense`).
    pub fn senses(&self) -> bool {
        self.known_map || self.obstacles || self.robots || self.treasures
    }
}

/// A robot seen in the view radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenRobot {
    /// Its id.
    pub id: RobotId,
    /// Its position.
    pub position: DVec2,
    /// Its type (index into the run's types).
    pub type_index: usize,
}

/// A treasure seen in the view radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenTreasure {
    /// Its id.
    pub id: TreasureId,
    /// Its position.
    pub position: DVec2,
    /// Units still buried.
    pub buried: u32,
    /// Units dug and lying there.
    pub loose: u32,
}

/// One round's perceptions (buffers reused across rounds).
#[derive(Clone, Debug, Default)]
pub struct Perception {
    /// Robots in view, by id.
    pub robots: Vec<SeenRobot>,
    /// Treasures in view, by id.
    pub treasures: Vec<SeenTreasure>,
    /// Messages delivered this round, in sending order.
    pub inbox: Vec<Message>,
}

/// The data module: what a robot remembers between rounds.
#[derive(Clone, Debug)]
pub struct DataModule {
    /// The explored region, if the strategy keeps one.
    pub known: Option<KnownMap>,
    /// Treasures seen or heard of.
    pub treasures: MemoryList<TreasureId, Sighting>,
    /// Robots seen, with where and when.
    pub robots: MemoryList<RobotId, (DVec2, u64)>,
}

impl DataModule {
    /// A data module with the given retention for remembered treasures and robots.
    pub fn new(known: Option<KnownMap>, treasures: Retention, robots: Retention) -> Self {
        Self {
            known,
            treasures: MemoryList::new(treasures),
            robots: MemoryList::new(robots),
        }
    }
}

/// The unchanging world a strategy may consult.
#[derive(Clone, Copy, Debug)]
pub struct WorldView<'a> {
    /// The kernel's obstacles (read only inside the known region, through [`Ctx`]).
    pub(crate) obstacles: &'a ObstacleMap,
    /// The navigation graph.
    pub(crate) nav: &'a NavGraph,
    /// The home base.
    pub home: HomeBase,
    /// The run's robot types.
    pub types: &'a [RobotType],
}

/// Everything a strategy sees and may do in one round.
pub struct Ctx<'a> {
    /// Current round (1-based).
    pub round: u64,
    /// This robot's state at the start of the round.
    pub me: &'a Robot,
    /// This robot's type.
    pub kind: &'a RobotType,
    pub(crate) perception: &'a Perception,
    /// The data module.
    pub data: &'a mut DataModule,
    pub(crate) world: WorldView<'a>,
    /// Random numbers, seeded from (run seed, robot, round).
    pub rng: ChaCha8Rng,
    pub(crate) outbox: &'a mut Vec<(Recipient, Payload)>,
    pub(crate) goal: &'a mut Option<DVec2>,
    pub(crate) path: &'a mut Vec<DVec2>,
    pub(crate) events: &'a mut Vec<crate::observer::StrategyEvent>,
}

impl<'a> Ctx<'a> {
    /// Robots in view (empty unless the strategy needs robots).
    pub fn robots_in_view(&self) -> &'a [SeenRobot] {
        &self.perception.robots
    }
    /// Treasures in view (empty unless the strategy needs treasures).
    pub fn treasures_in_view(&self) -> &'a [SeenTreasure] {
        &self.perception.treasures
    }
    /// Messages delivered this round (empty unless the strategy needs messages).
    pub fn messages(&self) -> &'a [Message] {
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
    /// The navigation graph (plan only through nodes your known map touches).
    pub fn nav(&self) -> &'a NavGraph {
        self.world.nav
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
        self.outbox.push((Recipient::Broadcast, payload));
    }
    /// Send to one robot, if it is in range.
    pub fn send(&mut self, to: RobotId, payload: Payload) {
        self.outbox.push((Recipient::Direct(to), payload));
    }
    /// Share the known map with everyone in range.
    pub fn broadcast_known_map(&mut self) {
        if let Some(k) = &self.data.known {
            let map = Arc::new(k.clone());
            self.broadcast(Payload::KnownMap(map));
        }
    }
    /// Publish the current goal (for viewers and team mates).
    pub fn set_goal(&mut self, goal: Option<DVec2>) {
        *self.goal = goal;
    }
    /// Report an event for the run's event log (group changes, notes).
    pub fn report(&mut self, event: crate::observer::StrategyEvent) {
        self.events.push(event);
    }
    /// Publish the planned path (for viewers).
    pub fn set_path(&mut self, path: &[DVec2]) {
        self.path.clear();
        self.path.extend_from_slice(path);
    }
}

/// One robot's decision process.
pub trait Strategy: Send {
    /// The perceptions this strategy uses (default: all).
    fn needs(&self) -> Needs {
        Needs::ALL
    }
    /// How long remembered treasures and robots are kept (default: the last 64 of each).
    fn retention(&self) -> (Retention, Retention) {
        (Retention::LastN(64), Retention::LastN(64))
    }
    /// Choose this round's action (and send messages through `ctx`).
    fn decide(&mut self, ctx: &mut Ctx) -> Action;
}

/// Named parameters of a strategy, from the config.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params(pub BTreeMap<String, String>);

impl Params {
    /// Parameters from pairs.
    pub fn from_pairs<'a>(pairs: impl IntoIterator<Item = (&'a str, &'a str)>) -> Self {
        Self(pairs.into_iter().map(|(k, v)| (k.to_owned(), v.to_owned())).collect())
    }
    /// A number, or `default` when absent.
    pub fn f64_or(&self, name: &str, default: f64) -> Result<f64, String> {
        match self.0.get(name) {
            None => Ok(default),
            Some(v) => v
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("parameter '{name}' must be a number, got '{v}'")),
        }
    }
    /// A whole number, or `default` when absent.
    pub fn u64_or(&self, name: &str, default: u64) -> Result<u64, String> {
        match self.0.get(name) {
            None => Ok(default),
            Some(v) => v
                .trim()
                .parse::<u64>()
                .map_err(|_| format!("parameter '{name}' must be a whole number ≥ 0, got '{v}'")),
        }
    }
    /// Fail on parameters the strategy does not know.
    pub fn only(&self, known: &[&str]) -> Result<(), String> {
        match self.0.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => Err(format!("unknown parameter '{k}' (known: {})", known.join(", "))),
            None => Ok(()),
        }
    }
}

/// Creates a strategy from its parameters.
pub type Factory = Box<dyn Fn(&Params) -> Result<Box<dyn Strategy>, String> + Send + Sync>;

/// Strategies by name.
pub struct StrategyRegistry {
    factories: BTreeMap<String, (String, Factory)>,
}

impl Default for StrategyRegistry {
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl StrategyRegistry {
    /// A registry with nothing in it.
    pub fn empty() -> Self {
        Self {
            factories: BTreeMap::new(),
        }
    }

    /// A registry with the built-in strategies (see [`builtin`]).
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        builtin::register_all(&mut r);
        r
    }

    /// Add (or replace) a strategy under `name`, with a one-line description.
    pub fn register(
        &mut self,
        name: &str,
        description: &str,
        factory: impl Fn(&Params) -> Result<Box<dyn Strategy>, String> + Send + Sync + 'static,
    ) {
        self.factories
            .insert(name.to_owned(), (description.to_owned(), Box::new(factory)));
    }

    /// Names of the registered strategies, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.factories.keys().map(String::as_str)
    }

    /// Name and description of each strategy.
    pub fn describe(&self) -> impl Iterator<Item = (&str, &str)> {
        self.factories.iter().map(|(k, (d, _))| (k.as_str(), d.as_str()))
    }

    /// Whether a name is registered.
    pub fn contains(&self, name: &str) -> bool {
        self.factories.contains_key(name)
    }

    /// Create a strategy by name.
    pub fn create(&self, name: &str, params: &Params) -> Result<Box<dyn Strategy>, String> {
        match self.factories.get(name) {
            Some((_, f)) => f(params).map_err(|e| format!("strategy '{name}': {e}")),
            None => Err(format!(
                "unknown strategy '{name}' (known: {})",
                self.names().collect::<Vec<_>>().join(", ")
            )),
        }
    }
}
