//! `smartteams`: run Smart Teams simulations. All logic lives in the library.

fn main() -> std::process::ExitCode {
    viewer_bridge::cli::main_with(&sim_core::agent::StrategyRegistry::with_builtins())
}
