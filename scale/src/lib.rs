//! The scale suite: each scenario generates its own map with the editor's library (nothing
//! large is committed), builds a [`Scenario`], and [`measure`] plays it, reporting set-up
//! time, rounds per second after set-up, and peak memory.
//!
//! ```
//! use scale::{RandomWalk, measure};
//!
//! // The dense random walk, shrunk: 20 walkers on a 64 m map.
//! let scenario = RandomWalk { robots: 20, side_m: 64.0, ..RandomWalk::default() }.scenario()?;
//! let m = measure(scenario, 10, 1)?;
//! assert_eq!(m.rounds, 10);
//! assert_eq!(m.robots, 20);
//! # Ok::<(), scale::Error>(())
//! ```

pub mod exploration;
pub mod fig4;
pub mod kernel;
pub mod paths;
pub mod scaling;
pub mod trace;
/// Charts (shared with `smartteams plot`).
pub use viewer_bridge::plot;

use std::sync::Arc;
use std::time::Instant;

use editor::generate::{GenerateOptions, cell_hash, mesas::mesas, unit};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::agent::{Params, StrategyRegistry};
use sim_core::engine::{Group, PhaseTimes, Scenario, ScenarioBuilder, Simulation, TurnSharing};
use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;
use sim_core::world::{HomeBase, MapData, RobotType, TreasureSpec};

pub use kernel::Kernel;

/// What can go wrong while setting a scenario up.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The kernel refused the scenario.
    #[error(transparent)]
    Sim(#[from] sim_core::Error),
    /// The map generator refused its options.
    #[error(transparent)]
    Editor(#[from] editor::EditorError),
    /// No free spot for the home base near the map's centre.
    #[error("no free spot for a home base of {radius_m} m within {searched_m} m of the map's centre")]
    NoHome {
        /// Home radius asked for.
        radius_m: f64,
        /// How far the search went.
        searched_m: f64,
    },
    /// A plot could not be drawn.
    #[error("plot: {0}")]
    Plot(#[from] viewer_bridge::plot::PlotError),
    /// An output file could not be written.
    #[error("{path}: {cause}")]
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        cause: std::io::Error,
    },
    /// Worker threads could not start.
    #[error("cannot start worker threads: {0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
}

/// This crate's result.
pub type Result<T> = std::result::Result<T, Error>;

/// The dense random walk: `robots` random walkers (turn probability 0.1, 0.5 m steps, 5 m
/// view, no energy use) on a white-noise map of `side_m` × `side_m` at `density`, all
/// starting in a home disc of `home_radius_m` at the centre (cleared of obstacles). Each
/// walker keeps its own known map and obeys collisions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomWalk {
    /// Walkers (default 1,000).
    pub robots: u32,
    /// Map side (default 1,024 m, 1 m cells).
    pub side_m: f64,
    /// Blocked fraction of the white noise (default 0.3).
    pub density: f64,
    /// Home radius (default 20 m).
    pub home_radius_m: f64,
    /// Seed of map and run (default 1).
    pub seed: u64,
}

impl Default for RandomWalk {
    fn default() -> Self {
        Self {
            robots: 1_000,
            side_m: 1_024.0,
            density: 0.3,
            home_radius_m: 20.0,
            seed: 1,
        }
    }
}

impl RandomWalk {
    /// The walker: an explorer body with 0.5 m steps, a 5 m view and no energy use.
    pub fn walker() -> RobotType {
        let mut t = RobotType::new("walker")
            .with_speed_m_per_round(0.5)
            .with_view_radius_m(5.0);
        t.energy_per_m = 0.0;
        t.energy_per_sense = 0.0;
        t.energy_idle = 0.0;
        t.energy_per_message = 0.0;
        t
    }

    /// Generate the map and build the scenario.
    pub fn scenario(&self) -> Result<Scenario> {
        self.scenario_on(&self.map()?)
    }

