//! Resolved run settings and the run itself.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use sim_core::agent::StrategyRegistry;
use sim_core::engine::{CoreLoan, Simulation, TurnSharing, with_hot_workers_lending};
use sim_core::io::Observer;
use sim_core::io::{Checkpoint, CheckpointWriter, RunSource, SimConfig};
use sim_core::io::{MetricsCsv, write_robot_stats};
use sim_core::spatial::RobotId;
use sim_core::world::{EXPLORED_MILESTONES, Event, MapData, RoundMetrics, RoundReport};

use crate::priority::LoggingWait;
use crate::progress::Progress;
use crate::rerun_observer::{LogOptions, RerunObserver, WhenBehind};
use crate::stop::Signal;
use crate::viewer::ViewerTarget;

/// Everything a run needs, checked before it starts.
#[derive(Clone, Debug)]
pub struct RunConfig {
    /// The parsed config, with command-line overrides applied.
    pub config: SimConfig,
    /// Worker threads for the decide phase (`None`: one per core).
    pub threads: Option<usize>,
    /// How step 3 shares its turns among the workers.
    pub turn_sharing: TurnSharing,
    /// Decisions slower than this are reported (`None`: not timed).
    pub decide_limit: Option<Duration>,
    /// Per-round metrics CSV.
    pub metrics: Option<PathBuf>,
    /// Per-robot statistics CSV.
    pub robot_stats: Option<PathBuf>,
    /// Show a progress bar (when stderr is a terminal).
    pub progress: bool,
    /// Where the Rerun recording goes (`None`: no recording).
    pub viewer: Option<ViewerTarget>,
    /// How much the recording holds.
    pub log: LogOptions,
    /// Checkpoints to write, and the one this run resumes from.
    pub checkpoint: Option<CheckpointPlan>,
}

/// Where and how often a run writes checkpoints, and the checkpoint it continues.
#[derive(Clone, Debug)]
pub struct CheckpointPlan {
    /// The checkpoint file (replaced at every checkpoint).
    pub path: PathBuf,
    /// Rounds between checkpoints.
    pub every_rounds: u64,
    /// How the run was set up (stored in every checkpoint).
    pub source: RunSource,
    /// The checkpoint this run continues (`smartteams resume`), read and checked.
    pub resume_from: Option<Arc<Checkpoint>>,
}

/// What a finished run reports.
#[derive(Clone, Debug)]
pub struct Summary {
    /// Run name.
    pub name: String,
    /// Rounds played (those before a checkpoint it resumed from included).
    pub rounds: u64,
    /// The checkpoint's round, for a resumed run (the rounds before it were played by
    /// the run that wrote it; the rate counts only those played here).
    pub resumed_at: Option<u64>,
    /// Robots.
    pub robots: usize,
    /// Final metrics.
    pub metrics: sim_core::world::RoundMetrics,
    /// [`Simulation::positions_digest`] at the end: equal digests, identical final positions.
    pub digest: u64,
    /// Wall time of the rounds (set-up excluded).
    pub elapsed: Duration,
    /// Wall time of loading and set-up.
    pub setup: Duration,
    /// Where the recording went and what it cost.
    pub recording: Option<RecordingSummary>,
    /// Decisions that took longer than the limit, and the slowest (robot, round, time).
    pub slow_decisions: (u64, Option<(RobotId, u64, Duration)>),
    /// The signal that stopped the run before its last round, if one did.
    pub interrupted: Option<Signal>,
    /// The files written beside the recording: (what, path) for the metrics CSV, the robot
    /// statistics and the checkpoint.
    pub files: Vec<(&'static str, PathBuf)>,
}

/// What the recording of a run holds and cost.
#[derive(Clone, Debug)]
pub struct RecordingSummary {
    /// Where it went.
    pub target: ViewerTarget,
    /// Rounds whose world state was logged (round 0 included).
    pub logged_rounds: u64,
    /// Rounds whose world was left out because a live viewer fell behind.
    pub skipped_rounds: u64,
    /// Time the simulation thread spent copying rounds for the logger.
    pub sim_thread: Duration,
    /// Time the end of the run waited for the logging thread and the stream to finish.
    pub closing: Duration,
    /// Time the logging thread spent building and logging archetypes.
    pub logging_thread: Duration,
    /// The round at which a live viewer was found gone; nothing was logged from it on.
    pub viewer_lost_at: Option<u64>,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let secs = self.elapsed.as_secs_f64();
        let played = self.rounds - self.resumed_at.unwrap_or(0);
        let resumed = self.resumed_at.map_or(String::new(), |k| {
            format!(" (resumed at round {k}: {played} played now)")
        });
        writeln!(
            f,
            "{}: {} rounds{resumed} with {} robots in {:.2} s ({:.1} rounds/s; set-up {:.2} s)",
            self.name,
            self.rounds,
            self.robots,
            secs,
            played as f64 / secs.max(1e-9),
            self.setup.as_secs_f64()
        )?;
        if let Some(stop) = self.stop_note() {
            writeln!(f, "  {stop}")?;
        }
        self.write_world(f)?;
        self.write_run_notes(f)
    }
}

