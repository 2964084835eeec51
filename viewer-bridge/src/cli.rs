//! The `smartteams` command line: raw arguments → validated [`RunConfig`] → [`execute`].

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use sim_core::agent::StrategyRegistry;
use sim_core::engine::TurnSharing;
use sim_core::io::{Checkpoint, RunOutputs, RunSource, SimConfig};

use crate::rerun_observer::LogOptions;
use crate::run::{CheckpointPlan, RunConfig, execute};
use crate::viewer::{DEFAULT_CONNECT_URL, ViewerTarget, connect_url};

/// Smart Teams: simulate robot swarms exploring unknown terrain.
#[derive(Debug, Parser)]
#[command(name = "smartteams", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// `println!` that ends the process quietly once standard output's reader has gone
/// (`smartteams strategies | head -1`), where `println!` would panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*)
            && e.kind() == std::io::ErrorKind::BrokenPipe
        {
            std::process::exit(0);
        }
    }};
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a simulation described by an XML config.
    // Negative numbers are values, so `--rounds -5` is refused as a bad number rather than
    // as an unknown option.
    #[command(allow_negative_numbers = true)]
    Run(RunArgs),
    /// Continue a run from its checkpoint (`run --checkpoint`) to the end it would have had.
    #[command(allow_negative_numbers = true)]
    #[command(mut_arg("rrd", |a| a.help(RESUME_RRD_HELP)))]
    #[command(mut_arg("log_every", defaults_as_the_run))]
    #[command(mut_arg("known_every", defaults_as_the_run))]
    #[command(mut_arg("known_per_robot_max", defaults_as_the_run))]
    #[command(mut_arg("explored_every", defaults_as_the_run))]
    #[command(mut_arg("max_links", defaults_as_the_run))]
    Resume(ResumeArgs),
    /// Show a map alone in Rerun (obstacles, home, treasures; 2D and 3D).
    #[command(mut_arg("rrd", |a| a.help(VIEW_RRD_HELP)))]
    #[command(mut_arg("no_viewer", |a| a.hide(true)))]
    View(ViewArgs),
    /// List the strategies this build knows.
    Strategies,
    /// List the tactics a `strategy="tactics"` group can be composed of.
    Tactics,
    /// Run every combination of a sweep file's values headless, on all cores, into one CSV.
    #[command(allow_negative_numbers = true)]
    Sweep(crate::sweep::SweepArgs),
    /// Join the CSVs of a sweep's shards into the CSV a single-machine sweep writes.
    Merge(crate::sweep::MergeArgs),
    /// Draw explored fraction, treasures delivered, energy and known-map memory against
    /// rounds (or distance walked, `--x distance`) from metrics or sweep CSVs (PNG or SVG):
    /// mean and spread over seeds.
    Plot(PlotArgs),
}

/// `resume --rrd`: where a resumed run records when no viewer option is given.
const RESUME_RRD_HELP: &str = "Write the recording to this `.rrd` file. The default when no other viewer option is \
     given: where the run that wrote the checkpoint recorded, a file beside its recording \
     (`x.rrd` → `x-from-<round>.rrd`) or the same viewer; none if it recorded nothing";

/// `view --rrd`: where `view` records when no viewer option is given.
const VIEW_RRD_HELP: &str = "Write the recording to this `.rrd` file. The default when no other viewer option is \
     given: `<map stem>-map.rrd` in the working directory";

/// A logging option of `resume`: its default is the run's, not `run`'s.
fn defaults_as_the_run(arg: clap::Arg) -> clap::Arg {
    let help = arg.get_help().map(ToString::to_string).unwrap_or_default();
    let body = help
        .split(" [default:")
        .next()
        .unwrap_or_default()
        .trim_end_matches('.');
    arg.help(format!("{body} [default: as the run that wrote the checkpoint]"))
}

