//! `place`: the home base and treasures. Treasures go to the centres of free cells that are
//! reachable from the home base (same 4-connected free component).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;
use sim_core::spatial::Square;
use sim_core::world::{HomeBase, MapData, TreasureSpec};

use crate::{EditorError, Result};
use sim_core::spatial::Components;

/// How treasures are spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spread {
    /// Uniformly over the reachable free area.
    Uniform,
    /// Around `clusters` random centres with a Gaussian spread of `sigma_m`.
    Clustered {
        /// Number of clusters.
        clusters: u32,
        /// Standard deviation of a treasure's offset from its cluster centre, metres.
        sigma_m: f64,
    },
}

/// Options of `place`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaceOptions {
    /// Home base centre (`None`: keep the map's, or choose one when `auto_home`).
    pub home: Option<DVec2>,
    /// Choose a home base automatically (free spot near the centre of the largest free region).
    pub auto_home: bool,
    /// Home base radius, metres.
    pub home_radius_m: f64,
    /// Number of treasures to add.
    pub treasures: u32,
    /// Keep the treasures already on the map.
    pub keep_treasures: bool,
    /// Spread of new treasures.
    pub spread: Spread,
    /// Quantity range (inclusive) of new treasures.
    pub quantity: (u32, u32),
    /// Random seed.
    pub seed: u64,
}

impl Default for PlaceOptions {
    fn default() -> Self {
        Self {
            home: None,
            auto_home: false,
            home_radius_m: 2.0,
            treasures: 0,
            keep_treasures: false,
            spread: Spread::Uniform,
            quantity: (1, 1),
            seed: 0,
        }
    }
}

/// A home base near the centre of the largest free region: a disc of `radius_m` that lies in
/// free space if any free leaf is big enough for it, else a smaller disc in a free cell.
pub fn auto_home(obstacles: &ObstacleMap, radius_m: f64) -> Result<HomeBase> {
    let comps = Components::new(obstacles.tree());
    let g = obstacles.grid();
    let Some(big) = comps.largest() else {
        return Err(EditorError::Placement(
            "the map has no free cell for a home base".into(),
        ));
    };
    let target = g.extent().center();
    let mut best: Option<(bool, f64, DVec2, f64)> = None; // (fits, distance², centre, radius)
    for (sq, label) in comps.leaves() {
        if label != big {
            continue;
        }
        let b = g.square(sq.x, sq.y, sq.level);
        let half = (b.max.x - b.min.x) / 2.0;
        let fits = half >= radius_m;
        let (r, inset) = if fits { (radius_m, radius_m) } else { (half, half) };
        let c = target.clamp(b.min + inset, b.max - inset);
        let d = c.distance_squared(target);
        let better = match best {
            None => true,
            Some((bf, bd, _, _)) => (fits && !bf) || (fits == bf && d < bd),
        };
        if better {
            best = Some((fits, d, c, r));
        }
    }
    let (_, _, center, r) = best.expect("the largest component has a leaf");
    Ok(HomeBase::Disc { center, radius_m: r })
}

fn check_radius(r: f64) -> Result<()> {
    if r.is_finite() && r > 0.0 {
        Ok(())
    } else {
        Err(EditorError::InvalidParameter(format!(
            "home radius must be a positive number of metres, got {r}"
        )))
    }
}

/// Apply `opts` to `map`: set the home base, then scatter treasures reachable from it.
pub fn place(map: &mut MapData, opts: &PlaceOptions) -> Result<()> {
    check_radius(opts.home_radius_m)?;
    let (qmin, qmax) = opts.quantity;
    if qmin == 0 || qmin > qmax {
        return Err(EditorError::InvalidParameter(format!(
            "treasure quantity range {qmin}..={qmax} must be non-empty and at least 1"
        )));
    }
    if let Some(h) = opts.home {
        let free = map.obstacles.is_point_free(h);
        if !free {
            return Err(EditorError::Placement(format!(
                "home base centre ({}, {}) is not a free point of the map",
                h.x, h.y
            )));
        }
        if !map.obstacles.is_disc_free(h, opts.home_radius_m) {
            return Err(EditorError::Placement(format!(
                "a home base of radius {} m at ({}, {}) overlaps obstacles or leaves the map; choose a smaller --home-radius-m or another spot",
                opts.home_radius_m, h.x, h.y
            )));
        }
        map.home = HomeBase::Disc {
            center: h,
            radius_m: opts.home_radius_m,
        };
    } else if opts.auto_home {
        map.home = auto_home(&map.obstacles, opts.home_radius_m)?;
    }
    if !opts.keep_treasures {
        map.treasures.clear();
    }
    if opts.treasures == 0 {
        return Ok(());
    }
    let comps = Components::new(map.obstacles.tree());
    let Some(home) = comps.label_at(map.home.center()) else {
        return Err(EditorError::Placement(
            "the home base centre lies in a blocked cell; no treasure can be reachable".into(),
        ));
    };
    let leaves: Vec<Square> = comps.leaves().filter(|&(_, l)| l == home).map(|(s, _)| s).collect();
    let mut cumulative = Vec::with_capacity(leaves.len());
    let mut total = 0u64;
    for s in &leaves {
        total += s.cells();
        cumulative.push(total);
    }
    let g = *map.obstacles.grid();
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let uniform_cell = |rng: &mut ChaCha8Rng| -> DVec2 {
        let u = rng.random_range(0..total);
        let k = cumulative.partition_point(|&c| c <= u);
        let s = leaves[k];
        let side = s.side_cells();
        let (dx, dy) = (rng.random_range(0..side), rng.random_range(0..side));
        g.cell_center(s.x + dx, s.y + dy)
    };
    let quantity = |rng: &mut ChaCha8Rng| rng.random_range(qmin..=qmax);
    match opts.spread {
        Spread::Uniform => {
            for _ in 0..opts.treasures {
                let position = uniform_cell(&mut rng);
                let quantity = quantity(&mut rng);
                map.treasures.push(TreasureSpec { position, quantity });
            }
        }
        Spread::Clustered { clusters, sigma_m } => {
            if clusters == 0 || !(sigma_m.is_finite() && sigma_m > 0.0) {
                return Err(EditorError::InvalidParameter(format!(
                    "clustered spread needs at least one cluster and a positive sigma, got {clusters} and {sigma_m}"
                )));
            }
            let centres: Vec<DVec2> = (0..clusters).map(|_| uniform_cell(&mut rng)).collect();
            for i in 0..opts.treasures {
                let c = centres[i as usize % centres.len()];
                let mut position = None;
                for _ in 0..1000 {
                    // Box–Muller.
                    let (u1, u2): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
                    let r = sigma_m * (-2.0 * u1.ln()).sqrt();
                    let p = c + r * DVec2::new((std::f64::consts::TAU * u2).cos(), (std::f64::consts::TAU * u2).sin());
                    if let Some((x, y)) = g.cell_of(p)
                        && comps.label_of_cell(x, y) == Some(home)
                    {
                        position = Some(g.cell_center(x, y));
                        break;
                    }
                }
                let position = position.unwrap_or(c);
                let quantity = quantity(&mut rng);
                map.treasures.push(TreasureSpec { position, quantity });
            }
        }
    }
    Ok(())
}