impl Summary {
    /// Where a run stopped by a signal stopped (`None` for a run that played to its end).
    pub fn stop_note(&self) -> Option<String> {
        self.interrupted.map(|signal| {
            format!(
                "interrupted at round {} by {} (what was played is kept)",
                self.rounds,
                signal.name()
            )
        })
    }

    /// The lines of what the robots did: exploration, treasures, robots, distance and the
    /// digest (the last without a line break).
    fn write_world(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = &self.metrics;
        writeln!(
            f,
            "  explored          {:.1} % of the free area; {}",
            100.0 * m.explored_fraction,
            milestones(m)
        )?;
        writeln!(
            f,
            "  treasures         {} found, {} excavated, {} delivered ({} units dug, {} delivered)",
            m.treasures_found, m.treasures_excavated, m.treasures_delivered, m.units_dug, m.units_delivered
        )?;
        writeln!(
            f,
            "  robots alive      {} (mean energy {:.1})",
            m.robots_alive, m.mean_energy
        )?;
        writeln!(
            f,
            "  distance          {:.1} m in all, {:.1} m ({:.1} %) through explored ground",
            m.distance_m,
            m.overlap_m,
            100.0 * m.overlap_m / m.distance_m.max(1e-9)
        )?;
        write!(f, "  digest            {:016x} (final positions)", self.digest)
    }

    /// The lines only some runs have, each after a line break: failed strategies, slow
    /// decisions, files written and the recording.
    fn write_run_notes(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = &self.metrics;
        if m.strategies_failed > 0 {
            write!(
                f,
                "\n  failed            {} robots disabled because their strategy panicked (see the event log)",
                m.strategies_failed
            )?;
        }
        if let (n, Some((robot, round, took))) = self.slow_decisions {
            write!(
                f,
                "\n  slow decisions    {n} over the limit; slowest: robot {robot}, round {round}, {:.3} s",
                took.as_secs_f64()
            )?;
        }
        if !self.files.is_empty() {
            let files: Vec<String> = self
                .files
                .iter()
                .map(|(what, path)| format!("{what} {}", path.display()))
                .collect();
            write!(f, "\n  written           {}", files.join(", "))?;
        }
        if let Some(r) = &self.recording {
            write!(
                f,
                "\n  recording         {} ({} rounds of world state; logging {:.2} s on the simulation thread, {:.2} s on the logging thread, {:.2} s closing)",
                r.target,
                r.logged_rounds,
                r.sim_thread.as_secs_f64(),
                r.logging_thread.as_secs_f64(),
                r.closing.as_secs_f64()
            )?;
            if r.skipped_rounds > 0 {
                write!(
                    f,
                    "\n  viewer behind     the world of {} rounds was left out (metrics and events were sent)",
                    r.skipped_rounds
                )?;
            }
            if let Some(round) = r.viewer_lost_at {
                write!(
                    f,
                    "\n  viewer gone       at round {round}: the rounds from it on were played, not logged"
                )?;
            }
        }
        Ok(())
    }
}

