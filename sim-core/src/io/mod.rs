//! Layer 5, input and output: the [`Observer`] trait through which viewers watch a run (and
//! [`Simulation::run`](crate::engine::Simulation::run), which drives it), the CSV writers,
//! the XML config, checkpoints and the invariant checker. The top layer: it may import from
//! all below.

mod checkpoint;
mod config;
mod csv;
mod invariants;
mod observer;
pub mod sweep;

pub use checkpoint::{CHECKPOINT_FORMAT, Checkpoint, CheckpointWriter, RunOutputs, RunSource, write_checkpoint};
pub use config::{GroupConfig, Outputs, SimConfig};
pub use csv::{MetricsCsv, ROBOT_STATS_COLUMNS, write_robot_stats};
pub use invariants::InvariantChecker;
pub use observer::{Observer, ObserverError};
