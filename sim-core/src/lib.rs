//! # Smart Teams simulation core
//!
//! The library behind the `smartteams` simulator, in five layers, each a module that
//! imports only from the layers before it:
//!
//! 1. [`spatial`]: geometry, the region quadtree behind obstacle and known maps, the
//!    treasure and robot indexes, the navigation graph, and the ids that key them;
//! 2. [`world`]: robot types, robots, treasures, actions, messages, memory lists, the map
//!    file, and what a round reports (events, links, metrics);
//! 3. [`agent`]: strategies, their context [`Ctx`](agent::Ctx), parameters, the registry,
//!    tactics and the built-in strategies;
//! 4. [`engine`]: a validated [`Scenario`](engine::Scenario) and the
//!    [`Simulation`](engine::Simulation) that runs it (perceive → decide → resolve);
//! 5. [`io`]: the [`Observer`](io::Observer) trait viewers implement, the CSV writers, the
//!    XML config and the invariant checker.
//!
//! Every public item has one path: `sim_core::<layer>::<Item>`. sim-core knows nothing of
//! Rerun, images or command lines. A whole run: [`io::SimConfig::load`] →
//! [`io::SimConfig::scenario`] → [`engine::Simulation::new`] → [`engine::Simulation::run`].
//!
//! ```
//! use sim_core::glam::DVec2;
//! use sim_core::spatial::{Grid, KnownMap, ObstacleMap};
//!
//! // A 64 m × 64 m map with 1 m cells and a wall at x ∈ [30, 31).
//! let grid = Grid::new(DVec2::ZERO, 1.0, 64, 64)?;
//! let map = ObstacleMap::from_fn(grid, |x, _y| x == 30);
//! assert!(map.is_disc_free(DVec2::new(10.0, 10.0), 0.125));
//! assert!(!map.is_swept_disc_free(DVec2::new(10.0, 10.0), DVec2::new(50.0, 10.0), 0.125));
//! assert_eq!(map.first_hit(DVec2::new(10.0, 10.5), DVec2::X, 100.0), Some(20.0));
//!
//! // A robot that has looked around with a 5 m view radius.
//! let mut known = KnownMap::new(grid);
//! known.mark_disc(DVec2::new(10.0, 10.0), 5.0);
//! assert!(known.is_known(DVec2::new(12.0, 11.0)));
//! assert!(!known.is_known(DVec2::new(20.0, 10.0)));
//! # Ok::<(), sim_core::Error>(())
//! ```

pub mod spatial;

pub mod world;

pub mod agent;

pub mod engine;

pub mod io;

mod cache;
mod error;
mod fs;

pub use error::{Error, Result};
pub use fs::{absolute, write_atomically};
pub use glam;
