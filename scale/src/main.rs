//! `smartteams-bench`: the scale suite from the command line. One scenario per process, so
//! that the peak memory printed is that scenario's.

mod curves;

use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use scale::fig4::Fig4;
use scale::{Kernel, RandomWalk, Swarm, measure};
use sim_core::engine::TurnSharing;

/// The allocator: a round allocates and frees messages, payloads and search buffers on every
/// worker, which mimalloc's per-thread heaps serve without glibc's trimming and refaulting of
/// pages. Paper scale and 100,000 robots run faster with it (BENCHMARKS.md); results do not
/// depend on it.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Time Smart Teams at scale: each scenario generates its own map, then prints set-up time,
/// rounds per second after set-up, and peak memory.
#[derive(Parser, Debug)]
#[command(name = "smartteams-bench", version)]
struct Cli {
    #[command(subcommand)]
    scenario: Scenario,
    /// Rounds to time after set-up (random-walk, swarm, kernel, config, scaling; for
    /// exploration the bound of each run); fig4, curves, any-angle and nav-graph set their own.
    #[arg(long, default_value_t = 200, global = true)]
    rounds: u64,
    /// Worker threads (0: one per core) of random-walk, swarm, kernel and config; for
    /// `scaling`, a list (default 1,2). The other scenarios set their own.
    #[arg(long, global = true, value_delimiter = ',')]
    threads: Vec<usize>,
}

