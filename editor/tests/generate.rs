//! Generator densities and structure, checked cell by cell.

use editor::generate::{GenerateOptions, Kind, generate};
use sim_core::spatial::Components;

fn opts(w: f64, h: f64, seed: u64, density: Option<f64>) -> GenerateOptions {
    GenerateOptions {
        width_m: w,
        height_m: h,
        seed,
        density,
        ..GenerateOptions::default()
    }
}

fn blocked_fraction(map: &sim_core::spatial::ObstacleMap) -> f64 {
    let g = map.grid();
    // Count cells one by one (independent of the tree's area sums).
    let mut n = 0u64;
    for y in 0..g.height_cells() {
        for x in 0..g.width_cells() {
            n += u64::from(map.tree().cell_value(x, y));
        }
    }
    n as f64 / (f64::from(g.width_cells()) * f64::from(g.height_cells()))
}

#[test]
fn white_noise_density_within_1_percent() {
    // 65,536 cells: the binomial standard deviation is < 0.2 %.
    for d in [0.05, 0.3, 0.6] {
        let map = generate(Kind::Noise, &opts(256.0, 256.0, 3, Some(d))).unwrap();
        let f = blocked_fraction(&map);
        assert!((f - d).abs() < 0.01, "density {d}: got {f}");
    }
}

#[test]
fn fractal_density_within_1_percent() {
    // Small maps use every cell for the threshold: exact up to rounding. Larger ones sample.
    for (w, d) in [(200.0, 0.3), (1500.0, 0.2)] {
        let mut o = opts(w, w * 0.75, 5, Some(d));
        o.cell_m = if w > 1000.0 { 2.0 } else { 1.0 };
        let map = generate(Kind::Fractal, &o).unwrap();
        let f = blocked_fraction(&map);
        assert!((f - d).abs() < 0.01, "density {d}: got {f}");
        assert!(map.validate().is_ok());
    }
}

#[test]
fn mesas_density_within_tolerance() {
    // Boolean model + conservative rasterisation: within 0.05 of the target on a map much
    // larger than the obstacles.
    let mut o = opts(1200.0, 1200.0, 11, Some(0.15));
    o.scale_m = Some(30.0);
    let map = generate(Kind::Mesas, &o).unwrap();
    let f = blocked_fraction(&map);
    assert!((f - 0.15).abs() < 0.05, "got {f}");
}

#[test]
fn caves_are_cave_like() {
    let map = generate(Kind::Caves, &opts(160.0, 120.0, 2, None)).unwrap();
    let f = blocked_fraction(&map);
    assert!((0.2..0.7).contains(&f), "cave rock fraction {f}");
}

#[test]
fn maze_is_one_connected_corridor_system() {
    let map = generate(Kind::Maze, &opts(63.0, 41.0, 4, None)).unwrap();
    let c = Components::new(map.tree());
    assert_eq!(c.count(), 1, "a perfect maze has one free component");
    assert!(blocked_fraction(&map) > 0.3);
}

#[test]
fn rooms_are_all_connected_through_doors() {
    for seed in 0..5 {
        let map = generate(Kind::Rooms, &opts(120.0, 90.0, seed, None)).unwrap();
        let c = Components::new(map.tree());
        assert_eq!(c.count(), 1, "seed {seed}: every room is reachable");
        let g = map.grid();
        // The outer wall is closed.
        for x in 0..g.width_cells() {
            assert!(map.tree().cell_value(x, 0) && map.tree().cell_value(x, g.height_cells() - 1));
        }
        assert!(blocked_fraction(&map) > 0.05);
    }
}

/// The map file of one 100 m × 80 m map of `kind` from `seed`.
fn map_bytes(kind: Kind, seed: u64) -> Vec<u8> {
    sim_core::world::MapData {
        obstacles: generate(kind, &opts(100.0, 80.0, seed, None)).unwrap(),
        home: sim_core::world::HomeBase::Disc {
            center: sim_core::glam::DVec2::new(1.0, 1.0),
            radius_m: 1.0,
        },
        treasures: vec![],
    }
    .to_bytes()
}

/// CRC-32 of each generator's 100 m × 80 m map from seed 9. These change only when a
/// generator's output changes, in a commit that says why.
const PINNED_MAPS: [(Kind, u32); 6] = [
    (Kind::Noise, 0x85b0_6613),
    (Kind::Fractal, 0x8bb9_29f9),
    (Kind::Caves, 0xb299_99c7),
    (Kind::Maze, 0x2f7e_af30),
    (Kind::Rooms, 0xa852_a8d2),
    (Kind::Mesas, 0x2e7d_1343),
];

#[test]
fn generators_give_their_pinned_maps_and_other_seeds_other_maps() {
    let mut wrong = Vec::new();
    for (kind, crc) in PINNED_MAPS {
        let map = map_bytes(kind, 9);
        assert_eq!(map, map_bytes(kind, 9), "{kind:?} twice from one seed");
        assert_ne!(map, map_bytes(kind, 10), "{kind:?} from seeds 9 and 10");
        // The file ends with a CRC-32 of the rest (the CRC of the whole is a constant).
        let got = crc32fast::hash(&map[..map.len() - 4]);
        if got != crc {
            wrong.push(format!("(Kind::{kind:?}, 0x{got:08x}),"));
        }
    }
    assert!(
        wrong.is_empty(),
        "maps differ from the pinned ones:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn bad_parameters_are_refused() {
    assert!(generate(Kind::Noise, &opts(100.0, 100.0, 1, Some(1.5))).is_err());
    assert!(generate(Kind::Fractal, &opts(-5.0, 100.0, 1, None)).is_err());
    // A raster generator refuses a 10^10-cell map instead of allocating it.
    let e = generate(Kind::Caves, &opts(200_000.0, 200_000.0, 1, None)).unwrap_err();
    assert!(e.to_string().contains("raster"), "{e}");
}

/// An option a generator does not use is refused, not ignored; a cell size that is not
/// positive is named as such (it read as a count of cells too large).
#[test]
fn options_a_generator_does_not_use_are_refused() {
    let with = |f: fn(&mut GenerateOptions)| {
        let mut o = opts(64.0, 48.0, 1, None);
        f(&mut o);
        o
    };
    let cases: [(Kind, GenerateOptions, &str); 5] = [
        (
            Kind::Maze,
            with(|o| o.density = Some(0.5)),
            "--density does not apply to the maze generator",
        ),
        (
            Kind::Rooms,
            with(|o| o.density = Some(0.5)),
            "--density does not apply to the rooms generator",
        ),
        (
            Kind::Noise,
            with(|o| o.scale_m = Some(4.0)),
            "--scale-m does not apply to the noise generator",
        ),
        (
            Kind::Caves,
            with(|o| o.count = Some(3)),
            "--count does not apply to the caves generator",
        ),
        (
            Kind::Noise,
            with(|o| o.cell_m = -1.0),
            "cell size must be positive, got -1 m",
        ),
    ];
    for (kind, o, want) in cases {
        let e = generate(kind, &o).unwrap_err().to_string();
        assert!(e.contains(want), "{kind:?}: {e}");
    }
    // The options each uses are taken.
    assert!(
        generate(
            Kind::Mesas,
            &with(|o| {
                o.density = Some(0.1);
                o.scale_m = Some(8.0);
                o.count = Some(5);
            })
        )
        .is_ok()
    );
}
