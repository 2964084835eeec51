//! Map file: exact round trips, and corrupt input that must error (never panic, never
//! allocate what the header claims).

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::Error;
use sim_core::glam::DVec2;
use sim_core::spatial::Aabb;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData, TreasureSpec};
use sim_core::world::{MAGIC, VERSION};

fn random_map(seed: u64, w: u32, h: u32) -> MapData {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let grid = Grid::new(DVec2::new(-12.5, 7.25), 0.5, w, h).unwrap();
    let density = rng.random_range(0.05..0.6);
    let obstacles = ObstacleMap::from_fn(grid, |x, y| (x / 5 + y / 7) % 4 == 0 || rng.random_bool(density));
    let e = grid.extent();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 1);
    let treasures = (0..rng.random_range(0..40))
        .map(|_| TreasureSpec {
            position: DVec2::new(rng.random_range(e.min.x..e.max.x), rng.random_range(e.min.y..e.max.y)),
            quantity: rng.random(),
        })
        .collect();
    let home = if seed.is_multiple_of(2) {
        HomeBase::Disc {
            center: e.center(),
            radius_m: 1.5,
        }
    } else {
        HomeBase::Rect(Aabb::from_corners(
            e.min + (e.max - e.min) * 0.1,
            e.min + (e.max - e.min) * 0.4,
        ))
    };
    MapData {
        obstacles,
        home,
        treasures,
    }
}

fn assert_same(a: &MapData, b: &MapData) {
    assert_eq!(a.obstacles.grid(), b.obstacles.grid());
    assert_eq!(a.home, b.home);
    assert_eq!(a.treasures, b.treasures);
    assert_eq!(a.obstacles.leaf_count(), b.obstacles.leaf_count());
    let side = a.obstacles.grid().side_cells();
    for y in 0..side {
        for x in 0..side {
            assert_eq!(a.obstacles.tree().cell_value(x, y), b.obstacles.tree().cell_value(x, y));
        }
    }
}

fn here() -> &'static Path {
    Path::new("test.stmap")
}

#[test]
fn round_trip_is_exact() {
    for (seed, w, h) in [(1, 1, 1), (2, 37, 19), (3, 64, 64), (4, 100, 3), (5, 129, 200)] {
        let map = random_map(seed, w, h);
        let bytes = map.to_bytes();
        let back = MapData::from_bytes(&bytes, here()).unwrap();
        back.obstacles.validate().unwrap();
        assert_same(&map, &back);
        assert_eq!(back.to_bytes(), bytes, "re-encoding differs for seed {seed}");
    }
}

