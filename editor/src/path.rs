//! `path`: the shortest any-angle path between two points of a map, for a robot of a given
//! radius (0: the Moving AI any-angle rules); and the queries that time it (`smartteams-bench
//! any-angle` and the editor's timing harness share them): a Moving AI scenario's, or random
//! pairs of free cell centres.

use std::fmt;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use sim_core::glam::DVec2;
use sim_core::spatial::{AnyAnglePath, AnyAnglePlanner, NoPath, ObstacleMap};
use sim_core::world::MapData;

use crate::import::{ImportOptions, import};
use crate::{EditorError, Result};

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

/// One query, in world coordinates, with the published lengths where known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathQuery {
    /// Start.
    pub from: DVec2,
    /// Goal.
    pub to: DVec2,
    /// The octile optimum (a Moving AI scenario's 9th column; 0 = unreachable).
    pub octile: Option<f64>,
    /// The any-angle optimum (a 10th column, where the file has one).
    pub optimum: Option<f64>,
}

/// A map for timing paths: a Moving AI `.map` (imported as `smartteams-editor import` does)
/// or a Smart Teams map file.
pub fn load_map(path: &Path) -> Result<ObstacleMap> {
    if path.extension().is_some_and(|e| e == "map") {
        Ok(import(path, &ImportOptions::default())?)
    } else {
        Ok(MapData::load(path)?.obstacles)
    }
}

/// The queries of a Moving AI scenario file (`.scen`, or the same columns with an any-angle
/// optimum in a 10th): corners `(x, y)` with `y` down, as world points of `map`.
pub fn read_scenario(path: &Path, map: &ObstacleMap) -> Result<Vec<PathQuery>> {
    let bad = |line: usize, problem: String| EditorError::bad_input(path, format!("line {line}: {problem}"));
    let text = std::fs::read_to_string(path).map_err(EditorError::io(path))?;
    let g = map.grid();
    let top = f64::from(g.height_cells());
    let mut queries = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with("version") || line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < 9 {
            return Err(bad(
                i + 1,
                format!("expected at least 9 tab-separated columns, found {}", f.len()),
            ));
        }
        let num = |c: usize| -> Result<f64> {
            f[c].trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(i + 1, format!("column {}: expected a number, found {:?}", c + 1, f[c])))
        };
        let corner = |x: f64, y: f64| g.origin() + DVec2::new(x, top - y) * g.cell_m();
        queries.push(PathQuery {
            from: corner(num(4)?, num(5)?),
            to: corner(num(6)?, num(7)?),
            octile: Some(num(8)?),
            optimum: if f.len() > 9 { Some(num(9)?) } else { None },
        });
    }
    Ok(queries)
}

/// `count` queries between centres of free cells drawn with `seed`; none on a map without a
/// free cell (where drawing would never end).
pub fn random_queries(map: &ObstacleMap, count: usize, seed: u64) -> Vec<PathQuery> {
    if map.free_area_m2() <= 0.0 {
        return Vec::new();
    }
    let g = map.grid();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut free_centre = || loop {
        let c = g.cell_center(
            rng.random_range(0..g.width_cells()),
            rng.random_range(0..g.height_cells()),
        );
        if map.is_point_free(c) {
            return c;
        }
    };
    (0..count)
        .map(|_| PathQuery {
            from: free_centre(),
            to: free_centre(),
            octile: None,
            optimum: None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use sim_core::spatial::Grid;

    use super::*;

    #[test]
    fn random_queries_join_free_cell_centres_and_give_none_without_a_free_cell() {
        let grid = Grid::new(DVec2::ZERO, 0.5, 8, 4).unwrap();
        let map = ObstacleMap::from_fn(grid, |x, _| x < 6);
        let queries = random_queries(&map, 20, 1);
        assert_eq!(queries.len(), 20);
        assert!(
            queries
                .iter()
                .all(|q| map.is_point_free(q.from) && map.is_point_free(q.to))
        );
        assert_eq!(queries, random_queries(&map, 20, 1), "same seed, same queries");
        let full = ObstacleMap::from_fn(grid, |_, _| true);
        assert!(random_queries(&full, 20, 1).is_empty());
    }

    #[test]
    fn scenarios_are_read_with_y_down_and_bad_lines_named() {
        let grid = Grid::new(DVec2::new(10.0, 0.0), 2.0, 8, 4).unwrap();
        let map = ObstacleMap::from_fn(grid, |_, _| false);
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("q.scen");
        std::fs::write(&file, "version 1\n0\tm.map\t8\t4\t1\t0\t7\t4\t6.5\t6.25\n").unwrap();
        let q = read_scenario(&file, &map).unwrap();
        assert_eq!(
            q,
            [PathQuery {
                from: DVec2::new(12.0, 8.0),
                to: DVec2::new(24.0, 0.0),
                octile: Some(6.5),
                optimum: Some(6.25),
            }]
        );
        std::fs::write(&file, "version 1\n0\tm.map\t8\t4\t1\t0\t7\n").unwrap();
        let e = read_scenario(&file, &map).unwrap_err().to_string();
        assert!(
            e.contains("line 2: expected at least 9 tab-separated columns, found 7"),
            "{e}"
        );
    }
}