/// Arguments of `smartteams plot`.
#[derive(Debug, clap::Args)]
pub struct PlotArgs {
    /// Metrics CSVs (`run --metrics`) or sweep CSVs; a sweep's runs are grouped by the values
    /// it varies, seeds pooled.
    #[arg(required = true, value_name = "METRICS.csv")]
    pub inputs: Vec<PathBuf>,
    /// The figure (`.png` or `.svg`).
    #[arg(short, long, value_name = "FIG.png")]
    pub output: PathBuf,
    /// Size in pixels, `WIDTHxHEIGHT`.
    #[arg(long, value_name = "WxH", default_value = "1400x900", value_parser = parse_size)]
    pub size: (u32, u32),
    /// What the charts run along: rounds, or metres walked by all robots (explored fraction
    /// against distance walked, for comparing explorers).
    #[arg(long, value_enum, default_value_t)]
    pub x: crate::plot::XAxis,
}

/// `1400x900` → (1400, 900).
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("a size is WIDTHxHEIGHT in pixels, e.g. 1400x900; got '{s}'");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    ))
}

/// Draw a figure and say what it holds.
fn plot(inputs: &[PathBuf], output: &std::path::Path, size: (u32, u32), x: crate::plot::XAxis) -> Result<()> {
    let s = crate::plot::metrics_figure(inputs, output, size, x)?;
    say!(
        "{}: {} charts, {} lines each ({} runs): {}{}",
        output.display(),
        s.charts,
        s.groups.len(),
        s.runs,
        s.groups.join("; "),
        if s.labelled {
            ""
        } else {
            " (no font found: drawn without labels)"
        }
    );
    Ok(())
}

/// Where a recording goes (shared by `run` and `view`).
#[derive(Debug, Default, clap::Args)]
pub struct ViewerArgs {
    /// Write the recording to this `.rrd` file. The default when no other viewer option is
    /// given: the config's `<outputs rrd=…>`, else `<run name>.rrd` in the working directory.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["connect", "spawn", "no_viewer"])]
    pub rrd: Option<PathBuf>,
    /// Stream live to a running Rerun viewer (`--connect` alone: this machine, default port;
    /// `--connect=HOST:PORT` or `--connect=rerun+http://HOST:PORT/proxy`).
    #[arg(
        long,
        value_name = "URL",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = DEFAULT_CONNECT_URL,
        conflicts_with_all = ["spawn", "no_viewer"]
    )]
    pub connect: Option<String>,
    /// Start a local Rerun viewer (`rerun` on PATH) and stream to it (`--spawn` alone: the
    /// default port 9876; `--spawn=PORT` another).
    #[arg(
        long,
        value_name = "PORT",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "9876",
        conflicts_with = "no_viewer"
    )]
    pub spawn: Option<u16>,
    /// Log nothing to Rerun.
    #[arg(long)]
    pub no_viewer: bool,
}

impl ViewerArgs {
    /// The target these options ask for; `default_rrd` when none is given. Fails on a
    /// `--connect` value that is no viewer address.
    pub fn target(&self, default_rrd: PathBuf) -> Result<Option<ViewerTarget>> {
        Ok(if self.no_viewer {
            None
        } else if let Some(url) = &self.connect {
            Some(ViewerTarget::Connect(connect_url(url)?))
        } else if let Some(port) = self.spawn {
            Some(ViewerTarget::Spawn { port })
        } else {
            Some(ViewerTarget::Rrd(self.rrd.clone().unwrap_or(default_rrd)))
        })
    }

    /// Whether no viewer option was given.
    fn is_unset(&self) -> bool {
        self.rrd.is_none() && self.connect.is_none() && self.spawn.is_none() && !self.no_viewer
    }