    /// Generate the map: white noise of `density`, the home disc kept clear.
    pub fn map(&self) -> Result<Arc<MapData>> {
        let opts = GenerateOptions {
            width_m: self.side_m,
            height_m: self.side_m,
            density: Some(self.density),
            seed: self.seed,
            ..GenerateOptions::default()
        };
        let grid = opts.grid()?;
        let density = opts.density_or(0.3)?;
        let centre = DVec2::splat(self.side_m / 2.0);
        // White noise as the editor's generator draws it, with the home disc (plus a cell)
        // kept clear so that every walker has room to start.
        let clear_m = self.home_radius_m + 1.5;
        let obstacles = ObstacleMap::from_fn(grid, |x, y| {
            let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            p.distance(centre) > clear_m && unit(cell_hash(x, y, self.seed)) < density
        });
        let map = MapData {
            obstacles,
            home: HomeBase::Disc {
                center: centre,
                radius_m: self.home_radius_m,
            },
            treasures: Vec::new(),
        };
        Ok(Arc::new(map))
    }

    /// The scenario on `map` (made by [`map`](Self::map)): runs on one map share it.
    pub fn scenario_on(&self, map: &Arc<MapData>) -> Result<Scenario> {
        let registry = StrategyRegistry::with_builtins();
        Ok(ScenarioBuilder::new(Arc::clone(map))
            .with_name("dense-random-walk")
            .with_seed(self.seed)
            .with_rounds(u64::MAX)
            .with_types(vec![Self::walker()])
            .with_group(
                Group::new("random_walk", 0, self.robots)
                    .with_name("walkers")
                    .with_params(Params::from_pairs([("turn_probability", "0.1")])),
            )
            .build(&registry)?)
    }
}

/// The paper's scenario (and the moonshot, scaled up): a Mars-like map of `mesas` rocks and
/// mesas (the editor's generator, 1 m cells) of `side_m` × `side_m`, a home disc near the
/// centre, `treasures` treasures within 400 m of home, and a swarm of 80 % cooperative
/// frontier explorers (sensing, known maps, messages, known-map exchange), 10 % excavators
/// and 10 % transporters, all starting crowded at home.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Swarm {
    /// Robots (default 1,000).
    pub robots: u32,
    /// Map side (default 100 km).
    pub side_m: f64,
    /// Rocks and mesas on the map (default 6,000: about 1.3 M quadtree leaves at 100 km).
    pub mesas: u64,
    /// Largest mesa radius (default 200 m).
    pub mesa_scale_m: f64,
    /// Home radius (default 10 m).
    pub home_radius_m: f64,
    /// Treasures near home (default 200).
    pub treasures: u32,
    /// Bytes of messages each robot can receive per round (default 8,192: a 64 kbit/s radio
    /// at one round a second; `u64::MAX`: no limit).
    pub radio_bytes_per_round: u64,
    /// Seed of map and run (default 1).
    pub seed: u64,
}

impl Default for Swarm {
    fn default() -> Self {
        Self {
            robots: 1_000,
            side_m: 100_000.0,
            mesas: 6_000,
            mesa_scale_m: 200.0,
            home_radius_m: 10.0,
            treasures: 200,
            radio_bytes_per_round: 8_192,
            seed: 1,
        }
    }
}

impl Swarm {
    /// The paper's scale: 1,000 robots on 100 km × 100 km with about 1.3 M leaves.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The moonshot: 10,000 robots on 100 km × 100 km with over 10 M leaves.
    pub fn moonshot() -> Self {
        Self {
            robots: 10_000,
            mesas: 50_000,
            home_radius_m: 30.0,
            ..Self::default()
        }
    }

    /// Generate the map and build the scenario.
    pub fn scenario(&self) -> Result<Scenario> {
        self.scenario_on(&self.map()?)
    }

