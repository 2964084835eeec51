//! `smartteams.Simulation`: a run of an XML config driven from Python, round by round.

use std::path::PathBuf;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::agent::StrategyRegistry;
use sim_core::io::{Checkpoint, Observer, RunOutputs, RunSource, SimConfig, write_checkpoint};
use sim_core::spatial::RobotId;
use sim_core::world::{METRICS_COLUMNS, RoundMetrics};
use viewer_bridge::rerun_observer::{LogOptions, RerunObserver};
use viewer_bridge::viewer::ViewerTarget;

use crate::grids::{self, Window};
use crate::{to_py, whole_or_none};

/// Rounds between checkpoints that a checkpoint written from Python records, for a
/// `smartteams resume` of it (the command line's default).
const CHECKPOINT_EVERY: u64 = 100;

/// A simulation and what drives it: its worker pool, the metrics of the rounds played,
/// and the recording, if any. Shared by [`Simulation`] and the learning environments.
pub(crate) struct Run {
    pub sim: sim_core::engine::Simulation,
    pool: rayon::ThreadPool,
    source: RunSource,
    metrics: Vec<RoundMetrics>,
    /// Every event of the rounds played here: (round, what happened).
    pub events: Vec<(u64, String)>,
    recording: Option<RerunObserver>,
    /// Slow decisions warned of so far (see [`warn_of_slow_decisions`]).
    slow_warned: u64,
}

impl Run {
    /// A run of `config` with the strategies of `registry` on `threads` workers (`None`:
    /// one per core), recorded to `rrd` if given.
    pub fn new(
        config: &SimConfig,
        registry: &StrategyRegistry,
        threads: Option<usize>,
        rrd: Option<PathBuf>,
    ) -> PyResult<Self> {
        let source = RunSource::of(config).map_err(to_py)?;
        let scenario = config.scenario(registry).map_err(to_py)?;
        let sim = sim_core::engine::Simulation::new(scenario).map_err(to_py)?;
        Self::around(sim, source, Vec::new(), threads, rrd)
    }

    /// A run of `sim`, set up from `source`, after the rounds of `metrics`.
    fn around(
        sim: sim_core::engine::Simulation,
        source: RunSource,
        metrics: Vec<RoundMetrics>,
        threads: Option<usize>,
        rrd: Option<PathBuf>,
    ) -> PyResult<Self> {
        sim_core::engine::check_threads(threads).map_err(|e| to_py(format!("threads {e}")))?;
        let mut source = source;
        // What its checkpoints say it writes: no CSV and none of the config's outputs, and
        // no recording until `record_to`.
        source.outputs = RunOutputs {
            recording: Some(viewer_bridge::cli::recording_words(None)),
            ..RunOutputs::default()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.unwrap_or(0))
            .build()
            .map_err(|e| to_py(format!("cannot start worker threads: {e}")))?;
        let mut run = Self {
            sim,
            pool,
            source,
            metrics,
            events: Vec::new(),
            recording: None,
            slow_warned: 0,
        };
        if let Some(path) = rrd {
            run.record_to(path)?;
        }
        Ok(run)
    }

    /// Record the rest of the run to the `.rrd` file `path`.
    fn record_to(&mut self, path: PathBuf) -> PyResult<()> {
        let config = self.source.config().map_err(to_py)?;
        viewer_bridge::run::refuse_overwriting(
            &[("recording", &path)],
            &[("config", &config.path), ("map", config.map_path())],
        )
        .map_err(|e| to_py(format!("{e:#}")))?;
        let target = ViewerTarget::Rrd(path);
        let mut observer = viewer_bridge::run::open_recording(&self.sim, &target, LogOptions::default())
            .map_err(|e| to_py(format!("{e:#}")))?;
        observer.on_start(&self.sim).map_err(to_py)?;
        self.recording = Some(observer);
        self.source.outputs.recording = Some(viewer_bridge::cli::recording_words(Some(&target)));
        self.source.outputs.logging = Some(viewer_bridge::cli::logging_words(&LogOptions::default()));
        Ok(())
    }

    /// The worker pool the rounds run on.
    pub fn pool(&self) -> &rayon::ThreadPool {
        &self.pool
    }

    /// The metrics of every round played.
    pub fn metrics(&self) -> &[RoundMetrics] {
        &self.metrics
    }

    /// Whether every round has been played.
    pub fn done(&self) -> bool {
        self.sim.round() >= self.sim.total_rounds()
    }

