//! `path`: the shortest any-angle path between two points of a map, for a robot of a given
//! radius (0: the Moving AI any-angle rules).

use std::fmt;

use serde::Serialize;
use sim_core::glam::DVec2;
use sim_core::spatial::{AnyAnglePath, AnyAnglePlanner, NoPath, ObstacleMap};

use crate::Result;

/// A path as `path --json` prints it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathReport {
    /// Length, metres.
    pub length_m: f64,
    /// Waypoints `[x, y]` in world coordinates from start to goal.
    pub waypoints: Vec<[f64; 2]>,
}

impl From<AnyAnglePath> for PathReport {
    fn from(p: AnyAnglePath) -> Self {
        Self {
            length_m: p.length_m,
            waypoints: p.waypoints.iter().map(|w| [w.x, w.y]).collect(),
        }
    }
}

impl fmt::Display for PathReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "length_m {}", self.length_m)?;
        for [x, y] in &self.waypoints {
            writeln!(f, "{x} {y}")?;
        }
        Ok(())
    }
}

/// The shortest path from `from` to `to` for a robot of `radius_m`, or why there is none
/// (the inner result). The outer error is a planner that cannot be built (bad radius, a map
/// too large for it).
pub fn shortest_path(map: &ObstacleMap, from: DVec2, to: DVec2, radius_m: f64) -> Result<Result<PathReport, NoPath>> {
    let planner = AnyAnglePlanner::build(map, radius_m)?;
    Ok(planner.path(from, to).map(PathReport::from))
}
