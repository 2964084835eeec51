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
pub mod progress;
pub mod rerun_observer;
pub mod run;
pub mod stop;
pub mod sweep;
pub mod viewer;