    /// Play up to `n` rounds (fewer at the end), without the GIL while a round runs (Python
    /// strategies take it back as they decide). Ctrl-C stops between rounds.
    pub fn play(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        for _ in 0..n {
            if self.done() {
                break;
            }
            let (sim, pool) = (&mut self.sim, &self.pool);
            py.detach(|| {
                pool.install(|| {
                    sim.step();
                });
            });
            let report = self.sim.report();
            self.metrics.push(report.metrics);
            self.events
                .extend(report.events.iter().map(|e| (report.round, e.to_string())));
            warn_of_failed_strategies(py, report)?;
            self.slow_warned = warn_of_slow_decisions(py, report, self.slow_warned)?;
            if let Some(r) = &mut self.recording {
                r.on_round(&self.sim, self.sim.report()).map_err(to_py)?;
            }
            if self.done() {
                self.finish_recording()?;
            }
            py.check_signals()?;
        }
        Ok(())
    }

    /// Close the recording (it then holds every round played), if there is one.
    pub fn finish_recording(&mut self) -> PyResult<()> {
        match self.recording.take() {
            Some(mut r) => r.on_finish(&self.sim).map_err(to_py),
            None => Ok(()),
        }
    }
}

/// Slow decisions a run warns of, at most (the command line reports as many on stderr).
const SLOW_WARNINGS: u64 = 5;

/// A `RuntimeWarning` for each decision of the round of `report` slower than the limit
/// (100 ms), the first [`SLOW_WARNINGS`] of the run (`warned` so far; returns the new
/// count), the last saying that no more will be.
fn warn_of_slow_decisions(py: Python<'_>, report: &sim_core::world::RoundReport, warned: u64) -> PyResult<u64> {
    let mut warned = warned;
    for &(robot, took) in &report.slow_decisions {
        if warned >= SLOW_WARNINGS {
            break;
        }
        warned += 1;
        let more = if warned == SLOW_WARNINGS {
            "; no more slow decisions are warned of"
        } else {
            ""
        };
        let limit = sim_core::engine::DEFAULT_DECIDE_LIMIT.as_millis();
        let text = format!(
            "round {}: robot {robot} took {} ms to decide, more than {limit} ms{more}",
            report.round,
            took.as_millis()
        );
        let text = std::ffi::CString::new(text).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<pyo3::exceptions::PyRuntimeWarning>(), &text, 1)?;
    }
    Ok(warned)
}

/// A `RuntimeWarning` for each robot a failing strategy disabled in the round of `report`:
/// the event log keeps the reason, but a script that does not read it would not know why
/// its robots stopped. Python's warning filters show each text once by default, or turn
/// them into errors (`-W error`).
fn warn_of_failed_strategies(py: Python<'_>, report: &sim_core::world::RoundReport) -> PyResult<()> {
    for e in &report.events {
        if let sim_core::world::Event::StrategyFailed { robot, reason } = e {
            let first_line = reason.lines().next().unwrap_or_default();
            let text = format!(
                "round {}: robot {robot} is disabled: {first_line} (events() has the whole reason)",
                report.round
            );
            let text = std::ffi::CString::new(text.replace('\0', " ")).unwrap_or_default();
            PyErr::warn(py, &py.get_type::<pyo3::exceptions::PyRuntimeWarning>(), &text, 1)?;
        }
    }
    Ok(())
}

impl Drop for Run {
    fn drop(&mut self) {
        if let Some(mut r) = self.recording.take() {
            r.on_finish(&self.sim).ok();
        }
    }
}

/// A simulation of an XML config, driven round by round.
///
/// `Simulation(config, *, seed=None, rounds=None, threads=None, rrd=None)`: `config` is the
/// path of an XML config; `seed` and `rounds` override the config's (as `--seed` and
/// `--rounds` do); `threads` is the number of worker threads (one per core by default);
/// `rrd` a recording to write, as the command line's `--rrd`. Strategies registered with
/// `smartteams.register_strategy` can be named in the config.
#[pyclass(module = "smartteams")]
pub struct Simulation {
    /// In a mutex only for `Sync`: Python may drop the object, or read it, on any thread
    /// (its garbage collector runs where objects are allocated, a strategy's worker too).
    run: std::sync::Mutex<Run>,
}

