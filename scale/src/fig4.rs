//! The paper's Fig. 4, reproduced: known-map memory on a 500,000-leaf map (left: 100 robots
//! against rounds; right: after 50 rounds against the number of robots, beside the kernel's
//! own map), and the explored fraction against rounds for 10, 100 and 1,000 robots.
//!
//! Robots run `frontier` exploration towards the nearest frontier, as the paper's do (each
//! explores on its own, so its known map is what it has seen), all starting at home.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use editor::generate::{GenerateOptions, mesas::mesas};
use sim_core::agent::{Params, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation};
use sim_core::glam::DVec2;
use sim_core::world::{HomeBase, MapData, RobotType};

use crate::plot::{self, Series};
use crate::{Error, Result, free_spot_near};

/// What to run (defaults: the paper's figure).
#[derive(Clone, Debug, PartialEq)]
pub struct Fig4 {
    /// Map side (default 2,048 m, 1 m cells).
    pub side_m: f64,
    /// Rocks and mesas (default 15,500: about 500,000 leaves at 2,048 m).
    pub mesas: u64,
    /// Robots of the left panel (default 100).
    pub robots_over_time: u32,
    /// Rounds of the left panel (default 1,000).
    pub rounds: u64,
    /// Sample every this many rounds (default 10).
    pub every: u64,
    /// Robot counts of the right panel (default 10 … 1,000).
    pub robot_counts: Vec<u32>,
    /// Rounds before the right panel's measurement (default 50).
    pub rounds_before_count: u64,
    /// Robot counts of the explored-fraction curves (default 10, 100, 1,000).
    pub explored_counts: Vec<u32>,
    /// Rounds of the explored-fraction curves (default 500).
    pub explored_rounds: u64,
    /// Seed (default 1).
    pub seed: u64,
}

impl Default for Fig4 {
    fn default() -> Self {
        Self {
            side_m: 2_048.0,
            mesas: 15_500,
            robots_over_time: 100,
            rounds: 1_000,
            every: 10,
            robot_counts: vec![10, 20, 50, 100, 200, 500, 1_000],
            rounds_before_count: 50,
            explored_counts: vec![10, 100, 1_000],
            explored_rounds: 500,
            seed: 1,
        }
    }
}

/// The figure's numbers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fig4Data {
    /// Robots of the left panel.
    pub robots_over_time: u32,
    /// Quadtree leaves of the map.
    pub leaves: usize,
    /// Bytes of the kernel's obstacle map.
    pub kernel_bytes: usize,
    /// Left: (round, bytes of all known maps, explored fraction).
    pub memory_over_time: Vec<(u64, usize, f64)>,
    /// Right: (robots, bytes of all known maps after `rounds_before_count` rounds).
    pub memory_by_robots: Vec<(u32, usize)>,
    /// (robots, [(round, explored fraction)]).
    pub explored: Vec<(u32, Vec<(u64, f64)>)>,
}

impl Fig4 {
    /// The map: mesas with a 12 m home near the centre (room for 1,000 robots).
    pub fn map(&self) -> Result<Arc<MapData>> {
        let opts = GenerateOptions {
            width_m: self.side_m,
            height_m: self.side_m,
            count: Some(self.mesas),
            scale_m: Some(30.0),
            seed: self.seed,
            ..GenerateOptions::default()
        };
        let obstacles = mesas(&opts)?;
        let radius_m = 12.0;
        let home =
            free_spot_near(&obstacles, DVec2::splat(self.side_m / 2.0), radius_m + 1.0).ok_or(Error::NoHome {
                radius_m,
                searched_m: self.side_m / 4.0,
            })?;
        Ok(Arc::new(MapData {
            obstacles,
            home: HomeBase::Disc { center: home, radius_m },
            treasures: Vec::new(),
        }))
    }

    fn simulation(&self, map: &Arc<MapData>, robots: u32) -> Result<Simulation> {
        let registry = StrategyRegistry::with_builtins();
        let scenario = ScenarioBuilder::new(Arc::clone(map))
            .with_name(format!("fig4-{robots}"))
            .with_seed(self.seed)
            .with_rounds(u64::MAX)
            .with_types(vec![RobotType::explorer()])
            // The paper's explorers head for the nearest frontier: without the tour
            // (crowds that do not talk explore less with it, BENCHMARKS.md).
            .with_group(
                Group::new("frontier", 0, robots)
                    .with_name("explorers")
                    .with_params(Params::from_pairs([("tour_stops", "0")])),
            )
            .build(&registry)?;
        Ok(Simulation::new(scenario)?)
    }

    /// Run everything; `progress` is told what is running.
    pub fn run(&self, mut progress: impl FnMut(&str)) -> Result<Fig4Data> {
        let map = self.map()?;
        let mut data = Fig4Data {
            leaves: map.obstacles.leaf_count(),
            kernel_bytes: map.obstacles.memory_bytes(),
            robots_over_time: self.robots_over_time,
            ..Fig4Data::default()
        };
        progress(&format!(
            "left: {} robots, {} rounds",
            self.robots_over_time, self.rounds
        ));
        let mut sim = self.simulation(&map, self.robots_over_time)?;
        data.memory_over_time.push((0, sim.robot_memory_bytes(), 0.0));
        while sim.round() < self.rounds {
            sim.step();
            if sim.round().is_multiple_of(self.every) {
                let explored = sim.report().metrics.explored_fraction;
                data.memory_over_time
                    .push((sim.round(), sim.robot_memory_bytes(), explored));
            }
        }
        for &n in &self.robot_counts {
            progress(&format!("right: {n} robots, {} rounds", self.rounds_before_count));
            let mut sim = self.simulation(&map, n)?;
            for _ in 0..self.rounds_before_count {
                sim.step();
            }
            data.memory_by_robots.push((n, sim.robot_memory_bytes()));
        }
        for &n in &self.explored_counts {
            progress(&format!("explored: {n} robots, {} rounds", self.explored_rounds));
            let mut sim = self.simulation(&map, n)?;
            let mut curve = vec![(0, 0.0)];
            while sim.round() < self.explored_rounds {
                sim.step();
                if sim.round().is_multiple_of(self.every) {
                    curve.push((sim.round(), sim.report().metrics.explored_fraction));
                }
            }
            data.explored.push((n, curve));
        }
        Ok(data)
    }
}

