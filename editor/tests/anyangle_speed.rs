//! Opt-in timing of any-angle queries (issue 12): not a test of results but a measuring
//! harness that needs no Rerun build. `SMARTTEAMS_ANYANGLE_MAPS` lists maps (`.stmap`, or a
//! Moving AI `.map`, optionally `map.map=queries.scen`), comma-separated; each runs the
//! queries `smartteams-bench any-angle` runs (the scenario's, or 300 random pairs of free cell
//! centres, seed 1), first ten each on a planner just built, then all on one planner.
//! `SMARTTEAMS_ANYANGLE_LINK=1` links the whole visibility graph first, as the bench did;
//! `SMARTTEAMS_ANYANGLE_QUERIES=N` runs N random queries instead of 300.
//!
//! `cargo test --profile ci -p editor --test anyangle_speed -- --ignored --nocapture`

use std::path::Path;
use std::time::Instant;

use editor::import::{ImportOptions, import};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::glam::DVec2;
use sim_core::spatial::{AnyAnglePlanner, ObstacleMap};
use sim_core::world::MapData;

fn load(path: &Path) -> ObstacleMap {
    if path.extension().is_some_and(|e| e == "map") {
        import(path, &ImportOptions::default()).unwrap()
    } else {
        MapData::load(path).unwrap().obstacles
    }
}

/// As `scale::paths::random_queries`.
fn random_queries(map: &ObstacleMap, count: usize, seed: u64) -> Vec<(DVec2, DVec2)> {
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
    (0..count).map(|_| (free_centre(), free_centre())).collect()
}

/// As `scale::paths::read_scenario` (corners, y down).
fn scenario(path: &Path, map: &ObstacleMap) -> Vec<(DVec2, DVec2)> {
    let g = map.grid();
    let top = f64::from(g.height_cells());
    let corner =
        |x: &str, y: &str| g.origin() + DVec2::new(x.parse().unwrap(), top - y.parse::<f64>().unwrap()) * g.cell_m();
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with("version") && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            (corner(f[4], f[5]), corner(f[6], f[7]))
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
#[ignore = "timing harness: SMARTTEAMS_ANYANGLE_MAPS"]
fn anyangle_query_times() {
    let Ok(list) = std::env::var("SMARTTEAMS_ANYANGLE_MAPS") else {
        println!("skipped: SMARTTEAMS_ANYANGLE_MAPS is not set");
        return;
    };
    let link = std::env::var("SMARTTEAMS_ANYANGLE_LINK").is_ok_and(|v| v == "1");
    let count = std::env::var("SMARTTEAMS_ANYANGLE_QUERIES").map_or(300, |v| v.parse().unwrap());
    for item in list.split(',') {
        let (map_path, scen) = match item.split_once('=') {
            Some((m, s)) => (Path::new(m), Some(Path::new(s))),
            None => (Path::new(item), None),
        };
        let map = load(map_path);
        let queries = match scen {
            Some(s) => scenario(s, &map),
            None => random_queries(&map, count, 1),
        };
        let mut cold = Vec::new();
        let cold_n = std::env::var("SMARTTEAMS_ANYANGLE_COLD").map_or(10, |v| v.parse().unwrap());
        for &(a, b) in queries.iter().take(cold_n) {
            let fresh = AnyAnglePlanner::build(&map, 0.0).unwrap();
            let t = Instant::now();
            let _ = fresh.path(a, b);
            cold.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let planner = AnyAnglePlanner::build(&map, 0.0).unwrap();
        if link {
            planner.link_all();
        }
        let (mut times, mut total_len, mut reachable) = (Vec::new(), 0.0, 0);
        for &(a, b) in &queries {
            let t = Instant::now();
            let found = planner.path(a, b);
            let ms = t.elapsed().as_secs_f64() * 1e3;
            if ms > 200.0 {
                println!("slow query {a} -> {b}: {ms:.1} ms");
            }
            times.push(ms);
            if let Ok(p) = found {
                reachable += 1;
                total_len += p.length_m;
            }
        }
        let max = times.iter().copied().fold(0.0, f64::max);
        #[allow(clippy::cast_precision_loss)]
        let mean = times.iter().sum::<f64>() / times.len() as f64;
        println!(
            "{}: first query on a new planner: mean {:.2} ms, median {:.2} ms, slowest {:.2} ms | {} queries ({reachable} reachable, total length {total_len:.6}): mean {mean:.3} ms, median {:.3} ms, slowest {max:.3} ms",
            map_path.display(),
            cold.iter().sum::<f64>() / cold.len().max(1) as f64,
            if cold.is_empty() { 0.0 } else { median(cold.clone()) },
            cold.iter().copied().fold(0.0, f64::max),
            queries.len(),
            median(times),
        );
    }
}
