//! The core of the learning environments (`smartteams/env.py`): a run in which the caller
//! moves some robots, and their observations and rewards in bulk, one array per quantity.
//!
//! The controlled robots keep their group's strategy object, which decides for the robots
//! of the group the caller does not move (so one robot can learn among team mates that run
//! the configured strategy). Each round, a controlled robot moves by the caller's action
//! times its speed; its observation is the patch of its own known map centred on it and a
//! state vector; its reward is the free area it was first to explore this round plus the
//! units it delivered.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError, RwLock};

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::prelude::*;
use rayon::prelude::*;
use sim_core::agent::{Ctx, Needs, Params, Strategy, StrategyRegistry};
use sim_core::glam::DVec2;
use sim_core::io::SimConfig;
use sim_core::spatial::{KnownMap, RobotId};
use sim_core::world::{Action, Retention};

use crate::simulation::Run;
use crate::{to_py, whole, whole_or_none};

/// The strategy name controlled groups get (not a name a config can use).
const CONTROLLED: &str = "smartteams.env.controlled";
/// The parameter that carries a controlled group's own strategy.
const OWN_STRATEGY: &str = "smartteams.env.strategy";
/// Length of the state vector: energy fraction, load fraction, direction home (x, y),
/// treasures in view.
pub(crate) const STATE_LEN: usize = 5;

/// The moves of the controlled robots this round, by robot id (`None`: not controlled).
type Moves = Arc<RwLock<Vec<Option<DVec2>>>>;

/// A run with robots moved by the caller.
#[pyclass(module = "smartteams")]
pub struct EnvCore {
    config: SimConfig,
    threads: Option<usize>,
    controlled: Vec<u32>,
    patch_cells: u32,
    moves: Moves,
    /// In a mutex only for `Sync`: Python may drop the object, or read it, on any thread.
    run: Mutex<Option<Run>>,
    /// Per controlled robot: explored area and units delivered at the last observation.
    credited: Vec<(f64, u64)>,
}

impl EnvCore {
    /// The episode's run, if `reset` started one (never contended: every method that
    /// changes it borrows the object mutably).
    fn lock(&self) -> MutexGuard<'_, Option<Run>> {
        self.run.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

// Arguments converted from Python arrive owned.
#[allow(clippy::needless_pass_by_value)]
#[pymethods]
impl EnvCore {
    /// `groups`: names of the groups whose robots are controlled (all groups by default);
    /// `robots`: ids of the controlled robots instead (for one robot among team mates).
    #[new]
    #[pyo3(signature = (config, *, groups=None, robots=None, patch_cells=11, threads=None))]
    fn new(
        config: std::path::PathBuf,
        groups: Option<Vec<String>>,
        robots: Option<Vec<u32>>,
        patch_cells: i128,
        threads: Option<i128>,
    ) -> PyResult<Self> {
        let threads = whole_or_none("threads", threads)?;
        let patch_cells: u32 = whole("patch_cells", patch_cells)?;
        if patch_cells == 0 || patch_cells.is_multiple_of(2) || patch_cells > 101 {
            return Err(to_py(format!(
                "patch_cells must be odd, from 1 to 101; got {patch_cells}"
            )));
        }
        let mut config = SimConfig::load(&config).map_err(to_py)?;
        let controlled = controlled_robots(&config, groups.as_deref(), robots.as_deref())?;
        // The groups with a controlled robot get the controlled strategy around their own.
        let mut first = 0u32;
        for g in &mut config.groups {
            let ids = first..first + g.count;
            first += g.count;
            if controlled.iter().any(|id| ids.contains(id)) {
                let own = std::mem::replace(&mut g.strategy, CONTROLLED.to_owned());
                g.params = g.params.clone().with(OWN_STRATEGY, own);
            }
        }
        Ok(Self {
            config,
            threads,
            controlled,
            patch_cells,
            moves: Arc::default(),
            run: Mutex::new(None),
            credited: Vec::new(),
        })
    }