impl Simulation {
    /// The run (never contended: every method that changes it borrows the object
    /// mutably).
    fn lock(&self) -> std::sync::MutexGuard<'_, Run> {
        self.run.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

// Arguments converted from Python arrive owned.
#[allow(clippy::needless_pass_by_value)]
#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (config, *, seed=None, rounds=None, threads=None, rrd=None))]
    fn new(
        config: PathBuf,
        seed: Option<i128>,
        rounds: Option<i128>,
        threads: Option<i128>,
        rrd: Option<PathBuf>,
    ) -> PyResult<Self> {
        let (seed, rounds): (Option<u64>, Option<u64>) =
            (whole_or_none("seed", seed)?, whole_or_none("rounds", rounds)?);
        let threads = whole_or_none("threads", threads)?;
        let mut config = SimConfig::load(&config).map_err(to_py)?;
        if let Some(s) = seed {
            config.seed = s;
        }
        if let Some(r) = rounds {
            config.rounds = r;
        }
        let registry = crate::strategy::registry();
        Ok(Self {
            run: std::sync::Mutex::new(Run::new(&config, &registry, threads, rrd)?),
        })
    }

    /// Continue the run a checkpoint holds (`smartteams run --checkpoint` or
    /// [`checkpoint`](Self::checkpoint)), to the end it would have had.
    #[staticmethod]
    #[pyo3(signature = (path, *, threads=None, rrd=None))]
    fn resume(path: PathBuf, threads: Option<i128>, rrd: Option<PathBuf>) -> PyResult<Self> {
        let threads = whole_or_none("threads", threads)?;
        let checkpoint = Checkpoint::read(&path).map_err(to_py)?;
        let config = checkpoint.source().config().map_err(to_py)?;
        let registry = crate::strategy::registry();
        let sim = checkpoint.resume(&config, &registry).map_err(to_py)?;
        let source = checkpoint.source().clone();
        Ok(Self {
            run: std::sync::Mutex::new(Run::around(sim, source, checkpoint.metrics().to_vec(), threads, rrd)?),
        })
    }

