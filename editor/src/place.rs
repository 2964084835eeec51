//! `place`: the home base and treasures. Treasures go to the centres of free cells that are
//! reachable from the home base (same 4-connected free component).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::glam::DVec2;
use sim_core::spatial::Grid;
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

/// What [`place`] found, for its caller to report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Placement {
    /// The free cells reachable from the home base, where new treasures went (`None` when
    /// no treasure was asked for). More treasures than cells share cells' centres.
    pub reachable_cells: Option<u64>,
}

/// Apply `opts` to `map`: set the home base, then scatter treasures reachable from it.
pub fn place(map: &mut MapData, opts: &PlaceOptions) -> Result<Placement> {
    check_radius(opts.home_radius_m)?;
    check_quantity(opts.quantity)?;
    set_home(map, opts)?;
    if !opts.keep_treasures {
        map.treasures.clear();
    }
    if opts.treasures == 0 {
        return Ok(Placement::default());
    }
    let area = Reachable::around(&map.obstacles, &map.home)?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    match opts.spread {
        Spread::Uniform => scatter_uniform(&mut map.treasures, opts, &area, &mut rng),
        Spread::Clustered { clusters, sigma_m } => {
            scatter_clustered(&mut map.treasures, opts, &area, clusters, sigma_m, &mut rng)?;
        }
    }
    Ok(Placement {
        reachable_cells: Some(area.total),
    })
}

/// Check the treasure quantity range `(min, max)`: non-empty, and from at least 1.
fn check_quantity((qmin, qmax): (u32, u32)) -> Result<()> {
    if qmin == 0 || qmin > qmax {
        return Err(EditorError::InvalidParameter(format!(
            "treasure quantity range {qmin}..={qmax} must be non-empty and at least 1"
        )));
    }
    Ok(())
}

/// Set the home base `opts` asks for: a disc at the given centre, checked to be free, or one
/// chosen automatically; otherwise keep the map's.
fn set_home(map: &mut MapData, opts: &PlaceOptions) -> Result<()> {
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
    Ok(())
}

/// Add `opts.treasures` treasures at cells drawn uniformly from `area`.
fn scatter_uniform(treasures: &mut Vec<TreasureSpec>, opts: &PlaceOptions, area: &Reachable<'_>, rng: &mut ChaCha8Rng) {
    let (qmin, qmax) = opts.quantity;
    for _ in 0..opts.treasures {
        let position = area.uniform_cell(rng);
        let quantity = rng.random_range(qmin..=qmax);
        treasures.push(TreasureSpec { position, quantity });
    }
}

/// Add `opts.treasures` treasures around `clusters` centres drawn uniformly from `area`, taken
/// in turn, each at a Gaussian offset of `sigma_m` from its centre.
fn scatter_clustered(
    treasures: &mut Vec<TreasureSpec>,
    opts: &PlaceOptions,
    area: &Reachable<'_>,
    clusters: u32,
    sigma_m: f64,
    rng: &mut ChaCha8Rng,
) -> Result<()> {
    if clusters == 0 || !(sigma_m.is_finite() && sigma_m > 0.0) {
        return Err(EditorError::InvalidParameter(format!(
            "clustered spread needs at least one cluster and a positive sigma, got {clusters} and {sigma_m}"
        )));
    }
    let (qmin, qmax) = opts.quantity;
    let centres: Vec<DVec2> = (0..clusters).map(|_| area.uniform_cell(rng)).collect();
    for i in 0..opts.treasures {
        let c = centres[i as usize % centres.len()];
        let position = area.near(c, sigma_m, rng);
        let quantity = rng.random_range(qmin..=qmax);
        treasures.push(TreasureSpec { position, quantity });
    }
    Ok(())
}

/// The free cells reachable from the home base (its 4-connected free component), to draw
/// treasure positions from.
struct Reachable<'a> {
    /// The map's free components.
    comps: Components<'a>,
    /// The home base's component.
    label: u32,
    /// The component's free leaves.
    leaves: Vec<Square>,
    /// Running cell count: entry `i` counts the cells of `leaves[..=i]`.
    cumulative: Vec<u64>,
    /// Cells in the component.
    total: u64,
    /// The map's grid.
    grid: Grid,
}

impl<'a> Reachable<'a> {
    /// The free component of `obstacles` around `home`'s centre; an error if that centre is
    /// blocked.
    fn around(obstacles: &'a ObstacleMap, home: &HomeBase) -> Result<Self> {
        let comps = Components::new(obstacles.tree());
        let Some(label) = comps.label_at(home.center()) else {
            return Err(EditorError::Placement(
                "the home base centre lies in a blocked cell; no treasure can be reachable".into(),
            ));
        };
        let leaves: Vec<Square> = comps.leaves().filter(|&(_, l)| l == label).map(|(s, _)| s).collect();
        let mut cumulative = Vec::with_capacity(leaves.len());
        let mut total = 0u64;
        for s in &leaves {
            total += s.cells();
            cumulative.push(total);
        }
        Ok(Self {
            comps,
            label,
            leaves,
            cumulative,
            total,
            grid: *obstacles.grid(),
        })
    }

    /// The centre of a cell drawn uniformly from the component.
    fn uniform_cell(&self, rng: &mut ChaCha8Rng) -> DVec2 {
        let u = rng.random_range(0..self.total);
        let k = self.cumulative.partition_point(|&c| c <= u);
        let s = self.leaves[k];
        let side = s.side_cells();
        let (dx, dy) = (rng.random_range(0..side), rng.random_range(0..side));
        self.grid.cell_center(s.x + dx, s.y + dy)
    }

    /// The centre of the cell of the component at a Gaussian offset of `sigma_m` from `c`,
    /// or `c` itself when a thousand draws all miss the component.
    fn near(&self, c: DVec2, sigma_m: f64, rng: &mut ChaCha8Rng) -> DVec2 {
        for _ in 0..1000 {
            // Box–Muller.
            let (u1, u2): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
            let r = sigma_m * (-2.0 * u1.ln()).sqrt();
            let p = c + r * DVec2::new((std::f64::consts::TAU * u2).cos(), (std::f64::consts::TAU * u2).sin());
            if let Some((x, y)) = self.grid.cell_of(p)
                && self.comps.label_of_cell(x, y) == Some(self.label)
            {
                return self.grid.cell_center(x, y);
            }
        }
        c
    }
}