    /// Treasures on the map: the most a robot can have in view.
    #[getter]
    fn treasure_count(&self) -> PyResult<usize> {
        let map = self.config.load_map().map_err(to_py)?;
        Ok(map.treasures.len())
    }

    /// The config's seed.
    #[getter]
    fn config_seed(&self) -> u64 {
        self.config.seed
    }

    /// Ids of the controlled robots, in order.
    #[getter]
    fn robot_ids(&self) -> Vec<u32> {
        self.controlled.clone()
    }

    /// Start a new episode with `seed` (and at most `rounds` rounds, or the config's);
    /// returns the observations `(patches, states)`.
    #[pyo3(signature = (seed, rounds=None))]
    fn reset<'py>(&mut self, py: Python<'py>, seed: i128, rounds: Option<i128>) -> PyResult<Observation<'py>> {
        let (seed, rounds): (u64, Option<u64>) = (whole("seed", seed)?, whole_or_none("max_rounds", rounds)?);
        let mut config = self.config.clone();
        config.seed = seed;
        if let Some(r) = rounds {
            config.rounds = r;
        }
        let registry = self.registry();
        let run = Run::new(&config, &registry, self.threads, None)?;
        let robots = run.sim.robots().len();
        if let Some(&bad) = self.controlled.iter().find(|&&id| id as usize >= robots) {
            return Err(to_py(format!("no robot {bad}: the run has {robots} robots")));
        }
        *self.moves.write().unwrap_or_else(PoisonError::into_inner) = vec![None; robots];
        self.credited = self.controlled.iter().map(|&id| credit(&run, id)).collect();
        *self.run.get_mut().unwrap_or_else(PoisonError::into_inner) = Some(run);
        self.observe(py)
    }

    /// Play one round with the controlled robots moved by `actions` (one row `(ax, ay)` per
    /// controlled robot, each in [-1, 1], times its speed, at most its speed long); returns
    /// `(patches, states, rewards, alive, done)`.
    fn step<'py>(&mut self, py: Python<'py>, actions: PyReadonlyArray2<'py, f32>) -> PyResult<Stepped<'py>> {
        let actions = actions.as_array();
        if actions.shape() != [self.controlled.len(), 2] {
            return Err(to_py(format!(
                "actions must have shape ({}, 2); got {:?}",
                self.controlled.len(),
                actions.shape()
            )));
        }
        {
            let mut moves = self.moves.write().unwrap_or_else(PoisonError::into_inner);
            for (row, &id) in actions.rows().into_iter().zip(&self.controlled) {
                let a = DVec2::new(f64::from(row[0]), f64::from(row[1]));
                moves[id as usize] = Some(if a.is_finite() {
                    a.clamp(DVec2::NEG_ONE, DVec2::ONE)
                } else {
                    DVec2::ZERO
                });
            }
        }
        let run = self.run.get_mut().unwrap_or_else(PoisonError::into_inner);
        let run = run.as_mut().ok_or_else(|| to_py("call reset() before step()"))?;
        run.play(py, 1)?;
        let (alive, done): (Vec<bool>, bool) = (
            self.controlled
                .iter()
                .map(|&id| run.sim.robots()[id as usize].alive)
                .collect(),
            run.done(),
        );
        let rewards = self.rewards();
        let (patches, states) = self.observe(py)?;
        Ok((
            patches,
            states,
            PyArray1::from_vec(py, rewards),
            PyArray1::from_vec(py, alive),
            done,
        ))
    }

    /// Rounds played in this episode.
    #[getter]
    fn round(&self) -> u64 {
        self.lock().as_ref().map_or(0, |r| r.sim.round())
    }

    /// The speed of each controlled robot, metres per round.
    #[getter]
    fn speeds(&self) -> PyResult<Vec<f64>> {
        let types = &self.config.types;
        self.controlled
            .iter()
            .map(|&id| {
                let kind = group_type_of(&self.config, id)?;
                Ok(types
                    .iter()
                    .find(|t| t.name == kind)
                    .map_or(0.0, |t| t.speed_m_per_round))
            })
            .collect()
    }

    /// The episode's events so far, as `Simulation.events()` gives them: `(round, text)`,
    /// a disabled robot's whole reason included.
    fn events(&self) -> Vec<(u64, String)> {
        self.lock().as_ref().map_or_else(Vec::new, |r| r.events.clone())
    }

    /// The run's metrics so far, as `Simulation.metrics()` gives them.
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let run = self.lock();
        let run = run.as_ref().ok_or_else(|| to_py("call reset() first"))?;
        crate::simulation::metrics_dict(py, run.metrics())
    }
}