/// The metrics of the last round played: from the checkpoint a run resumed from when it
/// played no round after it (a checkpoint of the final round), whose simulation holds no
/// round's report.
fn last_metrics(sim: &Simulation, resumed: Option<&Checkpoint>) -> RoundMetrics {
    match resumed
        .filter(|c| c.round() == sim.round())
        .and_then(|c| c.metrics().last())
    {
        Some(m) => *m,
        None => sim.report().metrics,
    }
}

/// When the run first had 50, 90 and 98 % of the free area explored: "50 % at round R
/// (D m walked)", or "not reached".
fn milestones(m: &RoundMetrics) -> String {
    EXPLORED_MILESTONES
        .iter()
        .zip(m.explored_milestones())
        .map(|(fraction, reached)| {
            let percent = (fraction * 100.0).round();
            match reached {
                Some((round, distance_m)) => format!("{percent} % at round {round} ({distance_m:.1} m walked)"),
                None => format!("{percent} % not reached"),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Run a resolved config with the built-in observers plus `extra` (viewers).
pub fn execute(
    run: &RunConfig,
    registry: &StrategyRegistry,
    extra: &mut [&mut (dyn Observer + Send)],
) -> Result<Summary> {
    check_outputs_apart(run)?;
    let started = Instant::now();
    let resumed = run.checkpoint.as_ref().and_then(|c| c.resume_from.as_deref());
    let mut sim = build_simulation(run, registry, resumed)?;
    let setup = started.elapsed();
    let mut outputs = Outputs::open(run, &sim, resumed)?;
    let pool = start_workers(run.threads)?;
    // The workers keep their cores between rounds (see `with_hot_workers`), lending them to
    // the recording's logging thread while it has work; viewers of the caller's are not
    // known to lend them back, so with those the workers sleep between parallel steps.
    let loan = extra.is_empty().then(|| Arc::new(CoreLoan::default()));
    if let Some(loan) = &loan {
        outputs.rerun = outputs.rerun.take().map(|r| r.with_core_loan(Arc::clone(loan)));
    }
    let t0 = Instant::now();
    let result = run_rounds(&mut sim, &pool, loan.as_deref(), &mut outputs.observers(extra));
    let elapsed = t0.elapsed();
    // Whatever happened, keep the outputs of the rounds that were played; a run that ends,
    // or is stopped by a signal, also writes its checkpoint, whatever the round, so even a
    // run shorter than `--checkpoint-every` can be resumed.
    if result.is_ok()
        && let Some(c) = outputs.checkpoints.as_mut()
    {
        c.write_now(&sim)?;
    }
    outputs.keep(run, &sim)?;
    let interrupted = result
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("run stopped at round {}", sim.round()))?;
    let mut summary = outputs.summary(run, &sim, resumed, setup, elapsed);
    summary.interrupted = interrupted;
    Ok(summary)
}

/// Refuse a run whose output files name one file twice, or a file the run reads (its config
/// or its map): see [`refuse_overwriting`].
fn check_outputs_apart(run: &RunConfig) -> Result<()> {
    let mut outputs: Vec<(&str, &Path)> = Vec::new();
    if let Some(p) = &run.metrics {
        outputs.push(("metrics file", p));
    }
    if let Some(p) = &run.robot_stats {
        outputs.push(("robot stats file", p));
    }
    if let Some(ViewerTarget::Rrd(p)) = &run.viewer {
        outputs.push(("recording", p));
    }
    if let Some(c) = &run.checkpoint {
        outputs.push(("checkpoint", &c.path));
    }
    refuse_overwriting(
        &outputs,
        &[("config", &run.config.path), ("map", run.config.map_path())],
    )
}

/// Refuse `outputs` (what each is, its path) that name one file twice or a file of `inputs`:
/// one would overwrite the other, and swapped arguments would destroy an input. Paths to
/// one file through links or `..` count as one.
pub fn refuse_overwriting(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<()> {
    let keys: Vec<PathBuf> = outputs.iter().map(|(_, p)| file_identity(p)).collect();
    for (k, &(what, path)) in outputs.iter().enumerate() {
        if let Some(j) = keys[..k].iter().position(|key| *key == keys[k]) {
            bail!(
                "the {} and the {what} are both {}: one would overwrite the other",
                outputs[j].0,
                path.display()
            );
        }
        if let Some((input, _)) = inputs.iter().find(|(_, p)| file_identity(p) == keys[k]) {
            bail!(
                "the {what} {} is the run's {input}: writing it would destroy it",
                path.display()
            );
        }
    }
    Ok(())
}

/// What names a file, whether it exists or not, for telling two paths to one file apart
/// from paths to two: the file with links resolved if it exists, else its folder's.
pub(crate) fn file_identity(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let folder = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    match (std::fs::canonicalize(folder), path.file_name()) {
        (Ok(folder), Some(name)) => folder.join(name),
        _ => sim_core::absolute(path),
    }
}

/// The simulation of a run: continued from the checkpoint `resumed`, or set up from the config.
fn build_simulation(run: &RunConfig, registry: &StrategyRegistry, resumed: Option<&Checkpoint>) -> Result<Simulation> {
    let sim = match resumed {
        Some(checkpoint) => checkpoint.resume(&run.config, registry)?,
        None => Simulation::new(run.config.scenario(registry)?)
            .with_context(|| format!("setting up {}", run.config.path.display()))?,
    };
    Ok(sim
        .with_decide_limit(run.decide_limit)
        .with_turn_sharing(run.turn_sharing))
}

/// The worker threads of the decide phase (`None`: one per core).
fn start_workers(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}

/// The built-in observers of a run: its output files, its recording and what it tells the
/// user. Fields drop in declaration order, so the recording is dropped before the files.
struct Outputs {
    faults: Faults,
    progress: Progress,
    rerun: Option<RerunObserver>,
    checkpoints: Option<CheckpointWriter>,
    metrics: Option<MetricsCsv<BufWriter<File>>>,
    /// The robot-stats file, created before the first round and written at the end.
    robot_stats: Option<File>,
}

impl Outputs {
    /// Open the outputs in this order: the metrics CSV (with the rows of the rounds before a
    /// resumed checkpoint), the checkpoint writer, the recording, the progress bar.
    fn open(run: &RunConfig, sim: &Simulation, resumed: Option<&Checkpoint>) -> Result<Self> {
        let rows_before = resumed.map_or(&[][..], Checkpoint::metrics);
        let metrics = match &run.metrics {
            Some(p) => Some(MetricsCsv::with_rows(
                BufWriter::new(File::create(p).with_context(|| format!("cannot create metrics file {}", p.display()))?),
                rows_before,
            )?),
            None => None,
        };
        if let Some(message) = run
            .checkpoint
            .as_ref()
            .and_then(|c| crate::missing_folder("checkpoint", &c.path))
        {
            bail!(message);
        }
        let checkpoints = run
            .checkpoint
            .as_ref()
            .map(|c| CheckpointWriter::new(c.path.clone(), c.every_rounds, c.source.clone(), rows_before.to_vec()));
        // Created now, written at the end: a path that cannot be written is found before
        // the rounds are played, not after.
        let robot_stats = match &run.robot_stats {
            Some(p) => {
                Some(File::create(p).with_context(|| format!("cannot create robot stats file {}", p.display()))?)
            }
            None => None,
        };
        let rerun = match &run.viewer {
            Some(target) => Some(open_recording(sim, target, run.log)?),
            None => None,
        };
        Ok(Self {
            faults: Faults::default(),
            progress: Progress::new(run.progress, sim.round(), sim.total_rounds()),
            rerun,
            checkpoints,
            metrics,
            robot_stats,
        })
    }

    /// The observers in the order they are called: the built-in ones, then `extra`.
    fn observers<'a>(&'a mut self, extra: &'a mut [&mut (dyn Observer + Send)]) -> Vec<&'a mut (dyn Observer + Send)> {
        let mut observers: Vec<&mut (dyn Observer + Send)> = vec![&mut self.faults];
        if let Some(m) = self.metrics.as_mut() {
            observers.push(m);
        }
        if let Some(c) = self.checkpoints.as_mut() {
            observers.push(c);
        }
        observers.push(&mut self.progress);
        if let Some(r) = self.rerun.as_mut() {
            observers.push(r);
        }
        for o in extra.iter_mut() {
            observers.push(&mut **o);
        }
        observers
    }

    /// Flush the metrics CSV and write the robot statistics, whether or not the rounds ended
    /// well, so the rounds that were played are kept.
    fn keep(&mut self, run: &RunConfig, sim: &Simulation) -> Result<()> {
        if let Some(m) = self.metrics.as_mut() {
            sim_core::io::Observer::on_finish(m, sim).ok();
        }
        if let (Some(p), Some(file)) = (&run.robot_stats, self.robot_stats.take()) {
            write_robot_stats(sim, BufWriter::new(file)).with_context(|| format!("writing {}", p.display()))?;
        }
        Ok(())
    }

    /// What the finished run reports; `setup` and `elapsed` are the wall times of set-up and
    /// of the rounds.
    fn summary(
        self,
        run: &RunConfig,
        sim: &Simulation,
        resumed: Option<&Checkpoint>,
        setup: Duration,
        elapsed: Duration,
    ) -> Summary {
        Summary {
            name: sim.name().to_owned(),
            rounds: sim.round(),
            resumed_at: resumed.map(Checkpoint::round),
            robots: sim.robots().len(),
            metrics: last_metrics(sim, resumed),
            digest: sim.positions_digest(),
            elapsed,
            setup,
            recording: self.rerun.zip(run.viewer.clone()).map(|(r, target)| RecordingSummary {
                target,
                logged_rounds: r.logged_rounds(),
                skipped_rounds: r.skipped_rounds(),
                sim_thread: r.busy(),
                closing: r.closing(),
                logging_thread: r.worker_busy(),
                viewer_lost_at: r.viewer_lost_at(),
            }),
            slow_decisions: (self.faults.slow, self.faults.slowest),
            interrupted: None,
            files: [
                ("metrics", run.metrics.clone()),
                ("robot stats", run.robot_stats.clone()),
                (
                    "checkpoint",
                    run.checkpoint
                        .as_ref()
                        .filter(|_| self.checkpoints.as_ref().is_some_and(|c| c.written() > 0))
                        .map(|c| c.path.clone()),
                ),
            ]
            .into_iter()
            .filter_map(|(what, path)| Some((what, path?)))
            .collect(),
        }
    }
}

/// The Rerun recording of `sim` at `target`, logging what `log` asks for: a file's waits
/// for it from its opening, a live viewer's left behind when it falls behind.
pub fn open_recording(sim: &Simulation, target: &ViewerTarget, log: LogOptions) -> Result<RerunObserver> {
    let opening = LoggingWait::begin();
    let (rec, link) = crate::viewer::open(sim.name(), target, crate::blueprint::simulation())?;
    let observer = RerunObserver::new(rec, log);
    let observer = match link {
        Some(link) => observer.with_viewer(link),
        None => observer,
    };
    // A file writer always catches up, and the run waits for it from its opening; a live
    // viewer may be slow or paused, and connecting to it waits on the network.
    Ok(match target {
        ViewerTarget::Rrd(path) => observer
            .with_opening(&opening)
            .with_when_behind(WhenBehind::Wait)
            .with_file(path.clone()),
        ViewerTarget::Connect(_) | ViewerTarget::Spawn { .. } => observer.with_when_behind(WhenBehind::SkipWorld),
    })
}

/// Tells the user, on stderr, about robots whose strategy failed or was slow (the first
/// few of each; the summary counts them all).
#[derive(Default)]
struct Faults {
    failed: u64,
    slow: u64,
    slowest: Option<(RobotId, u64, Duration)>,
}

/// Faults of each kind told one by one before only counting.
const FAULTS_TOLD: u64 = 5;

impl Observer for Faults {
    fn on_round(&mut self, _sim: &Simulation, report: &RoundReport) -> Result<(), sim_core::io::ObserverError> {
        for e in &report.events {
            if let Event::StrategyFailed { .. } = e {
                self.failed += 1;
                if self.failed <= FAULTS_TOLD {
                    eprintln!("warning: round {}: {e}; the run goes on", report.round);
                }
            }
        }
        for &(robot, took) in &report.slow_decisions {
            self.slow += 1;
            if self.slow <= FAULTS_TOLD {
                eprintln!(
                    "warning: round {}: robot {robot}'s strategy took {:.3} s to decide",
                    report.round,
                    took.as_secs_f64()
                );
            }
            if self.slowest.is_none_or(|(_, _, t)| took > t) {
                self.slowest = Some((robot, report.round, took));
            }
        }
        Ok(())
    }
}

/// Show the map at `path` alone in Rerun (`smartteams view`).
pub fn view_map(path: &std::path::Path, target: &ViewerTarget) -> Result<()> {
    let map = MapData::load(path)?;
    let name = path
        .file_stem()
        .map_or_else(|| "map".into(), |s| s.to_string_lossy().into_owned());
    let (rec, _) = crate::viewer::open(&name, target, crate::blueprint::map_only())?;
    crate::layers::log_static_map(&rec, &map)?;
    crate::layers::log_static_treasures(&rec, &map)?;
    rec.flush_with_timeout(Duration::from_secs(10))
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("sending the map to {target}"))?;
    Ok(())
}

/// Play the remaining rounds on `pool`, notifying the observers, until the last round or a
/// stop signal ([`crate::stop`]): the round in progress is finished, and the observers are
/// told the run ended either way. Returns the signal, if one stopped the run.
///
/// With a `loan`, the rounds run on the pool with its workers kept awake between parallel
/// steps and lending their cores on `loan` ([`with_hot_workers_lending`]), as
/// `smartteams-bench` runs; otherwise each round wakes them. The results are the same. The
/// end (flushing and closing a recording) comes after the polling: the idle cores then go
/// to the recording's threads and a viewer on this machine.
fn run_rounds(
    sim: &mut Simulation,
    pool: &rayon::ThreadPool,
    loan: Option<&CoreLoan>,
    observers: &mut [&mut (dyn Observer + Send)],
) -> Result<Option<Signal>, sim_core::io::ObserverError> {
    if let Some(loan) = loan {
        pool.install(|| {
            let played = with_hot_workers_lending(loan, || {
                play_rounds(sim, observers, |sim| {
                    sim.step();
                })
            })?;
            finish_rounds(sim, observers, played)
        })
    } else {
        let played = play_rounds(sim, observers, |sim| {
            pool.install(|| {
                sim.step();
            });
        })?;
        finish_rounds(sim, observers, played)
    }
}

/// How the rounds of [`play_rounds`] ended: the signal that stopped them, and the first
/// observer error of a round.
type Played = (Option<Signal>, Option<sim_core::io::ObserverError>);

/// The loop of [`run_rounds`], each round played by `step`, after telling the observers the
/// run starts (an error there ends the run before any round, with nothing to finish).
fn play_rounds(
    sim: &mut Simulation,
    observers: &mut [&mut (dyn Observer + Send)],
    mut step: impl FnMut(&mut Simulation),
) -> Result<Played, sim_core::io::ObserverError> {
    for o in observers.iter_mut() {
        o.on_start(sim)?;
    }
    let mut stopped = None;
    let mut failed = None;
    'rounds: while sim.round() < sim.total_rounds() {
        if let Some(signal) = crate::stop::requested() {
            stopped = Some(signal);
            break;
        }
        step(sim);
        for o in observers.iter_mut() {
            if let Err(e) = o.on_round(sim, sim.report()) {
                failed = Some(e);
                break 'rounds;
            }
        }
    }
    Ok((stopped, failed))
}

/// Tell every observer the run ended, even after one failed, so that the others close what
/// they wrote (a recording's footer); the first error is the one reported.
fn finish_rounds(
    sim: &Simulation,
    observers: &mut [&mut (dyn Observer + Send)],
    (stopped, mut failed): Played,
) -> Result<Option<Signal>, sim_core::io::ObserverError> {
    for o in observers.iter_mut() {
        let finished = o.on_finish(sim);
        if failed.is_none() {
            failed = finished.err();
        }
    }
    failed.map_or(Ok(stopped), Err)
}
