//! The `smartteams` command line: raw arguments → validated [`RunConfig`] → [`execute`].

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use sim_core::config::SimConfig;
use sim_core::strategy::StrategyRegistry;

use crate::run::{RunConfig, execute};

/// Smart Teams: simulate robot swarms exploring unknown terrain.
#[derive(Debug, Parser)]
#[command(name = "smartteams", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a simulation described by an XML config.
    Run(RunArgs),
    /// List the strategies this build knows.
    Strategies,
}

/// Arguments of `smartteams run`.
#[derive(Debug, clap::Args)]
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
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write per-round metrics to this CSV file.
    #[arg(long)]
    pub metrics: Option<PathBuf>,
    /// Write per-robot statistics to this CSV file at the end.
    #[arg(long)]
    pub robot_stats: Option<PathBuf>,
    /// No progress bar and no summary.
    #[arg(long, short)]
    pub quiet: bool,
}

impl RunArgs {
    /// Resolve into a validated run config (the config file is parsed and checked here).
    pub fn resolve(self, registry: &StrategyRegistry) -> Result<RunConfig> {
        let mut config = SimConfig::load(&self.config)?;
        if let Some(map) = self.map {
            config.map_path = map;
        }
        if let Some(r) = self.rounds {
            config.rounds = r;
        }
        if let Some(s) = self.seed {
            config.seed = s;
        }
        if self.threads == Some(0) {
            bail!("--threads must be at least 1");
        }
        config.check_strategies(registry)?;
        let metrics = self.metrics.or_else(|| config.outputs.metrics.clone());
        let robot_stats = self.robot_stats.or_else(|| config.outputs.robot_stats.clone());
        Ok(RunConfig {
            config,
            threads: self.threads,
            metrics,
            robot_stats,
            progress: !self.quiet && std::io::stderr().is_terminal(),
        })
    }
}

/// Parse the command line and run, with the strategies of `registry`. Errors are printed
/// with their causes (`{:#}`) and give exit status 1.
pub fn main_with(registry: &StrategyRegistry) -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli, registry) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn dispatch(cli: Cli, registry: &StrategyRegistry) -> Result<()> {
    match cli.command {
        Command::Strategies => {
            for (name, description) in registry.describe() {
                println!("{name:14} {description}");
            }
            Ok(())
        }
        Command::Run(args) => {
            let quiet = args.quiet;
            let config_path = args.config.clone();
            let run = args.resolve(registry)?;
            let summary =
                execute(&run, registry, &mut []).with_context(|| format!("running {}", config_path.display()))?;
            if !quiet {
                println!("{summary}");
            }
            Ok(())
        }
    }
}