    /// The options a resume takes when given none, for a run whose checkpoint names its
    /// recording `words` ([`recording_words`]): no recording, the same viewer, or a file
    /// beside the run's (`x.rrd` → `x-from-<round>.rrd`; a resumed run's `x-from-300.rrd` →
    /// `x-from-<round>.rrd`). `None` for words [`recording_words`] does not write.
    fn resuming(words: &str, round: u64) -> Option<Self> {
        let mut args = Self::default();
        if words == "none" {
            args.no_viewer = true;
            return Some(args);
        }
        let (kind, value) = words.split_once(':')?;
        match kind {
            "connect" => args.connect = Some(value.to_owned()),
            "spawn" => args.spawn = Some(value.parse().ok()?),
            "rrd" => {
                let path = PathBuf::from(value);
                let stem = path
                    .file_stem()
                    .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
                let first = match stem.rsplit_once("-from-") {
                    Some((first, r)) if !r.is_empty() && r.bytes().all(|b| b.is_ascii_digit()) => first,
                    _ => &stem,
                };
                args.rrd = Some(path.with_file_name(format!("{first}-from-{round}.rrd")));
            }
            _ => return None,
        }
        Some(args)
    }
}

/// How a checkpoint names a run's recording ([`RunOutputs::recording`]): `none`,
/// `rrd:PATH` (absolute), `connect:URL` or `spawn:PORT`.
pub fn recording_words(target: Option<&ViewerTarget>) -> String {
    match target {
        None => "none".to_owned(),
        Some(ViewerTarget::Rrd(path)) => format!("rrd:{}", sim_core::absolute(path).display()),
        Some(ViewerTarget::Connect(url)) => format!("connect:{url}"),
        Some(ViewerTarget::Spawn { port }) => format!("spawn:{port}"),
    }
}

/// How a checkpoint records what a recording holds ([`RunOutputs::logging`]): the options
/// as typed, `log-every=K explored-every=K known-every=K max-links=N known-per-robot-max=N`
/// (`known-every=0`: none).
pub fn logging_words(log: &LogOptions) -> String {
    format!(
        "log-every={} explored-every={} known-every={} max-links={} known-per-robot-max={}",
        log.log_every,
        log.explored_every,
        log.known_every.unwrap_or(0),
        log.max_links,
        log.known_per_robot_max
    )
}

/// `path`, a file the run of `checkpoint` wrote (its `what`), if its folder still exists;
/// else an error saying so and that `flag` writes elsewhere.
fn still_writable(
    path: Option<PathBuf>,
    checkpoint: &std::path::Path,
    what: &str,
    flag: &str,
) -> Result<Option<PathBuf>> {
    if let Some(file) = path.as_deref()
        && let Some(dir) = crate::absent_folder(file)
    {
        bail!(
            "the run of checkpoint {} wrote its {what} to {}, but the folder {} no longer exists: {flag} writes elsewhere",
            checkpoint.display(),
            file.display(),
            dir.display()
        );
    }
    Ok(path)
}

/// Arguments of `smartteams view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// The map file (`.stmap`).
    pub map: PathBuf,
    /// Where to show it (default: `<map stem>-map.rrd` in the working directory).
    #[command(flatten)]
    pub viewer: ViewerArgs,
}

/// Arguments of `smartteams run`. `Default` gives an empty config path and the `.rrd` default
/// viewer; library callers usually set `output.viewer.no_viewer`.
#[derive(Debug, Default, clap::Args)]
pub struct RunArgs {
    /// The simulation config (XML).
    pub config: PathBuf,
    /// Use this map file instead of the config's.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Number of rounds (overrides the config).
    #[arg(long)]
    pub rounds: Option<u64>,
    /// Run seed (overrides the config).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write the whole state of the run to this file every `--checkpoint-every` rounds and
    /// at its end (atomically: a run killed at any moment leaves the last checkpoint whole);
    /// `smartteams resume FILE` continues it.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Rounds between checkpoints (with `--checkpoint`).
    #[arg(long, value_name = "K", default_value_t = 100, requires = "checkpoint",
          value_parser = clap::value_parser!(u64).range(1..))]
    pub checkpoint_every: u64,
    /// Outputs, viewer and threads.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Arguments of `smartteams resume`.
