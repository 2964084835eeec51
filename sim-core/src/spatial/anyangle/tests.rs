use glam::DVec2;
use proptest::prelude::*;

use super::reference::{segment_is_legal, shortest_length};
use super::{AnyAnglePath, AnyAnglePlanner, NoPath};
use crate::spatial::{Grid, ObstacleMap};

fn map_of(width: u32, height: u32, cells: &[bool]) -> ObstacleMap {
    let grid = Grid::new(DVec2::ZERO, 1.0, width, height).unwrap();
    ObstacleMap::from_fn(grid, |x, y| cells[(y * width + x) as usize])
}

fn blocked_fn(width: u32, height: u32, cells: &[bool]) -> impl Fn(i64, i64) -> bool + '_ {
    move |x, y| {
        x < 0 || y < 0 || x >= i64::from(width) || y >= i64::from(height) || cells[(y * i64::from(width) + x) as usize]
    }
}

#[allow(clippy::cast_possible_truncation)] // Waypoints of a point robot are lattice points.
fn lattice(p: DVec2) -> (i64, i64) {
    assert_eq!(p, p.round(), "waypoint {p} is not a lattice point");
    (p.x as i64, p.y as i64)
}

fn point(p: (i64, i64)) -> DVec2 {
    DVec2::new(p.0 as f64, p.1 as f64)
}

/// Width, height, blocked cells (row 0 at the bottom) and two lattice points.
type SmallMap = (u32, u32, Vec<bool>, (i64, i64), (i64, i64));

fn small_map() -> impl Strategy<Value = SmallMap> {
    (2u32..=7, 2u32..=7, 0.0f64..0.45).prop_flat_map(|(w, h, density)| {
        (
            Just(w),
            Just(h),
            proptest::collection::vec(proptest::bool::weighted(density), (w * h) as usize),
            (0..=i64::from(w), 0..=i64::from(h)),
            (0..=i64::from(w), 0..=i64::from(h)),
        )
    })
}

/// Anya's answer for a planner's checked ends: the search's own result, never the
/// visibility-graph fallback (a failed leg is a test failure here).
fn anya(planner: &AnyAnglePlanner, from: DVec2, to: DVec2) -> Result<AnyAnglePath, NoPath> {
    if !planner.is_leg_clear(from, from) {
        return Err(NoPath::StartBlocked(from));
    }
    if !planner.is_leg_clear(to, to) {
        return Err(NoPath::GoalBlocked(to));
    }
    if planner.is_leg_clear(from, to) {
        return planner.path(from, to);
    }
    planner
        .anya_path(from, to)
        .expect("every leg of Anya's path passes the exact sight test")
}

/// The visibility graph's answer for the same ends (what Anya is held to): its search where
/// one is needed, `path` where an end is blocked or the ends see each other.
fn reference(planner: &AnyAnglePlanner, from: DVec2, to: DVec2) -> Result<AnyAnglePath, NoPath> {
    if planner.is_leg_clear(from, from) && planner.is_leg_clear(to, to) && !planner.is_leg_clear(from, to) {
        planner.graph_path(from, to)
    } else {
        planner.path(from, to)
    }
}

/// Anya's answer `fast` agrees with the visibility graph's `slow`: the same length (to 1e-9
/// relative) or the same reason for no path; a found path runs from `from` to `to`, is no
/// shorter than the straight line, and every leg passes the exact sight test.
fn agree(
    planner: &AnyAnglePlanner,
    from: DVec2,
    to: DVec2,
    fast: &Result<AnyAnglePath, NoPath>,
    slow: &Result<AnyAnglePath, NoPath>,
) -> Result<(), TestCaseError> {
    match (fast, slow) {
        (Ok(f), Ok(s)) => {
            prop_assert!(
                (f.length_m - s.length_m).abs() <= 1e-9 * s.length_m.max(1.0),
                "Anya {} vs graph {}: {:?} vs {:?}",
                f.length_m,
                s.length_m,
                f.waypoints,
                s.waypoints
            );
            prop_assert!(f.length_m >= from.distance(to) - 1e-12);
            prop_assert_eq!(f.waypoints[0], from);
            prop_assert_eq!(*f.waypoints.last().unwrap(), to);
            for leg in f.waypoints.windows(2) {
                prop_assert!(planner.is_leg_clear(leg[0], leg[1]), "illegal leg {leg:?}");
            }
        }
        (Err(a), Err(b)) => prop_assert_eq!(a, b),
        _ => prop_assert!(false, "Anya {fast:?} vs graph {slow:?}"),
    }
    Ok(())
}

