//! A simulation run: its world, robots and agents, set up from a [`Scenario`]. The round
//! loop itself is in [`round`](crate::round).

use std::sync::Arc;

use glam::DVec2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::known_map::KnownMap;
use crate::mapfile::MapData;
use crate::messages::{Message, Payload, Recipient};
use crate::metrics::RoundMetrics;
use crate::model::{Action, Outcome, Robot, RobotStats, RobotType, TreasureState};
use crate::nav::NavGraph;
use crate::observer::{Observer, ObserverError, RoundReport};
use crate::robot_index::{RobotId, RobotIndex};
use crate::strategy::{DataModule, Needs, Params, Perception, Strategy, StrategyRegistry};
use crate::treasure_index::{TreasureId, TreasureIndex};
use crate::{Error, ObstacleMap, Result};

/// Where a group starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start {
    /// Around the home base centre.
    Home,
    /// Around a point.
    At(DVec2),
}

/// A group of robots with one type and one strategy.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// Name (for outputs).
    pub name: String,
    /// Number of robots.
    pub count: u32,
    /// Index into the scenario's types.
    pub type_index: usize,
    /// Strategy name in the registry.
    pub strategy: String,
    /// Strategy parameters.
    pub params: Params,
    /// Start position.
    pub start: Start,
}

/// Everything needed to start a run, validated.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Run name (outputs are named after it).
    pub name: String,
    /// The map.
    pub map: Arc<MapData>,
    /// Run seed.
    pub seed: u64,
    /// Rounds to run.
    pub rounds: u64,
    /// Robot types.
    pub types: Vec<RobotType>,
    /// Robot groups, in id order.
    pub groups: Vec<Group>,
}

/// A robot's brain: its strategy and data, owned by the robot alone.
pub(crate) struct Agent {
    pub(crate) strategy: Box<dyn Strategy>,
    pub(crate) needs: Needs,
    pub(crate) data: DataModule,
    pub(crate) perception: Perception,
    pub(crate) action: Action,
    pub(crate) outbox: Vec<(Recipient, Payload)>,
    pub(crate) goal: Option<DVec2>,
    pub(crate) path: Vec<DVec2>,
    pub(crate) known_changed: bool,
    pub(crate) events: Vec<crate::observer::StrategyEvent>,
    /// Known cells of the last map merged from each sender: a map that has not grown since
    /// is already contained in ours (maps only grow), so merging it again is skipped.
    pub(crate) merged_from: std::collections::HashMap<RobotId, u64>,
}

/// A running simulation.
pub struct Simulation {
    pub(crate) name: String,
    pub(crate) seed: u64,
    pub(crate) rounds: u64,
    pub(crate) round: u64,
    pub(crate) map: Arc<MapData>,
    pub(crate) nav: NavGraph,
    /// Shared so the resolve loop can hold a type while it mutates the simulation.
    pub(crate) types: Arc<[RobotType]>,
    pub(crate) groups: Vec<Group>,
    pub(crate) robots: Vec<Robot>,
    pub(crate) agents: Vec<Agent>,
    pub(crate) treasures: Vec<TreasureState>,
    pub(crate) treasure_index: TreasureIndex,
    pub(crate) robot_index: RobotIndex,
    /// Messages to deliver at the start of the next round, per robot.
    pub(crate) inboxes: Vec<Vec<Message>>,
    /// The union of everything every robot has seen.
    pub(crate) explored: KnownMap,
    pub(crate) explored_free_cells: u64,
    pub(crate) total_free_cells: u64,
    pub(crate) report: RoundReport,
    pub(crate) max_radius_m: f64,
    pub(crate) max_speed_m: f64,
    /// Positions at the start of the current round (send-time positions for messages).
    pub(crate) start_positions: Vec<DVec2>,
}

/// Spacing of the start lattice for robots of radius `r`.
fn lattice_spacing(r: f64) -> f64 {
    2.0 * r + 0.05
}

