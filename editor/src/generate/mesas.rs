//! Mars / Monument Valley (the paper's large scene): many rocks (parry2d discs) and mesas
//! (parry2d convex polygons of 5–9 vertices) with log-uniform sizes, placed uniformly.
//!
//! `scale_m` (default 60 m) is the largest mesa radius; mesas (10 % of obstacles) have radii
//! in `[scale/10, scale]`, rocks in `[max(cell/2, scale/120), scale/10]`. Without `count`, the
//! number of obstacles is chosen for the target density (default 0.15) by the Boolean-model
//! formula `n = −ln(1 − density) · area / mean obstacle area`; conservative rasterisation adds a
//! little (about half a cell along every outline).

use std::f64::consts::TAU;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;

use super::GenerateOptions;
use crate::progress::Progress;
use crate::shapes::{Obstacle, ShapeSet, polygon_area};
use crate::{EditorError, Result};

/// Fraction of obstacles that are mesas.
const MESA_FRACTION: f64 = 0.1;

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi <= lo {
        return lo;
    }
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

/// One obstacle's outline relative to its centre: `None` for a disc of the returned radius.
fn sample_outline(rng: &mut ChaCha8Rng, scale: f64, cell_m: f64) -> (f64, Option<Vec<DVec2>>) {
    if rng.random::<f64>() < MESA_FRACTION {
        let r = log_uniform(rng, scale / 10.0, scale);
        let k = rng.random_range(5..=9);
        let mut angles: Vec<f64> = (0..k).map(|_| rng.random::<f64>() * TAU).collect();
        angles.sort_by(f64::total_cmp);
        let pts = angles
            .iter()
            .map(|&a| r * rng.random_range(0.7..=1.0) * DVec2::new(a.cos(), a.sin()))
            .collect();
        (r, Some(pts))
    } else {
        let lo = (cell_m / 2.0).max(scale / 120.0);
        (log_uniform(rng, lo, (scale / 10.0).max(lo)), None)
    }
}

fn hull_area(points: &[DVec2]) -> f64 {
    // Andrew's monotone chain.
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let mut hull: Vec<DVec2> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        for &q in &p {
            while hull.len() >= start + 2
                && (hull[hull.len() - 1] - hull[hull.len() - 2]).perp_dot(q - hull[hull.len() - 2]) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
        if pass == 0 {
            p.reverse();
        }
    }
    polygon_area(&hull).abs()
}

/// The obstacles of a mesas map.
pub fn obstacles(opts: &GenerateOptions) -> Result<Vec<Obstacle>> {
    let grid = opts.grid()?;
    let d = opts.density_or(0.15)?;
    let scale = opts.scale_or(60.0)?;
    let area = grid.width_m() * grid.height_m();
    let n = match opts.count {
        Some(n) => n,
        None if d >= 1.0 => {
            return Err(EditorError::InvalidParameter(
                "mesas needs a density below 1 (or an explicit --count)".into(),
            ));
        }
        None => {
            let mut rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0xA5A5);
            let samples = 8192;
            let total: f64 = (0..samples)
                .map(|_| match sample_outline(&mut rng, scale, opts.cell_m) {
                    (r, None) => std::f64::consts::PI * r * r,
                    (_, Some(pts)) => hull_area(&pts),
                })
                .sum();
            let mean = total / f64::from(samples);
            (-(1.0 - d).ln() * area / mean).round() as u64
        }
    };
    if n > 100_000_000 {
        return Err(EditorError::InvalidParameter(format!(
            "{n} obstacles is too many (at most 10^8); use a larger --scale-m or a lower density"
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let ext = grid.extent();
    let mut out = Vec::with_capacity(n as usize);
    while (out.len() as u64) < n {
        let c = DVec2::new(
            rng.random_range(ext.min.x..ext.max.x),
            rng.random_range(ext.min.y..ext.max.y),
        );
        let shape = match sample_outline(&mut rng, scale, opts.cell_m) {
            (r, None) => Obstacle::disc(c, r),
            (_, Some(pts)) => Obstacle::convex_hull(c, &pts, rng.random::<f64>() * TAU),
        };
        if let Some(s) = shape {
            out.push(s);
        }
    }
    Ok(out)
}

/// Generate a mesas map.
pub fn mesas(opts: &GenerateOptions) -> Result<ObstacleMap> {
    let grid = opts.grid()?;
    let shapes = obstacles(opts)?;
    let set = ShapeSet::new(grid, shapes);
    let mut progress = Progress::new(
        u64::from(grid.width_cells()) * u64::from(grid.height_cells()),
        &format!("mesas ({} obstacles)", set.shapes().len()),
        opts.progress,
    );
    let map = set.rasterise(&mut progress);
    progress.finish();
    Ok(map)
}