/// Anya's answer between lattice points `s` and `g` agrees with the brute force over all
/// lattice points (which holds every shortest path, as those bend only at cell corners), and
/// each leg is legal by the reference's cell-by-cell test.
fn agree_with_brute_force(
    (w, h, cells): (u32, u32, &[bool]),
    s: (i64, i64),
    g: (i64, i64),
    fast: &Result<AnyAnglePath, NoPath>,
) -> Result<(), TestCaseError> {
    let blocked = blocked_fn(w, h, cells);
    let best = shortest_length(&blocked, i64::from(w), i64::from(h), s, g);
    match fast {
        Ok(p) => {
            let best = best.expect("Anya found a path the brute force did not");
            prop_assert!(
                (p.length_m - best).abs() < 1e-9,
                "Anya {} vs brute force {best}",
                p.length_m
            );
            for leg in p.waypoints.windows(2) {
                prop_assert!(
                    segment_is_legal(&blocked, lattice(leg[0]), lattice(leg[1])),
                    "illegal leg {leg:?}"
                );
            }
        }
        Err(e) => prop_assert!(
            best.is_none() || matches!(e, NoPath::StartBlocked(_) | NoPath::GoalBlocked(_)),
            "Anya says {e}, brute force finds {best:?}"
        ),
    }
    Ok(())
}

/// Point robots (Anya, called directly) between lattice points a path may touch, drawn
/// among those of maps up to 8 × 8: the brute force's length exactly, and every leg legal by
/// the reference. Cases that need a search (the ends do not see each other) are counted, so that
/// the check cannot quietly stop running.
#[test]
fn anya_between_corners_is_as_short_as_brute_force() {
    use proptest::sample::Index;
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let maps = (2u32..=8, 2u32..=8, 0.0f64..0.45).prop_flat_map(|(w, h, density)| {
        (
            Just(w),
            Just(h),
            proptest::collection::vec(proptest::bool::weighted(density), (w * h) as usize),
            any::<Index>(),
            any::<Index>(),
        )
    });
    let config = Config {
        cases: 1500,
        rng_seed: RngSeed::Fixed(1214),
        ..Config::default()
    };
    let searched = std::cell::Cell::new(0);
    TestRunner::new(config)
        .run(&maps, |(w, h, cells, si, gi)| {
            let planner = AnyAnglePlanner::build(&map_of(w, h, &cells), 0.0).unwrap();
            let points: Vec<(i64, i64)> = (0..=i64::from(h))
                .flat_map(|y| (0..=i64::from(w)).map(move |x| (x, y)))
                .filter(|&p| planner.is_leg_clear(point(p), point(p)))
                .collect();
            if points.is_empty() {
                return Ok(());
            }
            let (s, g) = (points[si.index(points.len())], points[gi.index(points.len())]);
            if !planner.is_leg_clear(point(s), point(g)) {
                searched.set(searched.get() + 1);
            }
            let fast = anya(&planner, point(s), point(g));
            agree_with_brute_force((w, h, &cells), s, g, &fast)
        })
        .unwrap();
    assert!(searched.get() >= 300, "only {} of 1500 cases searched", searched.get());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(12), ..ProptestConfig::default() })]

    /// Linking every corner up front (`link_all`, pairs tested once on all threads) gives
    /// the graph that searches link corner by corner on the way, for point robots and robots
    /// with a radius, and the same graph search.
    #[test]
    fn link_all_gives_the_graph_linked_on_the_way((w, h, cells, s, g) in small_map(), r in prop_oneof![Just(0.0), 0.05f64..0.45]) {
        let map = map_of(w, h, &cells);
        let lazy = AnyAnglePlanner::build(&map, r).unwrap();
        let all = AnyAnglePlanner::build(&map, r).unwrap();
        all.link_all();
        let (from, to) = (point(s), point(g));
        prop_assert_eq!(reference(&lazy, from, to), reference(&all, from, to));
        let (lg, ag) = (lazy.graph().unwrap(), all.graph().unwrap());
        for u in 0..lg.vertices.len() {
            prop_assert_eq!(lazy.neighbours(lg, u), all.neighbours(ag, u), "corner {}", u);
        }
        prop_assert_eq!(lazy.edge_count(), all.edge_count());
    }

    /// The planner's own leg test agrees with the reference on every pair of lattice points.
    #[test]
    fn leg_tests_agree_with_the_reference((w, h, cells, a, b) in small_map()) {
        let map = map_of(w, h, &cells);
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        let blocked = blocked_fn(w, h, &cells);
        prop_assert_eq!(planner.is_leg_clear(point(a), point(b)), segment_is_legal(&blocked, a, b));
    }

    /// Between half-integer points too (the floating-point walk): a leg on the map equals
    /// the reference's verdict on the map refined to half cells (each cell split in four),
    /// which changes no rule's outcome.
    #[test]
    fn leg_tests_between_half_cells_agree_with_the_refined_reference((w, h, cells, a, b) in small_map(), odd in (0i64..2, 0i64..2, 0i64..2, 0i64..2)) {
        let map = map_of(w, h, &cells);
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        let blocked = blocked_fn(w, h, &cells);
        let fine = |x: i64, y: i64| blocked(x.div_euclid(2), y.div_euclid(2));
        // Points on the half-cell lattice, within the map.
        let a2 = ((2 * a.0 + odd.0).min(2 * i64::from(w)), (2 * a.1 + odd.1).min(2 * i64::from(h)));
        let b2 = ((2 * b.0 + odd.2).min(2 * i64::from(w)), (2 * b.1 + odd.3).min(2 * i64::from(h)));
        prop_assert_eq!(planner.is_leg_clear(point(a2) / 2.0, point(b2) / 2.0), segment_is_legal(&fine, a2, b2), "{:?} -> {:?}", a2, b2);
    }

    /// A robot with a radius keeps it clear on every leg (by the map's exact swept-disc test)
    /// and never beats the point robot's optimum.
    #[test]
    fn robots_keep_their_radius_clear((w, h, cells, _, _) in small_map(), r in 0.05f64..0.45, s in (0.0f64..1.0, 0.0f64..1.0), g in (0.0f64..1.0, 0.0f64..1.0)) {
        let map = map_of(w, h, &cells);
        let size = DVec2::new(f64::from(w), f64::from(h));
        let (s, g) = (DVec2::new(s.0, s.1) * size, DVec2::new(g.0, g.1) * size);
        let planner = AnyAnglePlanner::build(&map, r).unwrap();
        if let Ok(path) = planner.path(s, g) {
            for leg in path.waypoints.windows(2) {
                prop_assert!(map.is_swept_disc_free(leg[0], leg[1], r), "leg {leg:?} comes closer than {r}");
            }
            let point_robot = AnyAnglePlanner::build(&map, 0.0).unwrap();
            let best = point_robot.path(s, g).expect("a round robot's path is a point's path too");
            prop_assert!(path.length_m >= best.length_m - 1e-9);
        }
    }
}