/// What `reset` returns: patches `(n, k, k)` and states `(n, STATE_LEN)`.
type Observation<'py> = (Bound<'py, PyArray3<u8>>, Bound<'py, PyArray2<f32>>);
/// What `step` returns: observation, rewards, alive, whether the run's rounds are over.
type Stepped<'py> = (
    Bound<'py, PyArray3<u8>>,
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
    bool,
);

impl EnvCore {
    /// The built-in and Python strategies, and the controlled one wrapping each group's own.
    fn registry(&self) -> StrategyRegistry {
        let own = Arc::new(crate::strategy::registry());
        let mut registry = crate::strategy::registry();
        let moves = Arc::clone(&self.moves);
        registry.register(CONTROLLED, "moved by a learning environment", move |params| {
            let name = params.text(OWN_STRATEGY).unwrap_or("random_walk").to_owned();
            let rest = Params::from_pairs(params.iter().filter(|(k, _)| *k != OWN_STRATEGY));
            Ok(Box::new(Controlled {
                own: own.create(&name, &rest)?,
                moves: Arc::clone(&moves),
            }))
        });
        registry
    }

    /// Each controlled robot's reward since the last call: area first explored plus units
    /// delivered.
    fn rewards(&mut self) -> Vec<f64> {
        let Some(run) = self.run.get_mut().unwrap_or_else(PoisonError::into_inner).as_ref() else {
            return Vec::new();
        };
        self.controlled
            .iter()
            .zip(&mut self.credited)
            .map(|(&id, before)| {
                let now = credit(run, id);
                let reward = (now.0 - before.0) + (now.1 - before.1) as f64;
                *before = now;
                reward
            })
            .collect()
    }

    /// Patches and states of the controlled robots, worked out in parallel.
    fn observe<'py>(&self, py: Python<'py>) -> PyResult<Observation<'py>> {
        let run = self.lock();
        let run = run.as_ref().ok_or_else(|| to_py("call reset() first"))?;
        let (k, n) = (self.patch_cells as usize, self.controlled.len());
        let mut patches = vec![0u8; n * k * k];
        let mut states = vec![0f32; n * STATE_LEN];
        let world = World::of(&run.sim);
        let known: Vec<_> = self
            .controlled
            .iter()
            .map(|&id| run.sim.known_map(RobotId::new(id)))
            .collect();
        let (cells, pool, controlled) = (self.patch_cells, run.pool(), &self.controlled);
        py.detach(|| {
            pool.install(|| {
                patches
                    .par_chunks_mut(k * k)
                    .zip(states.par_chunks_mut(STATE_LEN))
                    .zip(controlled.par_iter().zip(&known))
                    .for_each(|((patch, state), (&id, known))| world.observe(id, *known, cells, patch, state));
            });
        });
        let patches = Array3::from_shape_vec((n, k, k), patches).map_err(to_py)?;
        let states = Array2::from_shape_vec((n, STATE_LEN), states).map_err(to_py)?;
        Ok((patches.into_pyarray(py), states.into_pyarray(py)))
    }
}

/// What observations are made of: the parts of a simulation that threads may share.
struct World<'a> {
    obstacles: &'a sim_core::spatial::ObstacleMap,
    robots: &'a [sim_core::world::Robot],
    types: &'a [sim_core::world::RobotType],
    treasures: &'a [sim_core::world::TreasureState],
    home: DVec2,
}

impl<'a> World<'a> {
    fn of(sim: &'a sim_core::engine::Simulation) -> Self {
        Self {
            obstacles: sim.obstacles(),
            robots: sim.robots(),
            types: sim.types(),
            treasures: sim.treasures(),
            home: sim.map().home.center(),
        }
    }

