//! The greedy reference explorer against hand-worked distances.

use std::sync::Arc;

use scale::exploration::{GREEDY_REFERENCE, explore, indoor_maps};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData};

/// A corridor 30 m × 1 m inside 0.3 m walls (free from x = 0.3 to 29.7, 0.1 m cells), the
/// robot starting at (1.5, 0.8). A cell counts as explored when it lies wholly in the 3.5 m
/// view: the corridor's cells up to √(3.5² − 0.5²) = 3.464 m ahead, less up to a cell,
/// and everything behind. 98 % of the 29.4 m is 28.812 m, seen from x ≥ 0.3 + 28.812 −
/// 3.464 + u = 25.648 + u (u < 0.1). Views come at the start of a round, after r − 1 steps
/// of 0.25 m: 1.5 + 0.25 (r − 1) ≥ 25.648 + u first holds at r − 1 = 97 (96.6 + 4u < 97),
/// so round 98, and the distance counted at its end is 98 × 0.25 = 24.5 m. A reference that
/// dithers or turns back walks more.
#[test]
fn the_reference_walks_a_corridor_straight_to_its_end() {
    let cell_m = 0.1;
    let grid = Grid::from_size_m(DVec2::ZERO, cell_m, 30.0, 1.6).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        let (px, py) = ((f64::from(x) + 0.5) * cell_m, (f64::from(y) + 0.5) * cell_m);
        !(0.3..=29.7).contains(&px) || !(0.3..=1.3).contains(&py)
    });
    let map = Arc::new(MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(1.5, 0.8),
            radius_m: 0.3,
        },
        treasures: Vec::new(),
    });
    let run = explore(&map, GREEDY_REFERENCE, 1, 400).unwrap();
    let (_, d98) = run.at_98.expect("the corridor is explored");
    assert!((d98 - 24.5).abs() < 1e-6, "walked {d98} m to 98 %");
    // Straight on: nothing walked through ground already explored until then.
    assert!(run.overlap_m < 1e-9, "{run:?}");
}

/// Every indoor map of the comparison set is one connected region the reference explores
/// to 90 %: the table compares explorers on maps that can be explored.
#[test]
fn the_reference_explores_every_indoor_map() {
    for (name, map) in indoor_maps().unwrap() {
        let run = explore(&map, GREEDY_REFERENCE, 1, 6_000).unwrap();
        assert!(run.at_90.is_some(), "{name}: {run:?}");
    }
}