impl Fig4Data {
    /// Write `memory-vs-rounds.csv`, `memory-vs-robots.csv`, `explored-vs-rounds.csv` and,
    /// with `plots`, `fig4-left.png`, `fig4-right.png`, `explored.png` into `dir`.
    pub fn write(&self, dir: &Path, plots: bool) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|cause| Error::Write {
            path: dir.to_path_buf(),
            cause,
        })?;
        let mut written = self.write_csv_files(dir)?;
        if plots {
            written.extend(self.write_plots(dir)?);
        }
        Ok(written)
    }

    fn write_csv_files(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let per_robot = |bytes: usize, robots: u32| format!("{:.1}", bytes as f64 / f64::from(robots.max(1)));
        let left = dir.join("memory-vs-rounds.csv");
        write_csv(
            &left,
            ["round", "known_map_bytes", "bytes_per_robot", "explored_fraction"],
            self.memory_over_time.iter().map(|&(round, bytes, explored)| {
                vec![
                    round.to_string(),
                    bytes.to_string(),
                    per_robot(bytes, self.robots_over_time),
                    format!("{explored:.6}"),
                ]
            }),
        )?;
        let right = dir.join("memory-vs-robots.csv");
        write_csv(
            &right,
            ["robots", "known_map_bytes", "bytes_per_robot", "kernel_map_bytes"],
            self.memory_by_robots.iter().map(|&(n, bytes)| {
                vec![
                    n.to_string(),
                    bytes.to_string(),
                    per_robot(bytes, n),
                    self.kernel_bytes.to_string(),
                ]
            }),
        )?;
        let explored = dir.join("explored-vs-rounds.csv");
        let mut header = vec!["round".to_owned()];
        header.extend(self.explored.iter().map(|(n, _)| format!("robots_{n}")));
        let rounds: Vec<u64> = self
            .explored
            .first()
            .map(|(_, c)| c.iter().map(|p| p.0).collect())
            .unwrap_or_default();
        write_csv(
            &explored,
            header,
            rounds.iter().enumerate().map(|(i, round)| {
                let mut row = vec![round.to_string()];
                row.extend(
                    self.explored
                        .iter()
                        .map(|(_, c)| c.get(i).map_or(String::new(), |p| format!("{:.6}", p.1))),
                );
                row
            }),
        )?;
        Ok(vec![left, right, explored])
    }

    fn write_plots(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let kib = |b: usize| b as f64 / 1024.0;
        let left = dir.join("fig4-left.png");
        plot::line_chart(
            &left,
            &format!(
                "Known-map memory of {} robots ({} leaves)",
                self.robots_over_time, self.leaves
            ),
            "rounds",
            "KiB, all robots",
            &[Series {
                label: "all known maps",
                points: self
                    .memory_over_time
                    .iter()
                    .map(|&(r, b, _)| (r as f64, kib(b)))
                    .collect(),
            }],
        )?;
        let right = dir.join("fig4-right.png");
        let robots_max = self.memory_by_robots.iter().map(|p| p.0).max().unwrap_or(1);
        plot::line_chart(
            &right,
            "Known-map memory after 50 rounds",
            "robots",
            "KiB",
            &[
                Series {
                    label: "all known maps",
                    points: self
                        .memory_by_robots
                        .iter()
                        .map(|&(n, b)| (f64::from(n), kib(b)))
                        .collect(),
                },
                Series {
                    label: "the kernel's obstacle map",
                    points: vec![
                        (0.0, kib(self.kernel_bytes)),
                        (f64::from(robots_max), kib(self.kernel_bytes)),
                    ],
                },
            ],
        )?;
        let explored = dir.join("explored.png");
        let labels: Vec<String> = self.explored.iter().map(|(n, _)| format!("{n} robots")).collect();
        let series: Vec<Series> = self
            .explored
            .iter()
            .zip(&labels)
            .map(|((_, c), label)| Series {
                label,
                points: c.iter().map(|&(r, f)| (r as f64, f)).collect(),
            })
            .collect();
        plot::line_chart(
            &explored,
            "Explored fraction (frontier exploration)",
            "rounds",
            "explored fraction",
            &series,
        )?;
        Ok(vec![left, right, explored])
    }
}

/// Write a header and rows as CSV to `path`.
fn write_csv<H: AsRef<[u8]>>(
    path: &Path,
    header: impl IntoIterator<Item = H>,
    rows: impl IntoIterator<Item = Vec<String>>,
) -> Result<()> {
    let fail = |e: csv::Error| Error::Write {
        path: path.to_path_buf(),
        cause: std::io::Error::other(e),
    };
    let mut w = csv::Writer::from_path(path).map_err(fail)?;
    w.write_record(header).map_err(fail)?;
    for row in rows {
        w.write_record(&row).map_err(fail)?;
    }
    w.flush().map_err(|cause| Error::Write {
        path: path.to_path_buf(),
        cause,
    })
}