    /// Play up to `n` rounds; returns the current round.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: i64) -> PyResult<u64> {
        let n = u64::try_from(n).map_err(|_| to_py(format!("step(n): n is the rounds to play, ≥ 0; got {n}")))?;
        let mut run = self.lock();
        run.play(py, n)?;
        Ok(run.sim.round())
    }

    /// Play every remaining round; returns the last round.
    fn run(&mut self, py: Python<'_>) -> PyResult<u64> {
        let mut run = self.lock();
        let left = run.sim.total_rounds().saturating_sub(run.sim.round());
        run.play(py, left)?;
        Ok(run.sim.round())
    }

    /// Rounds played so far.
    #[getter]
    fn round(&self) -> u64 {
        self.lock().sim.round()
    }

    /// Whether every round has been played.
    #[getter]
    fn done(&self) -> bool {
        self.lock().done()
    }

    /// Rounds the run plays in all.
    #[getter]
    fn total_rounds(&self) -> u64 {
        self.lock().sim.total_rounds()
    }

    /// The run's name.
    #[getter]
    fn name(&self) -> String {
        self.lock().sim.name().to_owned()
    }

    /// The run's seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.lock().sim.seed()
    }

    /// A digest of every robot's position: equal digests, identical positions (the
    /// `digest` line of `smartteams run`).
    #[getter]
    fn digest(&self) -> String {
        format!("{:016x}", self.lock().sim.positions_digest())
    }

    /// The robot types' names, indexed by the `type` column of [`robots`](Self::robots).
    #[getter]
    fn type_names(&self) -> Vec<String> {
        self.lock().sim.types().iter().map(|t| t.name.clone()).collect()
    }

    /// The groups' names, indexed by the `group` column of [`robots`](Self::robots).
    #[getter]
    fn group_names(&self) -> Vec<String> {
        self.lock().sim.groups().iter().map(|g| g.name.clone()).collect()
    }

    /// The metrics of every round played: a dict of 1-D arrays, one element per round,
    /// with the columns and values of the metrics CSV of `smartteams run --metrics`.
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        metrics_dict(py, &self.lock().metrics)
    }

    /// The robots now: a dict of 1-D arrays, one element per robot in id order: `id`,
    /// `group`, `type`, `x`, `y`, `energy`, `load`, `alive`, `known_area_m2`,
    /// `distance_m`, `explored_m2`, `overlap_m`, `units_dug`, `units_delivered`.
    fn robots<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        robots_dict(py, &self.lock().sim)
    }

    /// The treasures now: a dict of 1-D arrays, one element per treasure in id order: `id`,
    /// `x`, `y`, `quantity` (units at the start), `buried`, `loose`, `delivered`, `found`.
    fn treasures<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        treasures_dict(py, &self.lock().sim)
    }

    /// Every event of the rounds played (robots disabled, treasures found, groups formed,
    /// notes): a list of `(round, text)`, as the event log of a recording shows them.
    fn events(&self) -> Vec<(u64, String)> {
        self.lock().events.clone()
    }

    /// What robot `robot_id` knows of the window `x0, y0, width_m, height_m` (metres; the
    /// whole map by default): a 2-D `uint8` array, 0 unknown, 1 free, 2 blocked; row 0 is the
    /// window's southern row.
    #[pyo3(signature = (robot_id, x0=None, y0=None, width_m=None, height_m=None))]
    fn known_map<'py>(
        &self,
        py: Python<'py>,
        robot_id: i64,
        x0: Option<f64>,
        y0: Option<f64>,
        width_m: Option<f64>,
        height_m: Option<f64>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<u8>>> {
        let run = self.lock();
        let sim = &run.sim;
        let known = robot_known_map(sim, robot_id)?;
        let w = Window::of(sim.obstacles().grid(), x0, y0, width_m, height_m)?;
        let mut cells = Vec::new();
        grids::known_cells(known, sim.obstacles(), w, &mut cells);
        grid_array(py, w, cells)
    }

    /// The obstacles of the window `x0, y0, width_m, height_m` (metres; the whole map by
    /// default): a 2-D `uint8` array, 0 free, 1 blocked; row 0 is the window's southern row.
    #[pyo3(signature = (x0=None, y0=None, width_m=None, height_m=None))]
    fn obstacles<'py>(
        &self,
        py: Python<'py>,
        x0: Option<f64>,
        y0: Option<f64>,
        width_m: Option<f64>,
        height_m: Option<f64>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<u8>>> {
        let run = self.lock();
        let obstacles = run.sim.obstacles();
        let w = Window::of(obstacles.grid(), x0, y0, width_m, height_m)?;
        let mut cells = Vec::new();
        grids::obstacle_cells(obstacles, w, &mut cells);
        grid_array(py, w, cells)
    }

    /// The map's cell size and extent: `(cell_m, x0, y0, width_m, height_m)`.
    #[getter]
    fn map_extent(&self) -> (f64, f64, f64, f64, f64) {
        let run = self.lock();
        let grid = run.sim.obstacles().grid();
        let ext = grid.extent();
        (
            grid.cell_m(),
            ext.min.x,
            ext.min.y,
            ext.max.x - ext.min.x,
            ext.max.y - ext.min.y,
        )
    }

    /// Write the whole run as it stands to the checkpoint file `path`, as `smartteams run
    /// --checkpoint` does; [`resume`](Self::resume) or `smartteams resume` continue it.
    fn checkpoint(&self, path: PathBuf) -> PyResult<()> {
        crate::strategy::PICKLE_FAILURE.take();
        let run = self.lock();
        write_checkpoint(&path, &run.source, CHECKPOINT_EVERY, &run.metrics, &run.sim)
            .map_err(crate::strategy::with_pickle_failure)
    }

    /// Close the recording now (it is closed at the end of the run, or when the simulation
    /// is dropped, anyway).
    fn close(&mut self) -> PyResult<()> {
        self.lock().finish_recording()
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.lock().finish_recording()?;
        Ok(false)
    }

    fn __repr__(&self) -> String {
        let run = self.lock();
        let sim = &run.sim;
        format!(
            "<smartteams.Simulation '{}': {} robots, round {} of {}>",
            sim.name(),
            sim.robots().len(),
            sim.round(),
            sim.total_rounds()
        )
    }
}

/// The known map of robot `id`, or an error naming why there is none.
pub(crate) fn robot_known_map(sim: &sim_core::engine::Simulation, id: i64) -> PyResult<&sim_core::spatial::KnownMap> {
    let Some(id) = u32::try_from(id).ok().filter(|&i| (i as usize) < sim.robots().len()) else {
        return Err(to_py(format!(
            "no robot {id}: the run has {} robots, ids 0 to {}",
            sim.robots().len(),
            sim.robots().len().saturating_sub(1)
        )));
    };
    sim.known_map(RobotId::new(id)).ok_or_else(|| {
        to_py(format!(
            "robot {id} keeps no known map (its strategy does not need one)"
        ))
    })
}