    /// Robot `id`'s observation into `patch` (cells × cells) and `state`.
    fn observe(&self, id: u32, known: Option<&KnownMap>, cells: u32, patch: &mut [u8], state: &mut [f32]) {
        let robot = &self.robots[id as usize];
        let kind = &self.types[robot.type_index];
        let mut cells_out = Vec::with_capacity(patch.len());
        match known {
            Some(known) => crate::grids::patch(known, self.obstacles, robot.position, cells, &mut cells_out),
            None => cells_out.resize(patch.len(), crate::grids::UNKNOWN),
        }
        patch.copy_from_slice(&cells_out);
        let home = self.home - robot.position;
        let home = if home.length() > 0.0 {
            home / home.length()
        } else {
            DVec2::ZERO
        };
        let load = if kind.carry_capacity > 0 {
            f64::from(robot.load()) / f64::from(kind.carry_capacity)
        } else {
            0.0
        };
        let view2 = kind.view_radius_m * kind.view_radius_m;
        let in_view = self
            .treasures
            .iter()
            .filter(|t| t.buried + t.loose > 0 && t.position.distance_squared(robot.position) <= view2)
            .count();
        let values = [
            (robot.energy / kind.energy_capacity).clamp(0.0, 1.0),
            load.clamp(0.0, 1.0),
            home.x,
            home.y,
            in_view as f64,
        ];
        for (s, v) in state.iter_mut().zip(values) {
            *s = v as f32;
        }
    }
}

/// Free area robot `id` was first to explore, and units it delivered, so far.
fn credit(run: &Run, id: u32) -> (f64, u64) {
    let s = &run.sim.robots()[id as usize].stats;
    (s.explored_m2, s.units_delivered)
}

/// The ids of the robots of `groups` (all by default), or `robots` when given.
fn controlled_robots(config: &SimConfig, groups: Option<&[String]>, robots: Option<&[u32]>) -> PyResult<Vec<u32>> {
    if let Some(ids) = robots {
        return Ok(ids.to_vec());
    }
    if let Some(names) = groups
        && let Some(unknown) = names.iter().find(|n| !config.groups.iter().any(|g| &g.name == *n))
    {
        let known: Vec<&str> = config.groups.iter().map(|g| g.name.as_str()).collect();
        return Err(to_py(format!(
            "{}: no group '{unknown}' (groups: {})",
            config.path.display(),
            known.join(", ")
        )));
    }
    let mut ids = Vec::new();
    let mut next = 0u32;
    for g in &config.groups {
        if groups.is_none_or(|names| names.contains(&g.name)) {
            ids.extend(next..next + g.count);
        }
        next += g.count;
    }
    Ok(ids)
}

/// The type name of robot `id`'s group (robots are numbered group by group).
fn group_type_of(config: &SimConfig, id: u32) -> PyResult<String> {
    let mut next = 0u32;
    for g in &config.groups {
        if id < next + g.count {
            return Ok(g.type_name.clone());
        }
        next += g.count;
    }
    Err(to_py(format!("no robot {id} in {}", config.path.display())))
}

/// A group's strategy with some of its robots moved by the caller instead.
struct Controlled {
    own: Box<dyn Strategy>,
    moves: Moves,
}

impl Strategy for Controlled {
    fn needs(&self) -> Needs {
        // A controlled robot's observation is its own known map.
        self.own.needs().union(Needs {
            known_map: true,
            ..Needs::NONE
        })
    }

    fn retention(&self) -> (Retention, Retention) {
        self.own.retention()
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let moved = self.moves.read().unwrap_or_else(PoisonError::into_inner)[ctx.me.id.index()];
        match moved {
            Some(a) => ctx.move_by(a * ctx.kind.speed_m_per_round),
            None => self.own.decide(ctx),
        }
    }

    fn save_state(&self) -> Option<Vec<u8>> {
        self.own.save_state()
    }

    fn restore_state(&mut self, state: &[u8]) -> sim_core::Result<()> {
        self.own.restore_state(state)
    }
}
