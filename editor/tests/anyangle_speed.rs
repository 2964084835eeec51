//! Opt-in timing of any-angle queries (issue 12): not a test of results but a measuring
//! harness that needs no Rerun build. `SMARTTEAMS_ANYANGLE_MAPS` lists maps (`.stmap`, or a
//! Moving AI `.map`, optionally `map.map=queries.scen`), comma-separated; each runs the
//! queries `smartteams-bench any-angle` runs (`editor::path`'s, which the bench uses: the
//! scenario's, or 300 random pairs of free cell centres, seed 1), first ten each on a planner
//! just built, then all on one planner.
//! `SMARTTEAMS_ANYANGLE_LINK=1` links the whole visibility graph first, as the bench did;
//! `SMARTTEAMS_ANYANGLE_QUERIES=N` runs N random queries instead of 300.
//!
//! `cargo test --profile ci -p editor --test anyangle_speed -- --ignored --nocapture`

use std::path::Path;
use std::time::Instant;

use editor::path::{load_map, random_queries, read_scenario};
use sim_core::spatial::AnyAnglePlanner;

/// The median, 0 for no values (a map without free cells has no random queries).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
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
        let map = load_map(map_path).unwrap();
        let queries: Vec<_> = match scen {
            Some(s) => read_scenario(s, &map).unwrap(),
            None => random_queries(&map, count, 1),
        }
        .into_iter()
        .map(|q| (q.from, q.to))
        .collect();
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
            median(cold.clone()),
            cold.iter().copied().fold(0.0, f64::max),
            queries.len(),
            median(times),
        );
    }
}
