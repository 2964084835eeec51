//! `validate`: home base free, treasures free and reachable from home, everything in bounds.

use std::fmt;

use sim_core::spatial::Aabb;
use sim_core::world::{HomeBase, MapData};

use sim_core::spatial::Components;

/// One thing wrong with a map.
#[derive(Clone, Debug, PartialEq)]
pub enum Problem {
    /// The home base is degenerate (non-finite, zero size).
    HomeDegenerate,
    /// The home base reaches outside the map.
    HomeOutside,
    /// The home base's centre lies in a blocked cell.
    HomeCenterBlocked,
    /// Part of the home base overlaps obstacles.
    HomeOverlapsObstacles,
    /// Treasure `index` lies outside the map.
    TreasureOutside(usize),
    /// Treasure `index` lies in a blocked cell.
    TreasureBlocked(usize),
    /// Treasure `index` lies in free space that home cannot reach.
    TreasureUnreachable(usize),
    /// Treasure `index` has quantity 0.
    TreasureEmpty(usize),
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::HomeDegenerate => write!(f, "home base is degenerate (not finite or zero-sized)"),
            Problem::HomeOutside => write!(f, "home base reaches outside the map"),
            Problem::HomeCenterBlocked => write!(f, "home base centre lies in a blocked cell"),
            Problem::HomeOverlapsObstacles => write!(f, "home base overlaps obstacles"),
            Problem::TreasureOutside(i) => write!(f, "treasure {i} lies outside the map"),
            Problem::TreasureBlocked(i) => write!(f, "treasure {i} lies in a blocked cell"),
            Problem::TreasureUnreachable(i) => write!(f, "treasure {i} cannot be reached from the home base"),
            Problem::TreasureEmpty(i) => write!(f, "treasure {i} has quantity 0"),
        }
    }
}

fn home_ok(home: &HomeBase) -> bool {
    match *home {
        HomeBase::Disc { center, radius_m } => center.is_finite() && radius_m.is_finite() && radius_m > 0.0,
        HomeBase::Rect(r) => r.min.is_finite() && r.max.is_finite() && r.min.x < r.max.x && r.min.y < r.max.y,
    }
}

/// Every problem of `map` (empty = valid).
pub fn validate(map: &MapData) -> Vec<Problem> {
    let mut problems = Vec::new();
    let obstacles = &map.obstacles;
    let extent = obstacles.grid().extent();
    let inside = |p| extent.contains_box(&Aabb { min: p, max: p });
    let comps = Components::new(obstacles.tree());
    let mut home_label = None;
    if home_ok(&map.home) {
        if !extent.contains_box(&map.home.bounds()) {
            problems.push(Problem::HomeOutside);
        }
        home_label = comps.label_at(map.home.center());
        if home_label.is_none() {
            problems.push(Problem::HomeCenterBlocked);
        } else {
            let overlaps = match map.home {
                HomeBase::Disc { center, radius_m } => !obstacles.is_disc_free(center, radius_m),
                HomeBase::Rect(r) => {
                    let mut any = false;
                    obstacles.for_each_blocked_in_box(r, |_| any = true);
                    any || !extent.contains_box(&r)
                }
            };
            if overlaps && extent.contains_box(&map.home.bounds()) {
                problems.push(Problem::HomeOverlapsObstacles);
            }
        }
    } else {
        problems.push(Problem::HomeDegenerate);
    }
    for (i, t) in map.treasures.iter().enumerate() {
        if t.quantity == 0 {
            problems.push(Problem::TreasureEmpty(i));
        }
        if !(t.position.is_finite() && inside(t.position)) {
            problems.push(Problem::TreasureOutside(i));
            continue;
        }
        match comps.label_at(t.position) {
            None => problems.push(Problem::TreasureBlocked(i)),
            Some(l) if home_label.is_some_and(|h| h != l) => problems.push(Problem::TreasureUnreachable(i)),
            Some(_) => {}
        }
    }
    problems
}