#[test]
fn diagonal_touch_is_not_a_passage() {
    // Blocked (0, 0) and (1, 1): the only way from the top-left to the bottom-right corner
    // is through the point where they touch.
    let cells = [true, false, false, true];
    let planner = AnyAnglePlanner::build(&map_of(2, 2, &cells), 0.0).unwrap();
    let (from, to) = (DVec2::new(0.0, 2.0), DVec2::new(2.0, 0.0));
    assert_eq!(planner.path(from, to), Err(NoPath::Unreachable(from, to)));
    // Along the free cell's outer edge to the corner of the blocked one is fine.
    let p = planner.path(from, DVec2::new(1.0, 2.0)).unwrap();
    assert!((p.length_m - 1.0).abs() < 1e-12);
}

#[test]
fn an_edge_between_two_blocked_cells_is_not_a_passage() {
    // A 3 × 2 map with its bottom row blocked: the line y = 1 runs along blocked cells'
    // tops (allowed); the line x = 1 between (0, 0) and (1, 0) is shared by two blocked cells.
    let cells = [true, true, true, false, false, false];
    let planner = AnyAnglePlanner::build(&map_of(3, 2, &cells), 0.0).unwrap();
    assert!(planner.is_leg_clear(DVec2::new(0.0, 1.0), DVec2::new(3.0, 1.0)));
    assert!(!planner.is_leg_clear(DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0)));
    assert_eq!(
        planner.path(DVec2::new(1.0, 0.5), DVec2::new(1.0, 2.0)),
        Err(NoPath::StartBlocked(DVec2::new(1.0, 0.5)))
    );
    let goal = DVec2::new(2.5, 0.5);
    assert_eq!(planner.path(DVec2::new(0.5, 1.5), goal), Err(NoPath::GoalBlocked(goal)));
}