#[derive(Debug, Default, clap::Args)]
pub struct ResumeArgs {
    /// The checkpoint (`run --checkpoint FILE`).
    pub checkpoint: PathBuf,
    /// Rounds between further checkpoints, written to the same file (default: as the run
    /// that wrote it).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    pub checkpoint_every: Option<u64>,
    /// Outputs, viewer and threads, as for `run`; outputs not given are those of the run
    /// that wrote the checkpoint (the same CSV files, the same viewer or none, a file beside
    /// its recording, `<its name>-from-<round>.rrd`, and the same logging options). The
    /// metrics CSV holds every round, those before the checkpoint included; a recording
    /// starts at the checkpoint's round.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// What `run` and `resume` share: outputs, viewer, threads.
#[derive(Debug, Default, clap::Args)]
pub struct OutputArgs {
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// How a round's moves and actions are shared among the threads: `auto` (side by side
    /// from 3 threads and 512 robots or 2 threads and 4,096 robots, else in id order),
    /// `in-order` or `side-by-side`.
    /// Results do not depend on it.
    #[arg(long, default_value = "auto")]
    pub turns: TurnSharing,
    /// Write per-round metrics to this CSV file.
    #[arg(long)]
    pub metrics: Option<PathBuf>,
    /// Write per-robot statistics to this CSV file at the end.
    #[arg(long)]
    pub robot_stats: Option<PathBuf>,
    /// No progress bar and no summary (a run stopped by a signal says in one line where).
    #[arg(long, short)]
    pub quiet: bool,
    /// Report a strategy that takes longer than this to decide one round (milliseconds, timed
    /// to a few milliseconds; 0: do not time decisions).
    #[arg(long, value_name = "MS", default_value_t = 100)]
    pub decide_limit_ms: u64,
    /// Where the recording goes.
    #[command(flatten)]
    pub viewer: ViewerArgs,
    /// Log the world (robots, treasures, links, …) every K rounds only; metrics and events
    /// are logged every round, and the last round played always (a stopped run's too)
    /// [default: 1].
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    pub log_every: Option<u64>,
    /// Log each robot's known region (coarse, only robots whose map changed) every K rounds;
    /// 0 turns it off [default: 20].
    #[arg(long, value_name = "K")]
    pub known_every: Option<u64>,
    /// Swarms of at most N robots get one known-region entity per robot; larger ones one per
    /// robot type (each box carrying its robot's id) [default: 100].
    #[arg(long, value_name = "N")]
    pub known_per_robot_max: Option<usize>,
    /// Re-log the collective explored region every K rounds [default: 10].
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    pub explored_every: Option<u64>,
    /// Draw at most N communication links a round (an even sample of the round's distinct
    /// sender–receiver pairs; the messages chart keeps the full count); 0 draws none
    /// [default: 5000].
    #[arg(long, value_name = "N")]
    pub max_links: Option<usize>,
}

impl OutputArgs {
    /// Take the logging options not given from `words` ([`logging_words`]; words it does
    /// not write are passed over). [`resolve`](Self::resolve) bounds them as typed ones.
    fn log_as(&mut self, words: &str) {
        for (key, value) in words.split_whitespace().filter_map(|w| w.split_once('=')) {
            let Ok(n) = value.parse::<u64>() else { continue };
            let count = usize::try_from(n).ok();
            match key {
                "log-every" => self.log_every = self.log_every.or(Some(n)),
                "explored-every" => self.explored_every = self.explored_every.or(Some(n)),
                "known-every" => self.known_every = self.known_every.or(Some(n)),
                "max-links" => self.max_links = self.max_links.or(count),
                "known-per-robot-max" => self.known_per_robot_max = self.known_per_robot_max.or(count),
                _ => {}
            }
        }
    }

