//! # Smart Teams simulation core
//!
//! The library behind the `smartteams` simulator: the spatial structures of the paper
//! (obstacle region quadtree, treasure PR-quadtree, robot index, per-robot known maps), the
//! compact map file, the navigation graph, the round loop ([`round`]: perceive → decide →
//! resolve → observe), strategies and tactics, the XML config and the metrics. Viewers watch
//! a run through the [`Observer`] trait; sim-core knows nothing of Rerun, images or command
//! lines. A whole run: [`config::SimConfig::load`] → [`Scenario`] → [`Simulation::run`].
//!
//! ```
//! use sim_core::glam::DVec2;
//! use sim_core::{Grid, ObstacleMap, KnownMap};
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

pub mod config;
pub mod error;
pub mod geometry;
pub mod grid;
pub mod invariants;
pub mod known_map;
pub mod mapfile;
pub mod memory;
pub mod messages;
pub mod metrics;
pub mod model;
pub mod nav;
pub mod observer;
pub mod obstacle_map;
pub mod quadtree;
pub mod robot_index;
pub mod round;
pub mod sim;
pub mod strategy;
pub mod tactics;
pub mod treasure_index;

pub use error::{Error, Result};
pub use glam;
pub use grid::Grid;
pub use known_map::KnownMap;
pub use mapfile::{HomeBase, MapData, TreasureSpec};
pub use model::{Action, Outcome, Robot, RobotType, TreasureState};
pub use observer::{Event, Observer, RoundReport};
pub use obstacle_map::ObstacleMap;
pub use robot_index::{RobotId, RobotIndex};
pub use sim::{Scenario, Simulation};
pub use treasure_index::{TreasureId, TreasureIndex};