    /// Generate the map: the mesas, the home disc and the treasures.
    pub fn map(&self) -> Result<Arc<MapData>> {
        let opts = GenerateOptions {
            width_m: self.side_m,
            height_m: self.side_m,
            count: Some(self.mesas),
            scale_m: Some(self.mesa_scale_m),
            seed: self.seed,
            ..GenerateOptions::default()
        };
        let obstacles = mesas(&opts)?;
        let home = free_spot_near(&obstacles, DVec2::splat(self.side_m / 2.0), self.home_radius_m + 2.0).ok_or(
            Error::NoHome {
                radius_m: self.home_radius_m,
                searched_m: self.side_m / 4.0,
            },
        )?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x7EA5_0BE5);
        let mut treasures = Vec::new();
        while treasures.len() < self.treasures as usize {
            let at =
                home + DVec2::from_angle(rng.random_range(0.0..std::f64::consts::TAU)) * rng.random_range(20.0..400.0);
            if obstacles.is_disc_free(at, 0.3) {
                treasures.push(TreasureSpec {
                    position: at,
                    quantity: rng.random_range(1..=5),
                });
            }
        }
        let map = MapData {
            obstacles,
            home: HomeBase::Disc {
                center: home,
                radius_m: self.home_radius_m,
            },
            treasures,
        };
        Ok(Arc::new(map))
    }

    /// The scenario on `map` (made by [`map`](Self::map)): runs on one map share it.
    pub fn scenario_on(&self, map: &Arc<MapData>) -> Result<Scenario> {
        let scouts = self.robots * 8 / 10;
        let diggers = (self.robots - scouts) / 2;
        let haulers = self.robots - scouts - diggers;
        let scout = RobotType::explorer().with_view_radius_m(6.0).with_comm_radius_m(25.0);
        let scout = RobotType {
            name: "scout".into(),
            ..scout
        };
        let radio = self.radio_bytes_per_round;
        let types =
            [scout, RobotType::excavator(), RobotType::transporter()].map(|t| t.with_radio_bytes_per_round(radio));
        let registry = StrategyRegistry::with_builtins();
        Ok(ScenarioBuilder::new(Arc::clone(map))
            .with_name("swarm")
            .with_seed(self.seed)
            .with_rounds(u64::MAX)
            .with_types(types.to_vec())
            .with_group(
                Group::new("cooperative", 0, scouts)
                    .with_name("scouts")
                    .with_params(Params::from_pairs([("share_every", "10"), ("avoid_radius_m", "6")])),
            )
            .with_group(Group::new("excavator", 1, diggers).with_name("diggers"))
            .with_group(Group::new("transporter", 2, haulers).with_name("haulers"))
            .build(&registry)?)
    }
}

/// The free disc of `radius_m` nearest to `centre` on a spiral of 1 m steps, searched out to
/// a quarter of the map's width.
pub(crate) fn free_spot_near(obstacles: &ObstacleMap, centre: DVec2, radius_m: f64) -> Option<DVec2> {
    let limit = obstacles.grid().extent().max.x / 4.0;
    let mut d: f64 = 0.0;
    while d <= limit {
        let steps = (d * std::f64::consts::TAU).ceil().max(1.0) as u32;
        for k in 0..steps {
            let p = centre + DVec2::from_angle(f64::from(k) / f64::from(steps) * std::f64::consts::TAU) * d;
            if obstacles.is_disc_free(p, radius_m) {
                return Some(p);
            }
        }
        d += radius_m.max(1.0);
    }
    None
}

/// What [`measure`] saw.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Robots in the run.
    pub robots: usize,
    /// Quadtree leaves of the map.
    pub leaves: usize,
    /// Rounds timed.
    pub rounds: u64,
    /// Seconds to build the simulation from the scenario (the map generation is the
    /// caller's, see [`Measurement::generate_s`]).
    pub setup_s: f64,
    /// Seconds spent generating the map and validating the scenario (filled by callers).
    pub generate_s: f64,
    /// Seconds for the timed rounds.
    pub rounds_s: f64,
    /// Peak resident set size of the process so far, bytes (Linux; 0 elsewhere).
    pub peak_rss_bytes: u64,
    /// Bytes held by the robots' known maps at the end.
    pub robot_memory_bytes: usize,
    /// Explored fraction of the free area at the end.
    pub explored_fraction: f64,
    /// A digest of every robot's final position, to compare runs (thread counts).
    pub digest: u64,
    /// Wall time in each step of the timed rounds.
    pub phases: PhaseTimes,
}