    /// The validated run settings for `config`; `default_rrd` names the recording when no
    /// viewer option is given.
    fn resolve(self, config: SimConfig, default_rrd: PathBuf, checkpoint: Option<CheckpointPlan>) -> Result<RunConfig> {
        sim_core::engine::check_threads(self.threads).map_err(|e| anyhow::anyhow!("--threads {e}"))?;
        let metrics = self.metrics.or_else(|| config.outputs.metrics.clone());
        let robot_stats = self.robot_stats.or_else(|| config.outputs.robot_stats.clone());
        let viewer = self.viewer.target(default_rrd)?;
        let d = LogOptions::default();
        let log = LogOptions {
            log_every: self.log_every.unwrap_or(d.log_every).max(1),
            explored_every: self.explored_every.unwrap_or(d.explored_every).max(1),
            known_every: self.known_every.map_or(d.known_every, |k| (k > 0).then_some(k)),
            max_links: self.max_links.unwrap_or(d.max_links),
            known_per_robot_max: self.known_per_robot_max.unwrap_or(d.known_per_robot_max),
        };
        let checkpoint = checkpoint.map(|mut plan| {
            plan.source.outputs = RunOutputs {
                metrics: metrics.as_deref().map(sim_core::absolute),
                robot_stats: robot_stats.as_deref().map(sim_core::absolute),
                recording: Some(recording_words(viewer.as_ref())),
                logging: Some(logging_words(&log)),
                config_outputs: true,
            };
            plan
        });
        Ok(RunConfig {
            config,
            threads: self.threads,
            turn_sharing: self.turns,
            decide_limit: (self.decide_limit_ms > 0).then(|| std::time::Duration::from_millis(self.decide_limit_ms)),
            metrics,
            robot_stats,
            viewer,
            log,
            progress: !self.quiet && std::io::stderr().is_terminal(),
            checkpoint,
        })
    }
}

impl RunArgs {
    /// Resolve into a validated run config (the config file is parsed and checked here).
    pub fn resolve(self) -> Result<RunConfig> {
        let mut config = SimConfig::load(&self.config)?;
        if let Some(map) = self.map {
            config = config.with_map_argument(map);
        }
        if let Some(r) = self.rounds {
            config.rounds = r;
        }
        if let Some(s) = self.seed {
            config.seed = s;
        }
        let default_rrd = config
            .outputs
            .rrd
            .clone()
            .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", config.name)));
        let checkpoint = match self.checkpoint {
            Some(path) => Some(CheckpointPlan {
                path,
                every_rounds: self.checkpoint_every,
                source: RunSource::of(&config)?,
                resume_from: None,
            }),
            None => None,
        };
        self.output.resolve(config, default_rrd, checkpoint)
    }
}

impl ResumeArgs {
    /// Take the outputs not given from what the run of `checkpoint` wrote ([`RunOutputs`]);
    /// fails if the folder of such a file is gone.
    fn outputs_as_its_run(&mut self, checkpoint: &Checkpoint) -> Result<()> {
        let (stored, file, out) = (&checkpoint.source().outputs, &self.checkpoint, &mut self.output);
        if out.metrics.is_none() {
            out.metrics = still_writable(stored.metrics.clone(), file, "metrics", "--metrics FILE")?;
        }
        if out.robot_stats.is_none() {
            let what = "robot statistics";
            out.robot_stats = still_writable(stored.robot_stats.clone(), file, what, "--robot-stats FILE")?;
        }
        if let Some(words) = &stored.logging {
            out.log_as(words);
        }
        let resumed = |words: &str| ViewerArgs::resuming(words, checkpoint.round());
        if out.viewer.is_unset()
            && let Some(viewer) = stored.recording.as_deref().and_then(resumed)
        {
            let rrd = still_writable(viewer.rrd.clone(), file, "recording", "--rrd FILE or --no-viewer")?;
            out.viewer = ViewerArgs { rrd, ..viewer };
        }
        Ok(())
    }