impl Simulation {
    /// Set up a run: create the strategies, place the robots, build the navigation graph.
    #[allow(clippy::too_many_lines)] // set-up reads best in one piece: world, robots, indexes
    pub fn new(scenario: Scenario, registry: &StrategyRegistry) -> Result<Self> {
        let Scenario {
            name,
            map,
            seed,
            rounds,
            types,
            groups,
        } = scenario;
        for t in &types {
            t.validate().map_err(Error::InvalidParameter)?;
        }
        let obstacles = &map.obstacles;
        let grid = *obstacles.grid();
        let nav = NavGraph::build(obstacles);
        let mut treasure_index = TreasureIndex::new(grid.extent())?;
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
        let max_radius_m = types.iter().map(|t| t.radius_m).fold(0.0, f64::max);
        let max_speed_m = types.iter().map(|t| t.speed_m_per_round).fold(0.0, f64::max);
        let mut placer = Placer::new(obstacles, lattice_spacing(max_radius_m));
        let mut robots = Vec::new();
        let mut agents = Vec::new();
        for (gi, g) in groups.iter().enumerate() {
            let kind = types.get(g.type_index).ok_or_else(|| {
                Error::InvalidParameter(format!("group '{}' refers to robot type #{}", g.name, g.type_index))
            })?;
            let at = match g.start {
                Start::Home => map.home.center(),
                Start::At(p) => {
                    if !obstacles.is_disc_free(p, kind.radius_m) {
                        return Err(Error::InvalidParameter(format!(
                            "group '{}' starts at ({}, {}), inside an obstacle or outside the map",
                            g.name, p.x, p.y
                        )));
                    }
                    p
                }
            };
            for _ in 0..g.count {
                let id = RobotId(
                    u32::try_from(robots.len()).map_err(|_| Error::InvalidParameter("too many robots".into()))?,
                );
                let strategy = registry
                    .create(&g.strategy, &g.params)
                    .map_err(|e| Error::InvalidParameter(format!("group '{}': {e}", g.name)))?;
                let position = placer.next_near(at, kind.radius_m).ok_or_else(|| {
                    Error::InvalidParameter(format!(
                        "group '{}': no free room for robot {} near ({}, {})",
                        g.name, id.0, at.x, at.y
                    ))
                })?;
                let needs = strategy.needs();
                let (tr, rr) = strategy.retention();
                robots.push(Robot {
                    id,
                    type_index: g.type_index,
                    group: gi,
                    position,
                    energy: kind.energy_capacity,
                    cargo: Vec::new(),
                    alive: true,
                    last_action: (Action::Idle, Outcome::Done),
                    goal: None,
                    path: Vec::new(),
                    stats: RobotStats::default(),
                });
                agents.push(Agent {
                    strategy,
                    needs,
                    data: DataModule::new(needs.known_map.then(|| KnownMap::new(grid)), tr, rr),
                    perception: Perception::default(),
                    action: Action::Idle,
                    outbox: Vec::new(),
                    goal: None,
                    path: Vec::new(),
                    known_changed: false,
                    events: Vec::new(),
                    merged_from: std::collections::HashMap::new(),
                });
            }
        }
        let mut robot_index = RobotIndex::new();
        robot_index.rebuild(robots.iter().map(|r| (r.id, r.position)), index_cell_m(&types));
        let total_free_cells = obstacles.tree().count_cells(false);
        let n = robots.len();
        let mut sim = Self {
            name,
            seed,
            rounds,
            round: 0,
            nav,
            types: types.into(),
            groups,
            robots,
            agents,
            treasures,
            treasure_index,
            robot_index,
            inboxes: vec![Vec::new(); n],
            explored: KnownMap::new(grid),
            explored_free_cells: 0,
            total_free_cells,
            report: RoundReport::default(),
            max_radius_m,
            max_speed_m,
            start_positions: Vec::new(),
            map,
        };
        sim.report.metrics = sim.metrics(0, 0, 0);
        Ok(sim)
    }

    /// Run every remaining round, notifying the observers; stops at the first observer error.
    pub fn run(&mut self, observers: &mut [&mut dyn Observer]) -> Result<(), ObserverError> {
        for o in observers.iter_mut() {
            o.on_start(self)?;
        }
        while self.round < self.rounds {
            self.step();
            for o in observers.iter_mut() {
                o.on_round(self, &self.report)?;
            }
        }
        for o in observers.iter_mut() {
            o.on_finish(self)?;
        }
        Ok(())
    }

