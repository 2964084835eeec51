//! `smartteams`: run Smart Teams simulations. All logic lives in the library.

/// The allocator: a round allocates and frees messages, payloads and search buffers on every
/// worker, which mimalloc's per-thread heaps serve without glibc's trimming and refaulting of
/// pages. Paper scale and 100,000 robots run faster with it (BENCHMARKS.md); results do not
/// depend on it.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    viewer_bridge::cli::main_with(&sim_core::agent::StrategyRegistry::with_builtins())
}