/// The scenarios that play rounds and time them.
#[derive(Subcommand, Debug)]
enum Timed {
    /// Dense random walkers on a white-noise map.
    RandomWalk {
        /// Walkers.
        #[arg(long, default_value_t = 1_000)]
        robots: u32,
        /// Map side, metres (1 m cells).
        #[arg(long, default_value_t = 1_024.0)]
        side_m: f64,
        /// Blocked fraction.
        #[arg(long, default_value_t = 0.3)]
        density: f64,
        /// Seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// The paper's scale: 1,000 cooperative explorers, excavators and transporters on
    /// 100 km × 100 km with about 1.3 M leaves (`--robots 10000 --mesas 50000
    /// --home-radius-m 30` is the moonshot).
    Swarm {
        /// Robots (80 % explorers, 10 % excavators, 10 % transporters).
        #[arg(long, default_value_t = 1_000)]
        robots: u32,
        /// Map side, metres (1 m cells).
        #[arg(long, default_value_t = 100_000.0)]
        side_m: f64,
        /// Rocks and mesas on the map (6,000 ≈ 1.3 M leaves, 50,000 ≈ 11 M at 100 km).
        #[arg(long, default_value_t = 6_000)]
        mesas: u64,
        /// Home radius, metres.
        #[arg(long, default_value_t = 10.0)]
        home_radius_m: f64,
        /// Bytes of messages a robot can receive per round (0: no limit).
        #[arg(long, default_value_t = 8_192)]
        radio_bytes_per_round: u64,
        /// Print the measurement as one CSV row (for `curves`) instead of a sentence.
        #[arg(long)]
        csv_row: bool,
        /// Seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// The kernel scenario: cooperative explorers on a 2,048 m map of clustered rocks
    /// (about 2.1 M leaves). Prints the time strategies spent planning routes and
    /// frontiers, per robot-round (the target: at most 2 µs with 1,000 robots over 1,500
    /// rounds).
    Kernel {
        /// Explorers.
        #[arg(long, default_value_t = 1_000)]
        robots: u32,
        /// Seed of the run.
        #[arg(long, default_value_t = 7)]
        seed: u64,
        /// The explorers' `max_detour_m` (how much farther than the nearest frontier they
        /// walk to one no team mate claims); unbounded if not given.
        #[arg(long)]
        max_detour_m: Option<f64>,
    },
    /// A Smart Teams XML config (for example `configs/bench-1000.xml`), played `--rounds`
    /// rounds (not the config's) with no outputs.
    Config {
        /// The config file.
        file: std::path::PathBuf,
    },
}

#[derive(Subcommand, Debug)]
enum Scenario {
    #[command(flatten)]
    Timed(Timed),
    /// Where a scenario's round time goes on 1 thread, which steps run on one thread only,
    /// the sequential share and what Amdahl's law allows at 4, 16 and 64 cores, with the
    /// measured speed-up at each of `--threads` (default 1,2).
    Scaling {
        /// How step 3 shares its turns: `auto` (as runs do), `in-order` or `side-by-side`
        /// (as on a machine with more cores, for the sequential share there); a list runs
        /// each thread count with each, to compare them.
        #[arg(long, default_value = "auto", value_delimiter = ',')]
        turns: Vec<TurnSharing>,
        /// Play the runs in turn, this many rounds at a time, each on its own simulation
        /// (0: one run after the other), so that a drift of the machine's speed falls on
        /// all of them alike. In one process a 1-thread run slows a 2-thread one played in
        /// turn with it (BENCHMARKS.md, "Scaling"): for speed-ups, alternate processes.
        #[arg(long, default_value_t = 0)]
        alternate: u64,
        #[command(subcommand)]
        scenario: Timed,
    },
    /// Curves: `swarm` rounds per second and peak memory against robots (100 → 10,000) and
    /// against leaves (10⁵ → 10⁷), and the speed-up from 1 to 2 threads. Each point runs in
    /// its own process (so that its peak memory is its own); CSV and PNG files.
    Curves {
        /// Folder for the CSV and PNG files.
        #[arg(long, default_value = "docs/curves")]
        out: std::path::PathBuf,
        /// Largest swarm of the robots curve.
        #[arg(long, default_value_t = 10_000)]
        max_robots: u32,
        /// Write CSV only.
        #[arg(long)]
        no_plots: bool,
    },
    /// Any-angle paths: the visibility graph's size and build time on a map, then the mean
    /// query time and, against published optima, the mean and worst excess.
    AnyAngle {
        /// A Moving AI `.map` or a Smart Teams map file.
        #[arg(long)]
        map: std::path::PathBuf,
        /// A Moving AI scenario (`.scen`, or with an any-angle optimum in a 10th column);
        /// without one, `--queries` random pairs of free cell centres.
        #[arg(long)]
        scen: Option<std::path::PathBuf>,
        /// Random queries when there is no scenario.
        #[arg(long, default_value_t = 1_000)]
        queries: usize,
        /// Robot radius, metres.
        #[arg(long, default_value_t = 0.0)]
        robot_radius_m: f64,
        /// Seed of the random queries.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// The kernel's navigation graph: pieces of free space, edges and build time on a map,
    /// then route queries for a robot that knows the whole map, with their lengths against
    /// the exact any-angle planner's on maps small enough for it.
    NavGraph {
        /// A Moving AI `.map` or a Smart Teams map file.
        #[arg(long)]
        map: std::path::PathBuf,
        /// Random queries (pairs of free cell centres).
        #[arg(long, default_value_t = 1_000)]
        queries: usize,
        /// Robot radius, metres.
        #[arg(long, default_value_t = 0.125)]
        robot_radius_m: f64,
        /// Compare with the exact planner on maps of at most this many cells.
        #[arg(long, default_value_t = 4_194_304)]
        compare_cells: u64,
        /// Seed of the random queries.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Exploration quality: on each map of the comparison set, the distance one robot walks
    /// to 90 % and 98 % explored with the greedy nearest-frontier reference and with
    /// `--strategy`, and the rounds teams of `cooperative` robots take to 90 % (3.5 m view,
    /// 0.25 m a round, no energy use). `--rounds` bounds each run.
    Exploration {
        /// The built-in explorer compared with the reference.
        #[arg(long, default_value = "frontier")]
        strategy: String,
        /// A parameter of `--strategy`, as a config's `<param name=… value=…>` gives it
        /// (repeat for more; e.g. `--param replan_within_view=0.25`).
        #[arg(long = "param", value_name = "NAME=VALUE", value_parser = parse_param)]
        params: Vec<(String, String)>,
        /// A parameter of the teams' `cooperative` robots, and of the one robot they are
        /// timed against (repeat for more; e.g. `--team-param wait_rounds=0`).
        #[arg(long = "team-param", value_name = "NAME=VALUE", value_parser = parse_param)]
        team_params: Vec<(String, String)>,
        /// The shared map folder (ROS maps and the Stage cave); default: `SMARTTEAMS_DATA`.
        #[arg(long)]
        data: Option<std::path::PathBuf>,
        /// Team sizes of `cooperative` (2 or more) to time against one robot (`0`: no teams).
        #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
        teams: Vec<u32>,
        /// Only the maps whose name contains this.
        #[arg(long)]
        only: Option<String>,
        /// Also start both explorers from this many points along the reference's run from
        /// home, and print each map's ratios from every start and their means instead of
        /// the table; then the teams' speed-ups and summed distances over every start.
        #[arg(long, default_value_t = 0)]
        starts: usize,
        /// Draw each map's two walks into this folder, `MAP.png`: the reference's on the
        /// left, `--strategy`'s on the right, blue to 90 % explored, red from there on, the
        /// start green, what was first seen after 90 % amber, what stayed unseen pink; and
        /// the teams', one robot first, into `MAP-teams.png`. With `--starts`, the walks from
        /// home go to `MAP-home.png` and `MAP-home-teams.png`, each other start's to
        /// `MAP-start-K.png` and `MAP-start-K-teams.png`.
        #[arg(long, value_name = "DIR")]
        trace: Option<std::path::PathBuf>,
    },
    /// The paper's Fig. 4: known-map memory against rounds and robots on a 500,000-leaf
    /// map, and explored fraction against rounds; CSV and PNG files.
    Fig4 {
        /// Folder for the CSV and PNG files.
        #[arg(long, default_value = "docs/fig4")]
        out: std::path::PathBuf,
        /// A small, fast version (200 rounds, up to 200 robots), for a first look.
        #[arg(long)]
        quick: bool,
        /// Write CSV only.
        #[arg(long)]
        no_plots: bool,
    },
}

fn main() {
    if let Err(e) = run(&Cli::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: &Cli) -> Result<()> {
    match cli.scenario {
        Scenario::Fig4 {
            ref out,
            quick,
            no_plots,
        } => fig4(out, quick, !no_plots),
        Scenario::Curves {
            ref out,
            max_robots,
            no_plots,
        } => curves::run(out, max_robots, !no_plots),
        Scenario::AnyAngle {
            ref map,
            ref scen,
            queries,
            robot_radius_m,
            seed,
        } => any_angle(map, scen.as_deref(), queries, robot_radius_m, seed),
        Scenario::NavGraph {
            ref map,
            queries,
            robot_radius_m,
            compare_cells,
            seed,
        } => nav_graph(map, queries, robot_radius_m, compare_cells, seed),
        Scenario::Exploration {
            ref strategy,
            ref params,
            ref team_params,
            ref data,
            ref teams,
            ref only,
            starts,
            ref trace,
        } => {
            let compared = Compared {
                strategy: strategy.clone(),
                params: params.iter().cloned().collect(),
            };
            let teams = Teams {
                sizes: teams.clone(),
                params: team_params.iter().cloned().collect(),
            };
            let maps = MapChoice {
                data: data.as_deref(),
                only: only.as_deref(),
                starts,
            };
            exploration_command(&compared, &teams, &maps, trace.as_deref(), cli.rounds)
        }
        Scenario::Timed(ref timed) => time_scenario(timed, cli.rounds, one_thread_count(&cli.threads)?),
        Scenario::Scaling {
            ref scenario,
            ref turns,
            alternate,
        } => scaling(scenario, cli.rounds, &scaling_threads(&cli.threads), turns, alternate),
    }
}

/// The maps `exploration` runs on: from `data` (the real maps), those matching `only`, and
/// from `starts` starts besides home (0: home only).
struct MapChoice<'a> {
    data: Option<&'a std::path::Path>,
    only: Option<&'a str>,
    starts: usize,
}

/// `exploration`: checks the strategies' names and parameters before any table begins,
/// then runs from home or from every start.
fn exploration_command(
    compared: &Compared,
    teams: &Teams,
    maps: &MapChoice,
    trace: Option<&std::path::Path>,
    rounds: u64,
) -> Result<()> {
    anyhow::ensure!(
        !teams.sizes.contains(&1),
        "--teams 1: a team has 2 robots or more (one robot is what every team is timed against; 0: no teams)"
    );
    scale::exploration::check_strategy(&compared.strategy, &compared.params)?;
    scale::exploration::check_strategy("cooperative", &teams.params)?;
    if maps.starts > 0 {
        exploration_from_starts(compared, maps.data, teams, maps.only, maps.starts, trace, rounds)
    } else {
        let list = exploration_maps(maps.data, maps.only)?;
        exploration(compared, &list, teams, trace, rounds)
    }
}

/// `scaling`'s thread counts: `--threads` as given, 0 meaning rayon's default pool size (one
/// thread per core unless `RAYON_NUM_THREADS` says otherwise; the report names the count),
/// or 1 and 2.
fn scaling_threads(threads: &[usize]) -> Vec<usize> {
    if threads.is_empty() {
        vec![1, 2]
    } else {
        let default = rayon::current_num_threads();
        threads.iter().map(|&n| if n == 0 { default } else { n }).collect()
    }
}

/// The one `--threads` value of a scenario other than `scaling` (0 when not given).
fn one_thread_count(threads: &[usize]) -> Result<usize> {
    match threads {
        [] => Ok(0),
        [n] => Ok(*n),
        _ => anyhow::bail!("--threads takes one value here (a list is for `scaling`)"),
    }
}

/// Generate the map and robots of a timed scenario, time `rounds` rounds on `threads`
/// workers, and print the measurement.
fn time_scenario(timed: &Timed, rounds: u64, threads: usize) -> Result<()> {
    let t0 = Instant::now();
    let (name, make, csv_row) = scenario_maker(timed)?;
    let scenario = make()?;
    let generate_s = t0.elapsed().as_secs_f64();
    let mut m = measure(scenario, rounds, threads)?;
    m.generate_s = generate_s;
    if csv_row {
        println!("{}", m.csv_row().join(","));
        return Ok(());
    }
    print_measurement(name, &m);
    Ok(())
}

/// The scaling report of a timed scenario: one run per thread count and way of sharing
/// turns, each on a scenario built afresh on one map (same seed), one after the other or,
/// with `alternate` rounds, in turn (see [`scale::measure_alternated`]).
fn scaling(timed: &Timed, rounds: u64, threads: &[usize], turns: &[TurnSharing], alternate: u64) -> Result<()> {
    let (name, make, _) = scenario_maker(timed)?;
    let (mut labels, mut plan) = (Vec::new(), Vec::new());
    for &sharing in turns {
        for &n in threads {
            let label = if turns.len() > 1 {
                format!("{n} thr {sharing}")
            } else {
                format!("{n} thr")
            };
            labels.push((label, n));
            plan.push((n, sharing));
        }
    }
    let how = if alternate == 0 {
        String::new()
    } else {
        format!(", alternated every {alternate} rounds")
    };
    let mut runs = Vec::new();
    for ((label, n), m) in labels
        .into_iter()
        .zip(scale::measure_alternated(make, &plan, rounds, alternate)?)
    {
        eprintln!("scaling: {label}: {:.1} rounds/s{how}", m.rounds_per_s());
        runs.push((label, n, m));
    }
    let digests: std::collections::BTreeSet<u64> = runs.iter().map(|(_, _, m)| m.digest).collect();
    print_scaling(name, &runs, &digests);
    anyhow::ensure!(
        digests.len() == 1,
        "the runs' digests differ: the round is not deterministic"
    );
    Ok(())
}

/// Builds a timed scenario on its map, generated or loaded once.
type MakeScenario = Box<dyn Fn() -> scale::Result<sim_core::engine::Scenario>>;

/// A timed scenario: its name, its map (generated or loaded now, once) with what builds the
/// scenario on it, and whether the measurement is printed as a CSV row.
fn scenario_maker(scenario: &Timed) -> Result<(&'static str, MakeScenario, bool)> {
    Ok(match *scenario {
        Timed::RandomWalk {
            robots,
            side_m,
            density,
            seed,
        } => {
            let rw = RandomWalk {
                robots,
                side_m,
                density,
                seed,
                ..RandomWalk::default()
            };
            let map = rw.map()?;
            ("random-walk", Box::new(move || rw.scenario_on(&map)), false)
        }
        Timed::Swarm {
            robots,
            side_m,
            mesas,
            home_radius_m,
            radio_bytes_per_round,
            seed,
            csv_row,
        } => {
            let swarm = Swarm {
                robots,
                side_m,
                mesas,
                home_radius_m,
                radio_bytes_per_round: if radio_bytes_per_round == 0 {
                    u64::MAX
                } else {
                    radio_bytes_per_round
                },
                seed,
                ..Swarm::default()
            };
            let map = swarm.map()?;
            ("swarm", Box::new(move || swarm.scenario_on(&map)), csv_row)
        }
        Timed::Kernel {
            robots,
            seed,
            max_detour_m,
        } => {
            let kernel = Kernel {
                robots,
                seed,
                max_detour_m,
            };
            let map = Kernel::map();
            ("kernel", Box::new(move || kernel.scenario(&map)), false)
        }
        Timed::Config { ref file } => {
            let config = sim_core::io::SimConfig::load(file)?;
            let map = std::sync::Arc::new(config.load_map()?);
            let registry = sim_core::agent::StrategyRegistry::with_builtins();
            let make = move || Ok(config.scenario_with_map(&registry, std::sync::Arc::clone(&map))?);
            ("config", Box::new(make), false)
        }
    })
}

/// The measurement as sentences: the run, where its rounds' time went, and its planning.
fn print_measurement(name: &str, m: &scale::Measurement) {
    println!(
        "{name}: {} robots, {} leaves, {} rounds | map+scenario {:.2} s, set-up {:.2} s | {:.1} rounds/s, {:.3e} robot-rounds/s | peak RSS {:.0} MB, known maps {:.1} MB | explored {:.4} | digest {:016x}",
        m.robots,
        m.leaves,
        m.rounds,
        m.generate_s,
        m.setup_s,
        m.rounds_per_s(),
        m.robot_rounds_per_s(),
        m.peak_rss_bytes as f64 / 1e6,
        m.robot_memory_bytes as f64 / 1e6,
        m.explored_fraction,
        m.digest
    );
    let p = m.phases;
    println!(
        "  time in the rounds: perceive + decide {:.3} s, resolve {:.3} s, deliver {:.3} s, other {:.3} s",
        p.perceive_decide.as_secs_f64(),
        p.resolve.as_secs_f64(),
        p.deliver.as_secs_f64(),
        p.other.as_secs_f64()
    );
    println!(
        "  planning (routes and frontiers, CPU time summed over threads): {:.3} s, {:.3} µs per robot-round",
        p.planning.as_secs_f64(),
        m.planning_us_per_robot_round()
    );
}

/// The scaling report: per step, its time on each thread count and whether it runs on one
/// thread; then the sequential share on the first run and Amdahl's bounds.
fn print_scaling(name: &str, runs: &[(String, usize, scale::Measurement)], digests: &std::collections::BTreeSet<u64>) {
    use scale::scaling::{amdahl, karp_flatt, phases, sequential_share};
    let Some((first_label, first_threads, first)) = runs.first() else {
        return;
    };
    println!(
        "scaling: {name}, {} robots, {} rounds; digest {}",
        first.robots,
        first.rounds,
        if digests.len() == 1 {
            format!("{:016x} in every run", first.digest)
        } else {
            format!("DIFFERS between runs: {digests:016x?}")
        }
    );
    let base = phases(&first.phases);
    let by_run: Vec<_> = runs.iter().map(|(_, _, m)| phases(&m.phases)).collect();
    let width = runs
        .iter()
        .map(|(label, _, _)| label.len() + 6)
        .max()
        .unwrap_or(0)
        .max(12);
    print!("  {:<34}", "step");
    for (label, _, _) in runs {
        print!("{:>width$}", format!("{label} (s)"));
    }
    println!("  runs on");
    for (k, phase) in base.iter().enumerate() {
        print!("  {:<34}", phase.name);
        for list in &by_run {
            print!("{:>width$.3}", list[k].time.as_secs_f64());
        }
        println!("  {}", if phase.one_thread { "one thread" } else { "all workers" });
    }
    print!("  {:<34}", "round (wall)");
    for (_, _, m) in runs {
        print!("{:>width$.3}", m.rounds_s);
    }
    println!();
    // Thread counts alone: "1 -> 2 threads"; with ways of sharing turns, the runs' labels.
    let by_threads_only = runs.iter().all(|(label, n, _)| *label == format!("{n} thr"));
    for (label, n, m) in &runs[1..] {
        let speedup = first.rounds_s / m.rounds_s;
        // The Karp-Flatt metric needs a one-thread baseline.
        let serial = karp_flatt(speedup, *n)
            .filter(|_| *first_threads == 1)
            .map_or(String::new(), |e| {
                format!(" (Karp-Flatt serial fraction {:.1} %)", 100.0 * e)
            });
        if by_threads_only {
            println!("  {first_threads} -> {n} threads: {speedup:.2}x{serial}");
        } else {
            println!("  {first_label} -> {label}: {speedup:.2}x{serial}");
        }
    }
    let s = sequential_share(&base);
    println!(
        "  sequential share on {first_threads} thread(s): s = {:.1} %; Amdahl allows at most {:.1}x on 4 cores, {:.1}x on 16, {:.1}x on 64",
        100.0 * s,
        amdahl(s, 4),
        amdahl(s, 16),
        amdahl(s, 64)
    );
}

fn any_angle(
    map: &std::path::Path,
    scen: Option<&std::path::Path>,
    queries: usize,
    radius_m: f64,
    seed: u64,
) -> Result<()> {
    let obstacles = scale::paths::load_map(map)?;
    let queries = match scen {
        Some(s) => scale::paths::read_scenario(s, &obstacles)?,
        None => scale::paths::random_queries(&obstacles, queries, seed),
    };
    let b = scale::paths::bench(&obstacles, &queries, radius_m)?;
    let excess = b.excess.map_or(String::new(), |(mean, worst)| {
        format!(
            " | excess over published optima: mean {:.2e} %, worst {:.2e} %",
            mean * 100.0,
            worst * 100.0
        )
    });
    // Point robots are planned by Anya, which links no corners.
    let graph = if radius_m > 0.0 {
        format!("all linked in {:.2} s: {} edges", b.link_s, b.edges)
    } else {
        "no visibility graph (Anya)".to_owned()
    };
    println!(
        "any-angle: {} | {} cells, {} leaves | {} corners found in {:.3} s, first query on a new planner {:.1} ms | {graph}, {:.1} MB | {} queries ({} reachable, {} disagree with the octile column), mean {:.3} ms, slowest {:.3} ms{excess}",
        map.display(),
        u64::from(obstacles.grid().width_cells()) * u64::from(obstacles.grid().height_cells()),
        obstacles.leaf_count(),
        b.vertices,
        b.build_s,
        b.cold_query_ms,
        b.memory_bytes as f64 / 1e6,
        b.queries,
        b.reachable,
        b.reachability_mismatches,
        b.mean_query_ms,
        b.max_query_ms,
    );
    Ok(())
}

fn nav_graph(map: &std::path::Path, queries: usize, radius_m: f64, compare_cells: u64, seed: u64) -> Result<()> {
    let obstacles = scale::paths::load_map(map)?;
    let queries = scale::paths::random_queries(&obstacles, queries, seed);
    let b = scale::paths::nav_bench(&obstacles, &queries, radius_m, compare_cells)?;
    let excess = b.excess.map_or(String::from(" | not compared with the exact planner"), |(n, mean, worst)| {
        format!(
            " | over {n} routes the exact planner also found: mean {:.2} %, worst {:.2} % longer than a point's optimum",
            mean * 100.0,
            worst * 100.0
        )
    });
    println!(
        "nav-graph: {} | {} leaves, {} free | {} pieces, {} edges, built in {:.2} s, {:.1} MB | {} queries ({} reachable) for radius {radius_m} m, mean {:.3} ms, slowest {:.3} ms{excess}",
        map.display(),
        obstacles.leaf_count(),
        b.free_leaves,
        b.pieces,
        b.edges,
        b.build_s,
        b.memory_bytes as f64 / 1e6,
        b.queries,
        b.reachable,
        b.mean_query_ms,
        b.max_query_ms,
    );
    Ok(())
}

/// The Fig. 4 runs (`quick`: 200 rounds, up to 200 robots) written into `out`.
fn fig4(out: &std::path::Path, quick: bool, plots: bool) -> Result<()> {
    let fig = if quick {
        Fig4 {
            rounds: 200,
            robot_counts: vec![10, 50, 100, 200],
            explored_counts: vec![10, 100],
            explored_rounds: 200,
            ..Fig4::default()
        }
    } else {
        Fig4::default()
    };
    let data = fig.run(|what| eprintln!("fig4: {what}"))?;
    for path in data.write(out, plots)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The comparison set of `exploration`, the maps whose name contains `only`.
fn exploration_maps(data: Option<&std::path::Path>, only: Option<&str>) -> Result<Vec<scale::exploration::NamedMap>> {
    let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let from_env = std::env::var_os("SMARTTEAMS_DATA").map(std::path::PathBuf::from);
    let data = data.map(std::path::Path::to_path_buf).or(from_env);
    let mut maps = scale::exploration::comparison_maps(&workspace, data.as_deref())?;
    let names: Vec<String> = maps.iter().map(|(n, _)| n.clone()).collect();
    maps.retain(|(n, _)| only.is_none_or(|o| n.contains(o)));
    if maps.is_empty() {
        anyhow::bail!(
            "--only {}: no map's name holds it (the maps: {})",
            only.unwrap_or_default(),
            names.join(", ")
        );
    }
    Ok(maps)
}

/// `a / b` of two milestones' distances, or `-`.
fn ratio(a: Option<(u64, f64)>, b: Option<(u64, f64)>) -> String {
    distance_ratio(a, b).map_or("-".to_owned(), |r| format!("{r:.2}"))
}

/// `a / b` of two milestones' distances, if both were reached.
fn distance_ratio(a: Option<(u64, f64)>, b: Option<(u64, f64)>) -> Option<f64> {
    match (a, b) {
        (Some((_, a)), Some((_, b))) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

/// `--param NAME=VALUE` as a pair.
fn parse_param(text: &str) -> std::result::Result<(String, String), String> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => Ok((name.trim().to_owned(), value.trim().to_owned())),
        _ => Err(format!("expected NAME=VALUE, got '{text}'")),
    }
}

/// The explorer `exploration` compares with the reference: a strategy and its parameters.
struct Compared {
    strategy: String,
    params: sim_core::agent::Params,
}

impl Compared {
    /// One run of it (see [`scale::exploration::explore_with`]).
    fn explore(
        &self,
        map: &std::sync::Arc<sim_core::world::MapData>,
        max_rounds: u64,
    ) -> Result<scale::exploration::Exploration> {
        scale::exploration::explore_with(map, &self.strategy, &self.params, 1, max_rounds)
    }
}

/// `exploration --starts K`: each map from home and from `k` points along the reference's
/// run, both explorers from each; the ratios of `strategy` to the reference at every start,
/// each map's means, and the means over every run; then, for each team size of `teams`, its
/// runs from every start against one `cooperative` robot's from the same start. With
/// `trace`, each start's walks are drawn there as `exploration`'s are from home.
fn exploration_from_starts(
    compared: &Compared,
    data: Option<&std::path::Path>,
    teams: &Teams,
    only: Option<&str>,
    k: usize,
    trace: Option<&std::path::Path>,
    max_rounds: u64,
) -> Result<()> {
    use scale::exploration::{GREEDY_REFERENCE, explore, starting_at, starts_along_the_reference};
    make_trace_folder(trace)?;
    let strategy = &compared.strategy;
    println!("map | mean ratio to 90 % / 98 % | ratio to 90 % / 98 % from home, then from each start");
    println!("(a milestone only one explorer reached: `{strategy} only` or `reference only`)");
    let (mut all90, mut all98) = (Vec::new(), Vec::new());
    let mut team_runs = Vec::new();
    for (name, map) in exploration_maps(data, only)? {
        let starts = starts_along_the_reference(&map, k, max_rounds)?;
        let maps = std::iter::once(std::sync::Arc::clone(&map)).chain(starts.iter().map(|&p| starting_at(&map, p)));
        let (mut cells, mut at90, mut at98) = (Vec::new(), Vec::new(), Vec::new());
        for (start, m) in maps.enumerate() {
            let start = if start == 0 {
                "home".to_owned()
            } else {
                format!("start {start}")
            };
            let traced_name = format!("{name} {start}");
            let (reference, built_in) = match trace {
                Some(dir) => traced_runs(compared, &traced_name, &m, max_rounds, dir)?,
                None => (
                    explore(&m, GREEDY_REFERENCE, 1, max_rounds)?,
                    compared.explore(&m, max_rounds)?,
                ),
            };
            let cell = |a, b| match (a, b) {
                (Some(_), None) => format!("{strategy} only"),
                (None, Some(_)) => "reference only".to_owned(),
                _ => ratio(a, b),
            };
            cells.push(format!(
                "{} / {}",
                cell(built_in.at_90, reference.at_90),
                cell(built_in.at_98, reference.at_98)
            ));
            at90.extend(distance_ratio(built_in.at_90, reference.at_90));
            at98.extend(distance_ratio(built_in.at_98, reference.at_98));
            let team_picture = trace.map(|dir| dir.join(format!("{}-teams.png", file_stem(&traced_name))));
            let runs = TeamRuns::run(&m, teams, max_rounds, team_picture.as_deref())?;
            team_runs.extend(runs.map(|r| (format!("{name} from {start}"), r)));
        }
        println!(
            "{name} | {} / {} | {}",
            mean(&at90, 2),
            mean(&at98, 2),
            cells.join(", ")
        );
        all90.extend(at90);
        all98.extend(at98);
    }
    let farther = |ratios: &[f64]| ratios.iter().filter(|&&r| r > 1.0).count();
    // Three decimals: rules compared from every start differ by a few thousandths.
    println!(
        "mean over every start: {} to 90 % ({} runs), {} to 98 % ({} runs); farther than the reference in {} and {} of them",
        mean(&all90, 3),
        all90.len(),
        mean(&all98, 3),
        all98.len(),
        farther(&all90),
        farther(&all98)
    );
    print_team_runs(&team_runs);
    Ok(())
}

/// The teams of `exploration`: their sizes (0s skipped) and their `cooperative` robots'
/// parameters.
struct Teams {
    sizes: Vec<u32>,
    params: sim_core::agent::Params,
}

/// One `cooperative` robot's run on a map and each team size's (0s skipped).
struct TeamRuns {
    solo: scale::exploration::Exploration,
    teams: Vec<(u32, scale::exploration::Exploration)>,
}

impl TeamRuns {
    /// The runs on `map`; `None` when `teams` holds no size. With `picture`, their walks
    /// are drawn there side by side, one robot's first.
    fn run(
        map: &std::sync::Arc<sim_core::world::MapData>,
        teams: &Teams,
        max_rounds: u64,
        picture: Option<&std::path::Path>,
    ) -> Result<Option<Self>> {
        use scale::exploration::{explore_traced, explore_with};
        if !teams.sizes.iter().any(|&n| n > 0) {
            return Ok(None);
        }
        let sizes = std::iter::once(1).chain(teams.sizes.iter().copied().filter(|&n| n > 0));
        let (mut runs, mut walks) = (Vec::new(), Vec::new());
        for n in sizes {
            if picture.is_some() {
                let (run, walked) = explore_traced(map, "cooperative", &teams.params, n, max_rounds)?;
                runs.push((n, run));
                walks.push(walked);
            } else {
                runs.push((n, explore_with(map, "cooperative", &teams.params, n, max_rounds)?));
            }
        }
        if let Some(path) = picture {
            let panels: Vec<_> = runs.iter().map(|(_, run)| run).zip(&walks).collect();
            save_picture(map, &panels, path)?;
        }
        let (_, solo) = runs.remove(0);
        Ok(Some(Self { solo, teams: runs }))
    }

    /// How many times fewer rounds `team` took to 90 % than the lone robot, and its summed
    /// distance there over the lone robot's (`None` where either fell short of 90 %).
    fn against_one(&self, team: &scale::exploration::Exploration) -> Option<(f64, f64)> {
        let ((r1, d1), (rn, dn)) = (self.solo.at_90?, team.at_90?);
        Some((r1 as f64 / rn as f64, dn / d1))
    }
}

/// Per team size: the mean speed-up over one robot, the runs faster than one robot (2
/// robots: at least 1.6× faster), and the runs whose summed distance is within 1.25× one
/// robot's, out of the runs that reached 90 %; then the runs (named) short of the speed-up.
fn print_team_runs(runs: &[(String, TeamRuns)]) {
    let mut sizes: Vec<u32> = runs.iter().flat_map(|r| r.1.teams.iter().map(|t| t.0)).collect();
    sizes.sort_unstable();
    sizes.dedup();
    for robots in sizes {
        let named: Vec<(&str, Option<(f64, f64)>)> = runs
            .iter()
            .flat_map(|(name, r)| {
                r.teams
                    .iter()
                    .filter(|t| t.0 == robots)
                    .map(|t| (name.as_str(), r.against_one(&t.1)))
            })
            .collect();
        let of_size: Vec<Option<(f64, f64)>> = named.iter().map(|n| n.1).collect();
        let speedups: Vec<f64> = of_size.iter().flatten().map(|r| r.0).collect();
        let ratios: Vec<f64> = of_size.iter().flatten().map(|r| r.1).collect();
        let bar = if robots == 2 { 1.6 } else { 1.0 };
        println!(
            "{robots} cooperative robots, {} runs ({} short of 90 %): mean {}x faster than one, {} runs at least {bar}x faster; summed distance mean {}x one's, {} runs within 1.25x",
            of_size.len(),
            of_size.len() - speedups.len(),
            mean(&speedups, 2),
            speedups.iter().filter(|&&x| x >= bar).count(),
            mean(&ratios, 2),
            ratios.iter().filter(|&&x| x <= 1.25).count()
        );
        let short: Vec<String> = named
            .iter()
            .filter_map(|&(name, r)| r.filter(|r| r.0 < bar).map(|r| format!("{name} ({:.2}x)", r.0)))
            .collect();
        if !short.is_empty() {
            println!("  short of {bar}x: {}", short.join(", "));
        }
    }
}

/// The mean of `xs` to `decimals` places, or `-`.
fn mean(xs: &[f64], decimals: usize) -> String {
    if xs.is_empty() {
        "-".to_owned()
    } else {
        format!("{:.decimals$}", xs.iter().sum::<f64>() / xs.len() as f64)
    }
}

/// The exploration-quality table (see `Scenario::Exploration`).
fn exploration(
    compared: &Compared,
    maps: &[scale::exploration::NamedMap],
    teams: &Teams,
    trace: Option<&std::path::Path>,
    max_rounds: u64,
) -> Result<()> {
    use scale::exploration::{GREEDY_REFERENCE, explore};
    make_trace_folder(trace)?;
    let strategy = &compared.strategy;
    println!(
        "map | reference m to 90 % / 98 % | {strategy} m to 90 % / 98 % | ratio 90 / 98 | teams: rounds to 90 % (x faster than 1), summed m, overlap"
    );
    let (mut sum90, mut n90) = (0.0, 0);
    for (name, map) in maps {
        let (reference, built_in) = match trace {
            Some(dir) => traced_runs(compared, name, map, max_rounds, dir)?,
            None => (
                explore(map, GREEDY_REFERENCE, 1, max_rounds)?,
                compared.explore(map, max_rounds)?,
            ),
        };
        if let (Some((_, a)), Some((_, b))) = (built_in.at_90, reference.at_90) {
            sum90 += a / b;
            n90 += 1;
        }
        let team_picture = trace.map(|dir| dir.join(format!("{}-teams.png", file_stem(name))));
        let team_cells = team_cells(map, teams, max_rounds, team_picture.as_deref())?;
        println!(
            "{name} | {} / {} | {} / {} | {} / {} | {}",
            metres(reference.at_90),
            metres(reference.at_98),
            metres(built_in.at_90),
            metres(built_in.at_98),
            ratio(built_in.at_90, reference.at_90),
            ratio(built_in.at_98, reference.at_98),
            team_cells
        );
    }
    if n90 > 0 {
        println!("mean ratio to 90 %: {:.2} over {n90} maps", sum90 / f64::from(n90));
    }
    Ok(())
}

/// Make `exploration --trace`'s folder, if asked for; an error names it.
fn make_trace_folder(trace: Option<&std::path::Path>) -> Result<()> {
    if let Some(dir) = trace {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot make the folder {}", dir.display()))?;
    }
    Ok(())
}

/// The reference's and `compared`'s runs on `map`, the same runs as untraced, with the
/// picture of both walks ([`scale::trace::picture`]) written to `dir/NAME.png`.
fn traced_runs(
    compared: &Compared,
    name: &str,
    map: &std::sync::Arc<sim_core::world::MapData>,
    max_rounds: u64,
    dir: &std::path::Path,
) -> Result<(scale::exploration::Exploration, scale::exploration::Exploration)> {
    use scale::exploration::{GREEDY_REFERENCE, explore_traced};
    let (reference, reference_walks) = explore_traced(
        map,
        GREEDY_REFERENCE,
        &sim_core::agent::Params::default(),
        1,
        max_rounds,
    )?;
    let (built_in, walks) = explore_traced(map, &compared.strategy, &compared.params, 1, max_rounds)?;
    let path = dir.join(format!("{}.png", file_stem(name)));
    save_picture(map, &[(&reference, &reference_walks), (&built_in, &walks)], &path)?;
    Ok((reference, built_in))
}

/// The picture of `runs` on `map` ([`scale::trace::picture`]) written to `path`.
fn save_picture(
    map: &sim_core::world::MapData,
    runs: &[(&scale::exploration::Exploration, &scale::exploration::Walks)],
    path: &std::path::Path,
) -> Result<()> {
    scale::trace::picture(map, runs)
        .save(path)
        .with_context(|| format!("cannot write the picture {}", path.display()))?;
    eprintln!("exploration: {}", path.display());
    Ok(())
}

/// A map's name as a file name: lower case, a dash for each run of other characters than
/// letters and digits ("depot (ROS)" → "depot-ros").
fn file_stem(name: &str) -> String {
    let lower = name.to_lowercase();
    let words: Vec<&str> = lower
        .split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    words.join("-")
}

/// Metres walked by a milestone, or `-`.
fn metres(at: Option<(u64, f64)>) -> String {
    at.map_or("-".to_owned(), |(_, d)| format!("{d:.1}"))
}

/// The teams' cell of the exploration table: one `cooperative` robot's rounds and metres to
/// 90 %, then each team size of `teams` with its speed-up, summed metres and overlap (empty
/// when `teams` holds no size); with `picture`, the runs' walks drawn there.
fn team_cells(
    map: &std::sync::Arc<sim_core::world::MapData>,
    teams: &Teams,
    max_rounds: u64,
    picture: Option<&std::path::Path>,
) -> Result<String> {
    let Some(runs) = TeamRuns::run(map, teams, max_rounds, picture)? else {
        return Ok(String::new());
    };
    let rounds = |at: Option<(u64, f64)>| at.map_or("-".into(), |(r, _)| r.to_string());
    let mut cells = vec![format!("1: {}, {}", rounds(runs.solo.at_90), metres(runs.solo.at_90))];
    for (n, team) in &runs.teams {
        let speedup = runs
            .against_one(team)
            .map_or(String::new(), |(x, _)| format!(" ({x:.2}x)"));
        cells.push(format!(
            "{n}: {}{speedup}, {}, {:.0} % overlap",
            rounds(team.at_90),
            metres(team.at_90),
            100.0 * team.overlap_m / team.distance_m.max(1e-9)
        ));
    }
    Ok(cells.join("; "))
}
