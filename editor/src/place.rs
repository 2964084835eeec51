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

/// A free leaf as a place for the home base: (the full disc fits, distance² of the disc's
/// centre from the map's centre, the leaf's lower-left and upper-right corners).
type Candidate = (bool, f64, DVec2, DVec2);

/// A home base near the centre of the largest free region: a disc of `radius_m` that lies in
/// free space if any free leaf is big enough for it, else a smaller disc in a free cell.
/// Every disc returned has been checked with [`ObstacleMap::is_disc_free`].
pub fn auto_home(obstacles: &ObstacleMap, radius_m: f64) -> Result<HomeBase> {
    check_radius(radius_m)?;
    let comps = Components::new(obstacles.tree());
    let g = obstacles.grid();
    let Some(big) = comps.largest() else {
        return Err(EditorError::Placement(
            "the map has no free cell for a home base".into(),
        ));
    };
    let target = g.extent().center();
    // A leaf's rank: a leaf the full disc fits in first, then by the distance of the disc's
    // centre from the map's centre.
    let candidates = || {
        comps.leaves().filter(|&(_, label)| label == big).map(|(sq, _)| {
            let b = g.square(sq.x, sq.y, sq.level);
            let (fits, center, _) = disc_in_box(b.min, b.max, target, radius_m);
            (fits, center.distance_squared(target), b.min, b.max)
        })
    };
    let rank = |a: &Candidate, b: &Candidate| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1));
    // The best leaf (the first of equals); its disc is free unless rounding says otherwise.
    let best = candidates().reduce(|a, b| if rank(&b, &a).is_lt() { b } else { a });
    let free = |(_, _, min, max): Candidate| free_disc_in_box(obstacles, min, max, target, radius_m);
    let found = best.and_then(free).or_else(|| {
        // Rare: try every leaf, best first (the sort is stable: first of equals first).
        let mut all: Vec<_> = candidates().collect();
        all.sort_by(rank);
        all.into_iter().find_map(free)
    });
    match found {
        Some((center, radius_m)) => Ok(HomeBase::Disc { center, radius_m }),
        None => Err(EditorError::Placement(
            "no free disc fits in the largest free region (are the map's cells too small for its coordinates?)".into(),
        )),
    }
}

/// The disc of radius `radius_m` (or, if the box is too small for it, of the largest radius
/// the box holds) inside the box `min..max` whose centre is nearest to `target`:
/// `(fits, centre, radius)`. Never inverts a range: a box narrower than the disc along an axis
/// (the two sides of a square leaf can differ by float rounding) gets the box's middle there.
fn disc_in_box(min: DVec2, max: DVec2, target: DVec2, radius_m: f64) -> (bool, DVec2, f64) {
    let room = ((max - min) * 0.5).min_element();
    let fits = room >= radius_m;
    let r = if fits { radius_m } else { room };
    let (lo, hi) = (min + r, max - r);
    let along = |t: f64, lo: f64, hi: f64, a: f64, b: f64| {
        if lo <= hi { t.clamp(lo, hi) } else { a + (b - a) * 0.5 }
    };
    let center = DVec2::new(
        along(target.x, lo.x, hi.x, min.x, max.x),
        along(target.y, lo.y, hi.y, min.y, max.y),
    );
    (fits, center, r)
}

/// [`disc_in_box`] for a free leaf, checked against the map: a disc that touches the leaf's
/// edges can overlap a blocked neighbour (or leave the map) by a rounding error; then the
/// leaf's middle, then slightly smaller discs there are tried. `None` if nothing is free.
fn free_disc_in_box(
    obstacles: &ObstacleMap,
    min: DVec2,
    max: DVec2,
    target: DVec2,
    radius_m: f64,
) -> Option<(DVec2, f64)> {
    let (_, center, r) = disc_in_box(min, max, target, radius_m);
    let middle = min + (max - min) * 0.5;
    [
        (center, r),
        (middle, r),
        (middle, r * (1.0 - 1e-9)),
        (middle, r * (1.0 - 1e-6)),
        (middle, r * (1.0 - 1e-3)),
    ]
    .into_iter()
    .find(|&(c, r)| r > 0.0 && obstacles.is_disc_free(c, r))
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