#[test]
fn a_wall_across_the_map_leaves_the_far_side_unreachable() {
    let grid = Grid::new(DVec2::ZERO, 0.5, 10, 10).unwrap();
    let map = ObstacleMap::from_fn(grid, |x, _| x == 4);
    let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
    let (a, b) = (DVec2::new(0.5, 0.5), DVec2::new(4.5, 4.5));
    assert_eq!(planner.path(a, b), Err(NoPath::Unreachable(a, b)));
}

#[test]
fn a_gap_passes_robots_narrower_than_it() {
    // A wall across a 5 × 7 map at row 3 with a one-cell gap at column 2 (cells of 1 m).
    let grid = Grid::new(DVec2::ZERO, 1.0, 5, 7).unwrap();
    let map = ObstacleMap::from_fn(grid, |x, y| y == 3 && x != 2);
    let (a, b) = (DVec2::new(2.5, 1.0), DVec2::new(2.5, 6.0));
    let thin = AnyAnglePlanner::build(&map, 0.3).unwrap().path(a, b).unwrap();
    assert!(
        (thin.length_m - 5.0).abs() < 1e-12,
        "straight through the gap: {thin:?}"
    );
    let wide = AnyAnglePlanner::build(&map, 0.6).unwrap();
    assert_eq!(wide.path(a, b), Err(NoPath::Unreachable(a, b)));
    // Round a single block, a robot of radius 0.25 passes its corners 0.25 m out on each axis.
    let grid = Grid::new(DVec2::ZERO, 1.0, 5, 3).unwrap();
    let map = ObstacleMap::from_fn(grid, |x, y| x == 2 && y == 1);
    let planner = AnyAnglePlanner::build(&map, 0.25).unwrap();
    let p = planner.path(DVec2::new(0.5, 1.5), DVec2::new(4.5, 1.5)).unwrap();
    assert_eq!(p.waypoints.len(), 4, "{p:?}");
    assert!(
        p.waypoints[1].distance(DVec2::new(1.75, 2.25)) < 1e-12
            || p.waypoints[1].distance(DVec2::new(1.75, 0.75)) < 1e-12,
        "{p:?}"
    );
    let expected = 2.0 * 1.25f64.hypot(0.75) + 1.5;
    assert!((p.length_m - expected).abs() < 1e-12, "{} vs {expected}", p.length_m);
}

#[test]
fn nonsense_radii_are_refused() {
    let map = map_of(2, 2, &[false; 4]);
    for r in [-1.0, f64::NAN, f64::INFINITY] {
        let e = AnyAnglePlanner::build(&map, r).unwrap_err().to_string();
        assert!(e.contains("radius"), "{e}");
    }
}

/// Width, height, blocked cells and two points on the quarter-cell lattice (ends on cell
/// corners, edges, centres and between).
type QuarterMap = (u32, u32, Vec<bool>, (i64, i64), (i64, i64));