#[test]
fn save_and_load_through_a_file() {
    let dir = std::env::temp_dir().join(format!("smartteams-mapfile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("roundtrip.stmap");
    let map = random_map(7, 90, 60);
    map.save(&path).unwrap();
    let back = MapData::load(&path).unwrap();
    assert_same(&map, &back);
    // No temporary file is left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    let missing = MapData::load(&dir.join("missing.stmap")).unwrap_err();
    assert!(missing.to_string().contains("missing.stmap"), "{missing}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_tree_costs_two_bits_a_node() {
    let map = random_map(11, 256, 256);
    let bytes = map.to_bytes();
    // L leaves = 3 I + 1 for I internal nodes; the tree has 4 I + 1 nodes.
    let leaves = map.obstacles.leaf_count();
    let nodes = 4 * (leaves - 1) / 3 + 1;
    let header = 8 + 4 + 24 + 8 + home_bytes(&map) + 4 + 20 * map.treasures.len() + 8;
    assert_eq!(bytes.len(), header + nodes.div_ceil(4) + 4);
    assert!(leaves > 10_000, "{leaves}");
}

fn home_bytes(map: &MapData) -> usize {
    match map.home {
        HomeBase::Disc { .. } => 25,
        HomeBase::Rect(_) => 33,
    }
}

#[test]
fn every_truncation_errors() {
    let bytes = random_map(3, 40, 30).to_bytes();
    for len in 0..bytes.len() {
        match MapData::from_bytes(&bytes[..len], here()) {
            Err(Error::MapFile { path, .. }) => assert_eq!(path, here()),
            other => panic!("truncated to {len} bytes: {other:?}"),
        }
    }
}

#[test]
fn every_single_bit_flip_errors() {
    let bytes = random_map(4, 24, 24).to_bytes();
    for bit in 0..bytes.len() * 8 {
        let mut bad = bytes.clone();
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(MapData::from_bytes(&bad, here()).is_err(), "flip of bit {bit} accepted");
    }
}

/// Corrupt the body but fix the checksum, so the parser itself meets the garbage.
fn with_fixed_crc(mut body: Vec<u8>) -> Vec<u8> {
    body.truncate(body.len() - 4);
    let crc = crc32(&body);
    body.extend_from_slice(&crc.to_le_bytes());
    body
}

fn crc32(bytes: &[u8]) -> u32 {
    // Bitwise CRC-32 (IEEE), written out so the test does not share the reader's code.
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn garbage_with_a_valid_checksum_errors_or_decodes_validly() {
    let bytes = random_map(5, 33, 47).to_bytes();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut errors, mut accepted) = (0, 0);
    for _ in 0..3000 {
        let mut bad = bytes.clone();
        for _ in 0..rng.random_range(1..4) {
            let i = rng.random_range(0..bad.len() - 4);
            bad[i] = rng.random();
        }
        match MapData::from_bytes(&with_fixed_crc(bad), here()) {
            Err(e) => {
                assert!(e.to_string().contains("test.stmap"), "{e}");
                errors += 1;
            }
            Ok(map) => {
                // Only changes that still describe a valid map (a treasure moved) get in.
                map.obstacles.validate().unwrap();
                map.check().unwrap();
                accepted += 1;
            }
        }
    }
    assert!(errors > 1000, "{errors} errors, {accepted} accepted");
}

fn header_with(f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut bytes = random_map(6, 16, 16).to_bytes();
    f(&mut bytes);
    with_fixed_crc(bytes)
}

fn problem(bytes: &[u8]) -> String {
    match MapData::from_bytes(bytes, here()) {
        Err(e @ Error::MapFile { .. }) => e.to_string(),
        other => panic!("expected a map file error, got {other:?}"),
    }
}

#[test]
fn bad_headers_name_the_problem() {
    let mut wrong_magic = random_map(6, 16, 16).to_bytes();
    wrong_magic[..8].copy_from_slice(b"PNG\r\n\x1a\n\0");
    assert!(problem(&wrong_magic).contains("wrong magic"));
    assert_eq!(&random_map(6, 16, 16).to_bytes()[..8], &MAGIC);

    let v = header_with(|b| b[8..10].copy_from_slice(&(VERSION + 1).to_le_bytes()));
    assert!(problem(&v).contains("unsupported format version 2"), "{}", problem(&v));

    // Absurd sizes: 4 billion cells a side; a negative cell size.
    let huge = header_with(|b| b[36..40].copy_from_slice(&u32::MAX.to_le_bytes()));
    assert!(problem(&huge).contains("bad header"), "{}", problem(&huge));
    let neg = header_with(|b| b[28..36].copy_from_slice(&(-1.0f64).to_le_bytes()));
    assert!(problem(&neg).contains("cell size"), "{}", problem(&neg));

    // A treasure count that would need 80 GB: refused before any allocation.
    let count_at = 8 + 4 + 24 + 8 + 25;
    let many = header_with(|b| b[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes()));
    assert!(
        problem(&many).contains("claims 4294967295 treasures"),
        "{}",
        problem(&many)
    );
}

#[test]
fn absurd_node_counts_are_refused() {
    let map = random_map(8, 16, 16);
    let bytes = map.to_bytes();
    let nodes_at = 8 + 4 + 24 + 8 + home_bytes(&map) + 4 + 20 * map.treasures.len();
    for claim in [0u64, 2, u64::MAX, (1 << 40) + 1] {
        let mut bad = bytes.clone();
        bad[nodes_at..nodes_at + 8].copy_from_slice(&claim.to_le_bytes());
        let msg = problem(&with_fixed_crc(bad));
        assert!(
            msg.contains("node count") || msg.contains("truncated"),
            "{claim}: {msg}"
        );
    }
}