    /// Read and check the checkpoint, and resolve the run that continues it. Outputs not
    /// given write what the checkpoint's run wrote ([`RunOutputs`]).
    pub fn resolve(mut self) -> Result<RunConfig> {
        let checkpoint = Checkpoint::read(&self.checkpoint)?;
        self.outputs_as_its_run(&checkpoint)?;
        let mut config = checkpoint
            .source()
            .config()
            .with_context(|| format!("setting up the run of checkpoint {}", self.checkpoint.display()))?;
        if !checkpoint.source().outputs.config_outputs {
            // Its run wrote none of them (a Python run): neither does the resume.
            config.outputs = sim_core::io::Outputs::default();
        }
        let default_rrd = PathBuf::from(format!("{}-from-{}.rrd", config.name, checkpoint.round()));
        let plan = CheckpointPlan {
            path: self.checkpoint,
            every_rounds: self.checkpoint_every.unwrap_or(checkpoint.every_rounds()),
            source: checkpoint.source().clone(),
            resume_from: Some(std::sync::Arc::new(checkpoint)),
        };
        self.output.resolve(config, default_rrd, Some(plan))
    }
}

/// Parse the command line and run, with the strategies of `registry`. Errors are printed
/// with their causes (`{:#}`) and give exit status 1.
pub fn main_with(registry: &StrategyRegistry) -> ExitCode {
    let cli = parse_command_line();
    if let Err(e) = crate::stop::install() {
        eprintln!("warning: {e:#}; Ctrl-C will end runs without keeping their outputs");
    }
    // This process sets no other `tracing` subscriber: this one cannot be refused.
    crate::rerun_errors::watch();
    match dispatch(cli, registry) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The command line, or exit with clap's message. A value given to `--connect` or `--spawn`
/// after a space, which clap takes for another argument (the option's value is optional),
/// gets a message that shows it written with `=`.
fn parse_command_line() -> Cli {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    Cli::try_parse_from(&args).unwrap_or_else(|e| {
        if e.kind() == clap::error::ErrorKind::UnknownArgument
            && let Some(hint) = value_after_a_space(&args)
        {
            eprintln!("error: {hint}");
            std::process::exit(2);
        }
        e.exit()
    })
}

/// For arguments with `--connect X` or `--spawn X`, where `X` is no option and no file, the
/// message that says to write `--connect=X`.
fn value_after_a_space(args: &[std::ffi::OsString]) -> Option<String> {
    args.windows(2).find_map(|pair| {
        let (option, value) = (pair[0].to_str()?, pair[1].to_str()?);
        let valued = matches!(option, "--connect" | "--spawn") && !value.starts_with('-');
        (valued && !std::path::Path::new(value).is_file())
            .then(|| format!("{option} takes its value after `=`, not a space: {option}={value}"))
    })
}

fn dispatch(cli: Cli, registry: &StrategyRegistry) -> Result<ExitCode> {
    match cli.command {
        Command::Strategies => {
            list_strategies(registry);
            Ok(ExitCode::SUCCESS)
        }
        Command::Tactics => {
            list_tactics(registry);
            Ok(ExitCode::SUCCESS)
        }
        Command::View(args) => view(&args),
        Command::Sweep(args) => sweep(&args, registry),
        Command::Plot(args) => plot(&args.inputs, &args.output, args.size, args.x).map(|()| ExitCode::SUCCESS),
        Command::Merge(args) => merge(&args),
        Command::Run(args) => {
            let (quiet, file) = (args.output.quiet, args.config.display().to_string());
            run_and_report(&args.resolve()?, registry, quiet, ("running", &file))
        }
        Command::Resume(args) => {
            let (quiet, file) = (args.output.quiet, args.checkpoint.display().to_string());
            run_and_report(&args.resolve()?, registry, quiet, ("resuming", &file))
        }
    }
}

/// `strategies`: each registered strategy and what it does.
fn list_strategies(registry: &StrategyRegistry) {
    for (name, description) in registry.describe() {
        say!("{name:14} {description}");
    }
}

/// `tactics`: how to compose tactics, then each registered tactic and what it does.
fn list_tactics(registry: &StrategyRegistry) {
    say!("compose with strategy=\"tactics\" and <param name=\"tactics\" value=\"NAME,NAME,...\"/> (priority order);");
    say!("a tactic's parameters are NAME.PARAM, the goal of boundary and shortest_path is goal=\"X,Y\"\n");
    for (name, description) in registry.tactics().describe() {
        say!("{name:14} {description}");
    }
}

/// `view`: show a map in the viewer (or a recording of it).
fn view(args: &ViewArgs) -> Result<ExitCode> {
    let stem = args
        .map
        .file_stem()
        .map_or_else(|| "map".into(), |s| s.to_string_lossy().into_owned());
    // `-map`: a run's recording is named after its config, often the map's name too.
    let Some(target) = args.viewer.target(PathBuf::from(format!("{stem}-map.rrd")))? else {
        bail!("--no-viewer leaves nothing to show");
    };
    crate::run::view_map(&args.map, &target)?;
    say!("{}: shown in {target}", args.map.display());
    Ok(ExitCode::SUCCESS)
}

/// `sweep`: run the sweep, say what it wrote, and plot it if asked.
fn sweep(args: &crate::sweep::SweepArgs, registry: &StrategyRegistry) -> Result<ExitCode> {
    let summary = match crate::sweep::sweep(args, registry, !args.quiet && std::io::stderr().is_terminal()) {
        Ok(summary) => summary,
        Err(e) => return stopped_sweep(&e).ok_or(e),
    };
    if !args.quiet {
        say!(
            "{}: {} runs of {} ({} resumed), {} rows; manifest {}",
            summary.output.display(),
            summary.runs,
            summary.runs_total,
            summary.resumed,
            summary.rows,
            summary.manifest.display()
        );
    }
    if let Some(fig) = &args.plot {
        plot(
            std::slice::from_ref(&summary.output),
            fig,
            (1400, 900),
            crate::plot::XAxis::Round,
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

/// `merge`: merge a sharded sweep's parts and say what it wrote.
fn merge(args: &crate::sweep::MergeArgs) -> Result<ExitCode> {
    let summary = crate::sweep::merge_parts(args)?;
    let total = summary.runs_total.map_or(String::new(), |t| format!(" of {t}"));
    say!(
        "{}: {} runs{total}, {} rows",
        args.output.display(),
        summary.runs,
        summary.rows
    );
    Ok(ExitCode::SUCCESS)
}

/// The exit status of a sweep that `e` says a stop signal ended (the finished runs are
/// kept: the message says where), after saying so; `None` for any other error.
fn stopped_sweep(e: &anyhow::Error) -> Option<ExitCode> {
    let signal = crate::stop::requested()?;
    let stopped = e.chain().any(|c| {
        matches!(
            c.downcast_ref::<sim_core::Error>(),
            Some(sim_core::Error::Stopped { .. })
        )
    });
    if !stopped {
        return None;
    }
    say!("{e:#} (interrupted by {})", signal.name());
    Some(ExitCode::from(signal.exit_status()))
}

/// Execute a resolved run and print its summary (unless quiet; a quiet run stopped by a
/// signal says in one line where it stopped). Its exit status: 0, or 130 / 143 after a stop signal.
fn run_and_report(
    run: &RunConfig,
    registry: &StrategyRegistry,
    quiet: bool,
    (doing, file): (&str, &str),
) -> Result<ExitCode> {
    // "running FILE: …", unless the error names the file already (a config's line and column).
    let summary = execute(run, registry, &mut []).map_err(|e| {
        if e.to_string().starts_with(&format!("{file}:")) {
            e
        } else {
            e.context(format!("{doing} {file}"))
        }
    })?;
    // A closed pipe (`smartteams run … | head -1`) is not an error of the run.
    if !quiet {
        let _ = writeln!(std::io::stdout(), "{summary}");
    } else if let Some(stop) = summary.stop_note() {
        let _ = writeln!(std::io::stdout(), "{}: {stop}", summary.name);
    }
    Ok(summary
        .interrupted
        .map_or(ExitCode::SUCCESS, |s| ExitCode::from(s.exit_status())))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A resume records where its run did: the same viewer, none, or a file beside the
    /// run's, numbered by the round it starts at; words no run writes are not read.
    #[test]
    fn a_resume_records_where_its_run_did() {
        let resuming = |target: Option<ViewerTarget>, round| {
            let args = ViewerArgs::resuming(&recording_words(target.as_ref()), round).unwrap();
            args.target(PathBuf::from("default.rrd")).unwrap()
        };
        let rrd = |path: &str| Some(ViewerTarget::Rrd(PathBuf::from(path)));
        assert_eq!(resuming(None, 150), None);
        assert_eq!(resuming(rrd("/runs/x.rrd"), 150), rrd("/runs/x-from-150.rrd"));
        assert_eq!(resuming(rrd("/runs/x-from-150.rrd"), 300), rrd("/runs/x-from-300.rrd"));
        assert_eq!(
            resuming(rrd("/runs/x-from-.rrd"), 300),
            rrd("/runs/x-from--from-300.rrd")
        );
        let live = Some(ViewerTarget::Connect("rerun+http://10.0.0.2:9000/proxy".to_owned()));
        assert_eq!(resuming(live.clone(), 150), live);
        let spawned = Some(ViewerTarget::Spawn { port: 9877 });
        assert_eq!(resuming(spawned.clone(), 150), spawned);
        assert!(ViewerArgs::resuming("tape:/dev/st0", 150).is_none());
        assert!(ViewerArgs::resuming("spawn:port", 150).is_none());
    }

    /// The logging options a checkpoint keeps come back, unless given again; the defaults
    /// the help states are those of [`LogOptions::default`].
    #[test]
    fn a_resume_logs_as_its_run_did() {
        let log = LogOptions {
            log_every: 7,
            explored_every: 30,
            known_every: None,
            max_links: 0,
            known_per_robot_max: 12,
        };
        let config =
            || SimConfig::parse(include_str!("../../configs/demo.xml"), std::path::Path::new("demo.xml")).unwrap();
        let resolved = |args: OutputArgs| args.resolve(config(), PathBuf::from("x.rrd"), None).unwrap().log;
        let mut args = OutputArgs::default();
        args.log_as(&logging_words(&log));
        assert_eq!(resolved(args), log);
        let mut args = OutputArgs {
            log_every: Some(3),
            ..OutputArgs::default()
        };
        args.log_as(&logging_words(&log));
        assert_eq!(resolved(args), LogOptions { log_every: 3, ..log });
        assert_eq!(resolved(OutputArgs::default()), LogOptions::default());

        let help = <Cli as clap::CommandFactory>::command()
            .find_subcommand_mut("run")
            .unwrap()
            .render_long_help()
            .to_string();
        let d = LogOptions::default();
        for (flag, default) in [
            ("--log-every", d.log_every.to_string()),
            ("--known-every", d.known_every.unwrap_or(0).to_string()),
            ("--known-per-robot-max", d.known_per_robot_max.to_string()),
            ("--explored-every", d.explored_every.to_string()),
            ("--max-links", d.max_links.to_string()),
        ] {
            let text = help
                .split(flag)
                .nth(1)
                .and_then(|t| t.split("\n\n").next())
                .unwrap_or_default();
            assert!(text.contains(&format!("[default: {default}]")), "{flag}: {text}");
        }
    }

    /// `resume` and `view` say their own defaults: a resume's logging options and
    /// recording are the run's, `view` records `<map>-map.rrd` and has no `--no-viewer`.
    #[test]
    fn resume_and_view_help_say_their_own_defaults() {
        let help = |command: &str| {
            <Cli as clap::CommandFactory>::command()
                .find_subcommand_mut(command)
                .unwrap()
                .render_help()
                .to_string()
        };
        let resume = help("resume");
        for flag in [
            "--log-every",
            "--known-every",
            "--known-per-robot-max",
            "--explored-every",
            "--max-links",
        ] {
            let line = resume.lines().find(|l| l.trim_start().starts_with(flag)).unwrap();
            assert!(
                line.ends_with("[default: as the run that wrote the checkpoint]"),
                "{line}"
            );
        }
        assert!(
            resume.contains("x-from-<round>.rrd") && !resume.contains("<run name>.rrd"),
            "{resume}"
        );
        let view = help("view");
        assert!(
            view.contains("<map stem>-map.rrd") && !view.contains("--no-viewer"),
            "{view}"
        );
    }
}