fn quarter_map(max_side: u32) -> impl Strategy<Value = QuarterMap> {
    (2u32..=max_side, 2u32..=max_side, 0.0f64..0.5).prop_flat_map(|(w, h, density)| {
        (
            Just(w),
            Just(h),
            proptest::collection::vec(proptest::bool::weighted(density), (w * h) as usize),
            (0..=4 * i64::from(w), 0..=4 * i64::from(h)),
            (0..=4 * i64::from(w), 0..=4 * i64::from(h)),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, rng_seed: proptest::test_runner::RngSeed::Fixed(1212), ..ProptestConfig::default() })]

    /// Anya (radius 0) gives the visibility-graph search's length exactly (to 1e-9
    /// relative), between any two points of the quarter-cell lattice, reaches what it
    /// reaches, is never shorter than the straight line, and every leg passes the exact
    /// sight test; the brute force over all lattice points agrees for ends on cell corners.
    #[test]
    fn anya_equals_the_visibility_graph_and_the_brute_force((w, h, cells, s4, g4) in quarter_map(12)) {
        let map = map_of(w, h, &cells);
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        let (from, to) = (point(s4) / 4.0, point(g4) / 4.0);
        let fast = anya(&planner, from, to);
        agree(&planner, from, to, &fast, &reference(&planner, from, to))?;
        if s4.0 % 4 == 0 && s4.1 % 4 == 0 && g4.0 % 4 == 0 && g4.1 % 4 == 0 && w * h <= 64 {
            agree_with_brute_force((w, h, &cells), (s4.0 / 4, s4.1 / 4), (g4.0 / 4, g4.1 / 4), &fast)?;
        }
    }

    /// Same on larger maps with few, long walls (long cones, many bends), ends anywhere.
    #[test]
    fn anya_equals_the_visibility_graph_on_sparse_maps((w, h, cells, _, _) in quarter_map(40), s in (0.0f64..1.0, 0.0f64..1.0), g in (0.0f64..1.0, 0.0f64..1.0)) {
        // Thin the cells out to a sparse map: keep one blocked cell in three, in segments.
        let cells: Vec<bool> = cells.iter().enumerate().map(|(i, &b)| b && (i / 3) % 3 == 0).collect();
        let map = map_of(w, h, &cells);
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        let size = DVec2::new(f64::from(w), f64::from(h));
        let (from, to) = (DVec2::new(s.0, s.1) * size, DVec2::new(g.0, g.1) * size);
        let fast = anya(&planner, from, to);
        agree(&planner, from, to, &fast, &reference(&planner, from, to))?;
    }

    /// The raster's word-at-a-time scans find what a cell-by-cell look finds.
    #[test]
    fn raster_scans_agree_with_cell_by_cell((w, h, cells, _, _) in quarter_map(150), y in -1i64..152, x in -2i64..152) {
        let map = map_of(w, h, &cells);
        let r = super::raster::CellRaster::from_obstacles(&map).unwrap();
        let far = i64::from(w).max(x) + 3;
        prop_assert_eq!(r.next_blocked(y, x), (x..=far).find(|&k| r.blocked(k, y)).unwrap());
        prop_assert_eq!(r.prev_blocked(y, x), (x.min(-1)..=x).rev().find(|&k| r.blocked(k, y)).unwrap());
        prop_assert_eq!(r.next_free(y, x), (x..far).find(|&k| !r.blocked(k, y)));
        prop_assert_eq!(r.prev_free(y, x), (-1..=x).rev().find(|&k| !r.blocked(k, y)));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, rng_seed: proptest::test_runner::RngSeed::Fixed(1213), ..ProptestConfig::default() })]

    /// Two points a path may touch are in the same region exactly when the brute force
    /// joins them (the regions answer unreachable queries without a search).
    #[test]
    fn regions_agree_with_brute_force_reachability((w, h, cells, s, g) in small_map()) {
        let map = map_of(w, h, &cells);
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        let blocked = blocked_fn(w, h, &cells);
        let (ps, pg) = (point(s), point(g));
        prop_assume!(planner.is_leg_clear(ps, ps) && planner.is_leg_clear(pg, pg));
        let regions = super::regions::Regions::new(&super::raster::CellRaster::from_obstacles(&map).unwrap());
        let best = shortest_length(&blocked, i64::from(w), i64::from(h), s, g);
        prop_assert!(regions.of_point(ps).is_some() && regions.of_point(pg).is_some());
        prop_assert_eq!(regions.of_point(ps) == regions.of_point(pg), best.is_some());
    }
}

/// A point robot's query on a planner just built costs what the search sweeps, not a sight
/// test per corner of the map. On a 96 × 96 map of 12-cell rooms with doors and pillars, 60
/// queries between cell centres link no corner at all (the visibility graph is never
/// built), and give the visibility graph's lengths (Anya asked directly, and `path` gives
/// the same).
#[test]
fn point_queries_build_no_visibility_graph_and_match_it() {
    let grid = Grid::new(DVec2::ZERO, 1.0, 96, 96).unwrap();
    // Walls on every 12th row and column, a 2-cell door in each wall segment placed by a
    // fixed hash, and a pillar in each room.
    let door = |a: u32, b: u32| (a.wrapping_mul(7919) ^ b.wrapping_mul(104_729)) % 9 + 1;
    let map = ObstacleMap::from_fn(grid, |x, y| {
        let wall_x = x % 12 == 0 && !(y % 12 >= door(x, y / 12) && y % 12 < door(x, y / 12) + 2);
        let wall_y = y % 12 == 0 && !(x % 12 >= door(y + 1, x / 12) && x % 12 < door(y + 1, x / 12) + 2);
        let pillar = x % 12 == 6 && y % 12 == 5;
        wall_x || wall_y || pillar
    });
    let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
    let reference_planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
    let mut state = 12u64;
    let mut next = |n: u32| {
        // A fixed linear congruential sequence: the same queries on every run.
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        u32::try_from(state >> 33).unwrap() % n
    };
    let (mut found, mut bends) = (0, 0);
    for _ in 0..60 {
        let from = grid.cell_center(next(96), next(96));
        let to = grid.cell_center(next(96), next(96));
        let fast = anya(&planner, from, to);
        assert_eq!(planner.path(from, to), fast);
        agree(&planner, from, to, &fast, &reference(&reference_planner, from, to)).unwrap();
        if let Ok(f) = &fast {
            found += 1;
            bends += f.waypoints.len() - 2;
        }
    }
    assert_eq!(planner.edge_count(), 0, "a point robot's queries linked corners");
    assert!(
        planner.graph.get().is_none(),
        "a point robot's queries built the visibility graph"
    );
    assert!(reference_planner.edge_count() > 0);
    // The queries are not trivial: most are answered, round many corners.
    assert!(found >= 40 && bends >= 100, "{found} paths, {bends} bends");
}