impl Measurement {
    /// Rounds per second over the timed rounds.
    pub fn rounds_per_s(&self) -> f64 {
        self.rounds as f64 / self.rounds_s
    }

    /// Robot-rounds per second over the timed rounds.
    pub fn robot_rounds_per_s(&self) -> f64 {
        self.rounds_per_s() * self.robots as f64
    }

    /// Planning time ([`PhaseTimes::planning`], CPU time over all threads) per robot-round,
    /// in µs: navigation and frontier choice per robot per round.
    pub fn planning_us_per_robot_round(&self) -> f64 {
        let robot_rounds = self.rounds as f64 * self.robots as f64;
        if robot_rounds == 0.0 {
            return 0.0;
        }
        self.phases.planning.as_secs_f64() * 1e6 / robot_rounds
    }
}

impl Measurement {
    /// Column names of [`csv_row`](Self::csv_row).
    pub const COLUMNS: [&str; 10] = [
        "robots",
        "leaves",
        "rounds",
        "generate_s",
        "setup_s",
        "rounds_per_s",
        "us_per_robot_round",
        "peak_rss_bytes",
        "robot_memory_bytes",
        "digest",
    ];

    /// The measurement as one CSV row (columns [`COLUMNS`](Self::COLUMNS)).
    pub fn csv_row(&self) -> Vec<String> {
        vec![
            self.robots.to_string(),
            self.leaves.to_string(),
            self.rounds.to_string(),
            format!("{:.3}", self.generate_s),
            format!("{:.3}", self.setup_s),
            format!("{:.3}", self.rounds_per_s()),
            format!("{:.3}", 1e6 / self.robot_rounds_per_s()),
            self.peak_rss_bytes.to_string(),
            self.robot_memory_bytes.to_string(),
            format!("{:016x}", self.digest),
        ]
    }
}