/// A window's cells as a 2-D array.
fn grid_array(py: Python<'_>, w: Window, cells: Vec<u8>) -> PyResult<Bound<'_, numpy::PyArray2<u8>>> {
    let shape = (w.height as usize, w.width as usize);
    Ok(Array2::from_shape_vec(shape, cells).map_err(to_py)?.into_pyarray(py))
}

/// The metrics table as a dict of arrays: integer columns as `int64`, the others `float64`,
/// each value the one the CSV prints.
pub(crate) fn metrics_dict<'py>(py: Python<'py>, rows: &[RoundMetrics]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let records: Vec<_> = rows.iter().map(RoundMetrics::csv_record).collect();
    let integer = RoundMetrics::default().csv_record().map(|v| !v.contains('.'));
    for (c, name) in METRICS_COLUMNS.iter().enumerate() {
        let column = records.iter().map(|r| r[c].as_str());
        if integer[c] {
            let v: Vec<i64> = column.map(|s| s.parse().unwrap_or(i64::MAX)).collect();
            out.set_item(name, PyArray1::from_vec(py, v))?;
        } else {
            let v: Vec<f64> = column.map(|s| s.parse().unwrap_or(f64::NAN)).collect();
            out.set_item(name, PyArray1::from_vec(py, v))?;
        }
    }
    Ok(out)
}

/// One column of a dict of arrays.
fn column<T: numpy::Element>(out: &Bound<'_, PyDict>, name: &str, values: Vec<T>) -> PyResult<()> {
    out.set_item(name, PyArray1::from_vec(out.py(), values))
}

fn robots_dict<'py>(py: Python<'py>, sim: &sim_core::engine::Simulation) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let robots = sim.robots();
    let each = |f: &dyn Fn(&sim_core::world::Robot) -> f64| robots.iter().map(f).collect::<Vec<f64>>();
    column(&out, "id", robots.iter().map(|r| r.id.get()).collect::<Vec<u32>>())?;
    column(
        &out,
        "group",
        robots.iter().map(|r| r.group as u32).collect::<Vec<u32>>(),
    )?;
    column(
        &out,
        "type",
        robots.iter().map(|r| r.type_index as u32).collect::<Vec<u32>>(),
    )?;
    column(&out, "x", each(&|r| r.position.x))?;
    column(&out, "y", each(&|r| r.position.y))?;
    column(&out, "energy", each(&|r| r.energy))?;
    column(
        &out,
        "load",
        robots.iter().map(|r| i64::from(r.load())).collect::<Vec<i64>>(),
    )?;
    column(&out, "alive", robots.iter().map(|r| r.alive).collect::<Vec<bool>>())?;
    let known = |r: &sim_core::world::Robot| {
        sim.known_map(r.id)
            .map_or(0.0, sim_core::spatial::KnownMap::known_area_m2)
    };
    column(&out, "known_area_m2", each(&known))?;
    column(&out, "distance_m", each(&|r| r.stats.distance_m))?;
    column(&out, "explored_m2", each(&|r| r.stats.explored_m2))?;
    column(&out, "overlap_m", each(&|r| r.stats.overlap_m))?;
    column(
        &out,
        "units_dug",
        robots.iter().map(|r| r.stats.units_dug as i64).collect::<Vec<i64>>(),
    )?;
    column(
        &out,
        "units_delivered",
        robots
            .iter()
            .map(|r| r.stats.units_delivered as i64)
            .collect::<Vec<i64>>(),
    )?;
    Ok(out)
}

fn treasures_dict<'py>(py: Python<'py>, sim: &sim_core::engine::Simulation) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let t = sim.treasures();
    let ints =
        |f: &dyn Fn(&sim_core::world::TreasureState) -> u32| t.iter().map(|s| i64::from(f(s))).collect::<Vec<i64>>();
    column(&out, "id", t.iter().map(|s| s.id.get()).collect::<Vec<u32>>())?;
    column(&out, "x", t.iter().map(|s| s.position.x).collect::<Vec<f64>>())?;
    column(&out, "y", t.iter().map(|s| s.position.y).collect::<Vec<f64>>())?;
    column(&out, "quantity", ints(&|s| s.initial))?;
    column(&out, "buried", ints(&|s| s.buried))?;
    column(&out, "loose", ints(&|s| s.loose))?;
    column(&out, "delivered", ints(&|s| s.delivered))?;
    column(
        &out,
        "found",
        t.iter().map(|s| s.found_round.is_some()).collect::<Vec<bool>>(),
    )?;
    Ok(out)
}