/// Point robots' planners accept maps with any number of corners (their searches link
/// none, and no corner list is kept); the visibility graph they would fall back on refuses
/// more than `MAX_VERTICES` (`Undecided`), as robots with a radius do at build.
#[test]
fn point_planners_take_maps_with_more_corners_than_the_graph_limit() {
    // Pillars (single blocked cells) at odd columns and rows: four convex corners each.
    let pillars = |n: u32| {
        ObstacleMap::from_fn(Grid::new(DVec2::ZERO, 1.0, n, n).unwrap(), |x, y| {
            x % 2 == 1 && y % 2 == 1
        })
    };
    // From the map's corner (0, 0) to (n, n - 1), n even. The diagonal y = x - 1 runs
    // through cells (k, k - 1), never a pillar, touching pillars only at their corners, and
    // ends at the goal; the straight line from the start first meets it at (2, 1) (a steeper
    // one enters pillar (1, 1)). So the optimum is √5 + (n - 2)√2, which the brute force
    // confirms on small maps of the pattern.
    let optimum = |n: u32| 5f64.sqrt() + f64::from(n - 2) * 2f64.sqrt();
    for n in [4, 6, 8] {
        let cells: Vec<bool> = (0..n * n).map(|i| (i % n) % 2 == 1 && (i / n) % 2 == 1).collect();
        let best = shortest_length(
            &blocked_fn(n, n, &cells),
            i64::from(n),
            i64::from(n),
            (0, 0),
            (i64::from(n), i64::from(n) - 1),
        );
        assert!(
            (best.unwrap() - optimum(n)).abs() < 1e-12,
            "{n}: {best:?} vs {}",
            optimum(n)
        );
    }
    let map = pillars(520);
    let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
    assert!(planner.vertex_count() > super::MAX_VERTICES);
    let (from, to) = (DVec2::new(0.0, 0.0), DVec2::new(520.0, 519.0));
    let p = anya(&planner, from, to).unwrap();
    assert_eq!(planner.path(from, to).as_ref(), Ok(&p));
    assert!(
        (p.length_m - optimum(520)).abs() < 1e-9,
        "{} vs {}",
        p.length_m,
        optimum(520)
    );
    // To (2, 1), then along the diagonal (Anya may list corners it passes straight through).
    assert_eq!(p.waypoints[1], DVec2::new(2.0, 1.0), "{:?}", p.waypoints);
    assert!(
        p.waypoints[1..].iter().map(|&w| lattice(w)).all(|(x, y)| x - y == 1),
        "{:?}",
        p.waypoints
    );
    // No corner list was kept, and the fallback refuses rather than link 269,361 corners.
    assert!(planner.graph.get().is_none());
    assert_eq!(planner.graph_path(from, to), Err(NoPath::Undecided(from, to)));
    planner.link_all();
    assert_eq!(planner.edge_count(), 0);
    let e = AnyAnglePlanner::build(&map, 0.1).unwrap_err().to_string();
    assert!(e.contains("corners"), "{e}");
}

/// A query's memory follows what it sweeps, not the map: a short query on a 2048² map
/// leaves a few kilobytes of scratch, not a buffer per lattice point.
#[test]
fn a_query_on_a_large_map_keeps_little_scratch() {
    let n = 2048;
    let map = ObstacleMap::from_fn(Grid::new(DVec2::ZERO, 1.0, n, n).unwrap(), |x, y| {
        x == 1000 && (990..1010).contains(&y)
    });
    let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
    let (from, to) = (DVec2::new(995.5, 1000.5), DVec2::new(1005.5, 1000.5));
    let p = anya(&planner, from, to).unwrap();
    assert_eq!(p.waypoints.len(), 4, "over the wall's two top corners: {p:?}");
    let bytes = super::anya::scratch_bytes();
    assert!(bytes < 1 << 20, "{bytes} bytes of scratch");
}