/// Peak resident set size of this process, from `/proc/self/status` (0 where unknown).
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Build the simulation and play `rounds` rounds on `threads` worker threads (0: one per
/// core), timing the set-up and the rounds apart, and the strategies' planning within the
/// rounds ([`PhaseTimes::planning`]).
pub fn measure(scenario: Scenario, rounds: u64, threads: usize) -> Result<Measurement> {
    measure_with(scenario, rounds, threads, TurnSharing::Auto)
}

/// [`measure`] with step 3's turns shared as `sharing` says.
pub fn measure_with(scenario: Scenario, rounds: u64, threads: usize, sharing: TurnSharing) -> Result<Measurement> {
    let mut run = TimedRun::new(scenario, threads, sharing)?;
    run.play(rounds);
    Ok(run.measurement())
}

/// [`measure_with`] for several runs (each a thread count and how it shares step 3's
/// turns), each on a scenario `make` builds, played in turn `block` rounds at a time, each
/// on its own workers; with `block` 0, one run after the other, each built when its turn
/// comes and dropped before the next. Alternated, a drift of the machine's speed (a VM's
/// can move by a third within seconds) falls on every run alike, so that their ratios hold
/// still. A 2-thread run played in turn with a 1-thread one in one process runs slower than
/// alone (BENCHMARKS.md, "Scaling"): take speed-ups between thread counts from processes
/// alternated (`scripts/bench-threads.sh`). The measurements come in the order of `runs`. Cost: alternated, every run's
/// simulation is in memory at once; one after the other, one at a time. A `make` that
/// shares one map (as [`Swarm::scenario_on`] does) generates it once for all the runs.
///
/// ```
/// use scale::{RandomWalk, measure_alternated};
/// use sim_core::engine::TurnSharing;
///
/// let walk = RandomWalk { robots: 20, side_m: 64.0, ..RandomWalk::default() };
/// let map = walk.map()?;
/// let make = || walk.scenario_on(&map);
/// let ms = measure_alternated(make, &[(1, TurnSharing::Auto), (2, TurnSharing::SideBySide)], 10, 3)?;
/// assert_eq!((ms[0].rounds, ms[1].rounds), (10, 10));
/// assert_eq!(ms[0].digest, ms[1].digest);
/// // The same rounds as the runs played one after the other.
/// let one_by_one = measure_alternated(make, &[(1, TurnSharing::Auto)], 10, 0)?;
/// assert_eq!(ms[0].digest, one_by_one[0].digest);
/// # Ok::<(), scale::Error>(())
/// ```
pub fn measure_alternated(
    make: impl Fn() -> Result<Scenario>,
    runs: &[(usize, TurnSharing)],
    rounds: u64,
    block: u64,
) -> Result<Vec<Measurement>> {
    if block == 0 {
        return runs
            .iter()
            .map(|&(threads, sharing)| measure_with(make()?, rounds, threads, sharing))
            .collect();
    }
    let mut timed = runs
        .iter()
        .map(|&(threads, sharing)| TimedRun::new(make()?, threads, sharing))
        .collect::<Result<Vec<_>>>()?;
    let mut played = 0;
    while played < rounds {
        let n = block.min(rounds - played);
        for run in &mut timed {
            run.play(n);
        }
        played += n;
    }
    Ok(timed.iter().map(TimedRun::measurement).collect())
}

/// A simulation on its own pool of workers, with its set-up and rounds timed.
struct TimedRun {
    pool: rayon::ThreadPool,
    sim: Simulation,
    setup_s: f64,
    rounds: u64,
    rounds_s: f64,
}

impl TimedRun {
    /// Build the simulation on a pool of `threads` workers (0: one per core).
    fn new(scenario: Scenario, threads: usize, sharing: TurnSharing) -> Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let t0 = Instant::now();
        // Planning is timed for `PhaseTimes::planning` (two clock reads a search).
        let sim = pool
            .install(|| Simulation::new(scenario))?
            .with_time_planning(true)
            .with_turn_sharing(sharing);
        let setup_s = t0.elapsed().as_secs_f64();
        Ok(Self {
            pool,
            sim,
            setup_s,
            rounds: 0,
            rounds_s: 0.0,
        })
    }

    /// Play and time `rounds` more rounds.
    fn play(&mut self, rounds: u64) {
        let sim = &mut self.sim;
        let t = Instant::now();
        self.pool.install(|| {
            // The bench has the cores to itself: the workers poll between parallel steps
            // instead of sleeping (see `with_hot_workers`; SMARTTEAMS_COLD_WORKERS, set to anything, lets
            // them sleep, to measure the difference).
            let mut rounds_loop = || {
                for _ in 0..rounds {
                    sim.step();
                }
            };
            if std::env::var_os("SMARTTEAMS_COLD_WORKERS").is_some() {
                rounds_loop();
            } else {
                sim_core::engine::with_hot_workers(rounds_loop);
            }
        });
        self.rounds_s += t.elapsed().as_secs_f64();
        self.rounds += rounds;
    }

    /// What the run has measured so far.
    fn measurement(&self) -> Measurement {
        let sim = &self.sim;
        Measurement {
            robots: sim.robots().len(),
            leaves: sim.obstacles().leaf_count(),
            rounds: self.rounds,
            setup_s: self.setup_s,
            generate_s: 0.0,
            rounds_s: self.rounds_s,
            peak_rss_bytes: peak_rss_bytes(),
            robot_memory_bytes: sim.robot_memory_bytes(),
            explored_fraction: sim.report().metrics.explored_fraction,
            digest: sim.positions_digest(),
            phases: sim.phase_times(),
        }
    }
}
