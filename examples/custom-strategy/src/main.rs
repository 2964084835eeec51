//! The `smartteams` command line with the example strategy added.

fn main() -> std::process::ExitCode {
    let mut registry = sim_core::agent::StrategyRegistry::with_builtins();
    custom_strategy::register(&mut registry);
    viewer_bridge::cli::main_with(&registry)
}
