//! Placement reaches only free cells connected to home; validation finds planted problems.

use editor::place::{PlaceOptions, Spread, place};
use editor::validate::{Problem, validate};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData, TreasureSpec};

/// A 40 × 30 map: a wall at x = 20 splits it; a closed box around (30..35, 20..25) on the right.
fn split_map() -> MapData {
    let grid = Grid::new(DVec2::ZERO, 1.0, 40, 30).unwrap();
    let obstacles = ObstacleMap::from_fn(grid, |x, y| {
        x == 20
            || (y % 7 == 3 && x < 15 && x > 2)
            || ((x == 29 || x == 36) && (19..=26).contains(&y))
            || ((y == 19 || y == 26) && (29..=36).contains(&x))
    });
    MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(5.5, 5.5),
            radius_m: 1.0,
        },
        treasures: vec![],
    }
}

/// Cells reachable from `start` by an independent 4-neighbour flood fill.
fn reachable(map: &MapData, start: (u32, u32)) -> Vec<bool> {
    let g = *map.obstacles.grid();
    let (w, h) = (g.width_cells(), g.height_cells());
    let mut seen = vec![false; (w * h) as usize];
    let mut stack = vec![start];
    seen[(start.1 * w + start.0) as usize] = true;
    while let Some((x, y)) = stack.pop() {
        for (nx, ny) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
            if nx < w && ny < h && !map.obstacles.tree().cell_value(nx, ny) && !seen[(ny * w + nx) as usize] {
                seen[(ny * w + nx) as usize] = true;
                stack.push((nx, ny));
            }
        }
    }
    seen
}

#[test]
fn treasures_land_on_reachable_free_cells() {
    for spread in [
        Spread::Uniform,
        Spread::Clustered {
            clusters: 3,
            sigma_m: 4.0,
        },
    ] {
        let mut map = split_map();
        place(
            &mut map,
            &PlaceOptions {
                treasures: 300,
                quantity: (2, 5),
                spread,
                seed: 42,
                ..PlaceOptions::default()
            },
        )
        .unwrap();
        assert_eq!(map.treasures.len(), 300);
        let ok = reachable(&map, (5, 5));
        for t in &map.treasures {
            let (x, y) = map.obstacles.grid().cell_of(t.position).unwrap();
            assert!(ok[(y * 40 + x) as usize], "treasure at {} is not reachable", t.position);
            assert!((2..=5).contains(&t.quantity));
        }
        assert!(validate(&map).is_empty(), "{:?}", validate(&map));
    }
}

#[test]
fn home_must_be_free() {
    let mut map = split_map();
    let e = place(
        &mut map,
        &PlaceOptions {
            home: Some(DVec2::new(20.5, 10.0)),
            ..PlaceOptions::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("not a free point"), "{e}");
    place(
        &mut map,
        &PlaceOptions {
            home: Some(DVec2::new(30.0, 10.0)),
            home_radius_m: 1.5,
            treasures: 50,
            ..PlaceOptions::default()
        },
    )
    .unwrap();
    let ok = reachable(&map, (30, 10));
    for t in &map.treasures {
        assert!(t.position.x > 20.0, "treasure on the wrong side: {}", t.position);
        let (x, y) = map.obstacles.grid().cell_of(t.position).unwrap();
        assert!(ok[(y * 40 + x) as usize]);
    }
}

#[test]
fn validate_finds_every_planted_problem() {
    let mut map = split_map();
    map.home = HomeBase::Disc {
        center: DVec2::new(20.5, 10.5), // in the wall
        radius_m: 1.0,
    };
    assert!(validate(&map).contains(&Problem::HomeCenterBlocked));
    map.home = HomeBase::Disc {
        center: DVec2::new(19.2, 10.5), // free centre, disc overlaps the wall
        radius_m: 1.0,
    };
    assert_eq!(validate(&map), vec![Problem::HomeOverlapsObstacles]);
    map.home = HomeBase::Disc {
        center: DVec2::new(0.5, 10.5),
        radius_m: 1.0,
    };
    assert_eq!(validate(&map), vec![Problem::HomeOutside]);
    map.home = HomeBase::Disc {
        center: DVec2::new(5.5, 5.5),
        radius_m: 1.0,
    };
    let t = |x, y, quantity| TreasureSpec {
        position: DVec2::new(x, y),
        quantity,
    };
    map.treasures = vec![
        t(6.5, 8.5, 1),   // fine
        t(20.5, 5.5, 1),  // in the wall
        t(30.5, 5.5, 1),  // other side
        t(32.5, 22.5, 1), // inside the closed box
        t(50.0, 5.0, 1),  // outside
        t(7.5, 8.5, 0),   // empty
    ];
    assert_eq!(
        validate(&map),
        vec![
            Problem::TreasureBlocked(1),
            Problem::TreasureUnreachable(2),
            Problem::TreasureUnreachable(3),
            Problem::TreasureOutside(4),
            Problem::TreasureEmpty(5),
        ]
    );
}
