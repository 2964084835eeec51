//! `smartteams sweep` and `smartteams merge`: the command-line side of
//! [`sim_core::io::sweep`] (shard from the arguments or a cluster scheduler, a progress bar
//! of runs).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use sim_core::agent::StrategyRegistry;
use sim_core::io::sweep::{MergeSummary, Shard, Sweep, SweepSummary, merge, run_sweep_until};

/// Arguments of `smartteams sweep`.
#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    /// The sweep file (XML: a base config and the values to vary).
    pub sweep: PathBuf,
    /// The CSV to write (one row per run and round); a manifest is written beside it.
    #[arg(short, long, value_name = "RESULTS.csv")]
    pub output: PathBuf,
    /// Run only the I-th of N disjoint slices of the runs (I from 0). Default: from a Slurm
    /// job array (`SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN` of
    /// `SLURM_ARRAY_TASK_COUNT`) when set, else the whole sweep.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress bar and no summary.
    #[arg(long, short)]
    pub quiet: bool,
    /// Also draw the sweep's standard figure (as `smartteams plot` does) into this file.
    #[arg(long, value_name = "FIG.png")]
    pub plot: Option<PathBuf>,
}

/// Arguments of `smartteams merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shards' CSV files.
    #[arg(required = true, value_name = "PART.csv")]
    pub parts: Vec<PathBuf>,
    /// The CSV to write.
    #[arg(short, long, value_name = "RESULTS.csv")]
    pub output: PathBuf,
}

/// The shard a sweep runs: `--shard`, else a Slurm job array's task, else all.
/// `env` looks up environment variables (a parameter so tests need not set them).
pub fn resolve_shard(arg: Option<&str>, env: impl Fn(&str) -> Option<String>) -> Result<Shard> {
    if let Some(s) = arg {
        return s.parse().with_context(|| format!("--shard {s}"));
    }
    let Some(id) = env("SLURM_ARRAY_TASK_ID") else {
        return Ok(Shard::ALL);
    };
    let number = |name: &str, value: &str| -> Result<usize> {
        value
            .trim()
            .parse()
            .with_context(|| format!("{name}={value} is not a whole number"))
    };
    let id = number("SLURM_ARRAY_TASK_ID", &id)?;
    let min = env("SLURM_ARRAY_TASK_MIN").map_or(Ok(0), |v| number("SLURM_ARRAY_TASK_MIN", &v))?;
    let Some(count) = env("SLURM_ARRAY_TASK_COUNT") else {
        bail!("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not; give --shard I/N");
    };
    let count = number("SLURM_ARRAY_TASK_COUNT", &count)?;
    let Some(index) = id.checked_sub(min) else {
        bail!("SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}");
    };
    Shard::new(index, count).with_context(|| {
        format!("from SLURM_ARRAY_TASK_ID={id}, SLURM_ARRAY_TASK_MIN={min}, SLURM_ARRAY_TASK_COUNT={count}")
    })
}

/// Run `smartteams sweep`.
pub fn sweep(args: &SweepArgs, registry: &StrategyRegistry, progress: bool) -> Result<SweepSummary> {
    let shard = resolve_shard(args.shard.as_deref(), |k| std::env::var(k).ok())?;
    sim_core::engine::check_threads(args.threads).map_err(|e| anyhow::anyhow!("--threads {e}"))?;
    let sweep = Sweep::load(&args.sweep)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let bar = progress.then(|| {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.enable_steady_tick(Duration::from_millis(500));
        bar
    });
    let started = std::time::Instant::now();
    let summary = pool.install(|| {
        let stop = || crate::stop::requested().is_some();
        run_sweep_until(
            &sweep,
            registry,
            shard,
            &args.output,
            &|p| {
                if let Some(bar) = &bar {
                    bar.set_length(p.total as u64);
                    bar.set_position(p.done as u64);
                    // Estimated finish from this attempt's pace (resumed runs cost nothing).
                    let fresh = p.done - p.resumed;
                    if fresh > 0 {
                        let left = started.elapsed().mul_f64((p.total - p.done) as f64 / fresh as f64);
                        bar.set_message(format!("(about {:.0} s to go)", left.as_secs_f64()));
                    }
                }
            },
            &stop,
        )
    });
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    summary.with_context(|| format!("sweep {}", args.sweep.display()))
}

/// Run `smartteams merge`.
pub fn merge_parts(args: &MergeArgs) -> Result<MergeSummary> {
    merge(&args.parts, &args.output).with_context(|| format!("merging into {}", args.output.display()))
}