    /// Run name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Run seed.
    pub fn seed(&self) -> u64 {
        self.seed
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
    /// The obstacles.
    pub fn obstacles(&self) -> &ObstacleMap {
        &self.map.obstacles
    }
    /// The navigation graph.
    pub fn nav(&self) -> &NavGraph {
        &self.nav
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
    /// Treasures, by id.
    pub fn treasures(&self) -> &[TreasureState] {
        &self.treasures
    }
    /// A treasure.
    pub fn treasure(&self, id: TreasureId) -> Option<&TreasureState> {
        self.treasures.get(id.0 as usize)
    }
    /// A robot's known map, if its strategy keeps one.
    pub fn known_map(&self, id: RobotId) -> Option<&KnownMap> {
        self.agents.get(id.index())?.data.known.as_ref()
    }
    /// A robot's strategy needs.
    pub fn needs(&self, id: RobotId) -> Option<Needs> {
        self.agents.get(id.index()).map(|a| a.needs)
    }
    /// The union of all robots' views so far.
    pub fn explored(&self) -> &KnownMap {
        &self.explored
    }
    /// The last round's report.
    pub fn report(&self) -> &RoundReport {
        &self.report
    }
    /// Messages waiting for delivery at the start of the next round, per robot.
    pub fn pending_messages(&self) -> &[Vec<Message>] {
        &self.inboxes
    }

    /// Total memory held by the robots' data modules (known maps and memories), bytes.
    pub fn robot_memory_bytes(&self) -> usize {
        self.agents
            .iter()
            .map(|a| a.data.known.as_ref().map_or(0, KnownMap::memory_bytes))
            .sum()
    }

    /// Metrics for the current state.
    pub(crate) fn metrics(&self, round: u64, messages: u64, message_bytes: u64) -> RoundMetrics {
        let alive: Vec<&Robot> = self.robots.iter().filter(|r| r.alive).collect();
        let mean_energy = if alive.is_empty() {
            0.0
        } else {
            alive.iter().map(|r| r.energy).sum::<f64>() / alive.len() as f64
        };
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
            robots_alive: alive.len() as u32,
            mean_energy,
            messages,
            distance_m: self.robots.iter().map(|r| r.stats.distance_m).sum(),
            units_dug: self.robots.iter().map(|r| r.stats.units_dug).sum(),
            units_delivered: self.robots.iter().map(|r| r.stats.units_delivered).sum(),
            message_bytes,
        }
    }

    /// The random generator of a robot in a round: a function of (seed, robot, round) only.
    pub(crate) fn rng_for(seed: u64, robot: RobotId, round: u64) -> ChaCha8Rng {
        let mut x = seed ^ 0x9E37_79B9_7F4A_7C15;
        for v in [u64::from(robot.0), round] {
            // splitmix64 steps
            x = x.wrapping_add(v).wrapping_add(0x9E37_79B9_7F4A_7C15);
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^= x >> 31;
        }
        ChaCha8Rng::seed_from_u64(x)
    }
}

/// Cell size for the robot index: the typical query radius.
pub(crate) fn index_cell_m(types: &[RobotType]) -> f64 {
    types
        .iter()
        .map(|t| t.view_radius_m.max(t.comm_radius_m))
        .fold(1.0, f64::max)
        .min(64.0)
}

/// Hands out start positions on a global lattice (so robots never overlap), nearest first.
struct Placer<'a> {
    obstacles: &'a ObstacleMap,
    spacing: f64,
    used: std::collections::HashSet<(i64, i64)>,
    /// First ring around each centre that may still have room.
    progress: std::collections::HashMap<(i64, i64), i64>,
}

impl<'a> Placer<'a> {
    fn new(obstacles: &'a ObstacleMap, spacing: f64) -> Self {
        Self {
            obstacles,
            spacing,
            used: std::collections::HashSet::new(),
            progress: std::collections::HashMap::new(),
        }
    }

    fn next_near(&mut self, at: DVec2, radius: f64) -> Option<DVec2> {
        let s = self.spacing;
        let c = ((at.x / s).round() as i64, (at.y / s).round() as i64);
        let e = self.obstacles.grid().extent();
        // Crowds larger than a few hundred metres across are a config mistake, not a plan.
        let max_ring = (((e.max - e.min).max_element() / s).ceil() as i64 + 2).min(2000);
        let first = self.progress.get(&c).copied().unwrap_or(0);
        for ring in first..=max_ring {
            self.progress.insert(c, ring);
            let mut cells: Vec<(i64, i64)> = Vec::new();
            for dx in -ring..=ring {
                for dy in -ring..=ring {
                    if dx.abs().max(dy.abs()) == ring {
                        cells.push((c.0 + dx, c.1 + dy));
                    }
                }
            }
            let pos = |q: (i64, i64)| DVec2::new(q.0 as f64 * s, q.1 as f64 * s);
            cells.sort_by(|a, b| {
                pos(*a)
                    .distance_squared(at)
                    .total_cmp(&pos(*b).distance_squared(at))
                    .then(a.cmp(b))
            });
            for q in cells {
                if !self.used.contains(&q) && self.obstacles.is_disc_free(pos(q), radius) {
                    self.used.insert(q);
                    return Some(pos(q));
                }
            }
        }
        None
    }
}
