//! The bridge from a Smart Teams simulation to its users: the `smartteams` runner and the
//! Rerun viewer bridge ([`rerun_observer::RerunObserver`], [`blueprint`], [`layers`]).
//!
//! [`cli`] turns raw command-line arguments into a validated [`run::RunConfig`] before any
//! work starts; [`run::execute`] runs it with the observers the config asks for. A crate
//! with its own strategies calls [`cli::main_with`] with its registry and gets the whole
//! command line for free:
//!
//! ```no_run
//! use sim_core::agent::StrategyRegistry;
//!
//! fn main() -> std::process::ExitCode {
//!     let mut registry = StrategyRegistry::with_builtins();
//!     // registry.register("mine", "my strategy", |params| Ok(Box::new(MyStrategy::new(params)?)));
//!     viewer_bridge::cli::main_with(&registry)
//! }
//! ```

pub mod blueprint;
pub mod cli;
pub mod layers;
pub mod plot;
pub mod priority;
pub mod progress;
pub mod rerun_errors;
pub mod rerun_observer;
pub mod run;
pub mod stop;
pub mod sweep;
pub mod viewer;

/// Why `path`, the `what` a run is to write, cannot be created: its folder does not exist
/// (`None` when it does, or when the path names no folder). Checked before the work that
/// would write it, and said plainly rather than as the writer's error.
pub(crate) fn missing_folder(what: &str, path: &std::path::Path) -> Option<String> {
    let dir = absent_folder(path)?;
    Some(format!(
        "cannot write the {what} {}: the folder {} does not exist",
        path.display(),
        dir.display()
    ))
}

/// The folder of `path`, if it names one that does not exist.
pub(crate) fn absent_folder(path: &std::path::Path) -> Option<&std::path::Path> {
    path.parent().filter(|d| !d.as_os_str().is_empty() && !d.is_dir())
}
