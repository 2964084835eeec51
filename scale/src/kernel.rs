//! The kernel scenario (the navigation benchmark, and the kernel's criterion bench):
//! cooperative explorers on a generated map of clustered rocks, about 2.1 M leaves.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::agent::{Params, StrategyRegistry};
use sim_core::engine::{Group, Scenario, ScenarioBuilder};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap};
use sim_core::world::{HomeBase, MapData, RobotType, TreasureSpec};

use crate::Result;

/// `robots` cooperative explorers (20 m radios, maps shared every 20 rounds) from a 5 m
/// home at the centre of a 2,048 m × 2,048 m map (1 m cells): clustered rocks (blobs of
/// 1–6 m) over sparse white noise, a clear 60 m square round home, 200 treasures on a
/// spiral. The map is the same for every seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kernel {
    /// Explorers (default 1,000).
    pub robots: u32,
    /// Seed of the run (default 7).
    pub seed: u64,
    /// The explorers' `max_detour_m` (default `None`: unbounded, `cooperative`'s default).
    pub max_detour_m: Option<f64>,
}

impl Default for Kernel {
    fn default() -> Self {
        Self {
            robots: 1_000,
            seed: 7,
            max_detour_m: None,
        }
    }
}

/// The map's side in cells.
const SIDE: u32 = 2_048;

impl Kernel {
    /// The map (about 2.1 M leaves; a few seconds to generate).
    pub fn map() -> Arc<MapData> {
        let grid = Grid::new(DVec2::ZERO, 1.0, SIDE, SIDE).expect("a valid grid");
        let mut rng = ChaCha8Rng::seed_from_u64(1_000_000);
        let home = DVec2::splat(f64::from(SIDE) / 2.0);
        let obstacles = ObstacleMap::from_fn(grid, |x, y| {
            let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            if (p - home).abs().max_element() < 30.0 {
                return false;
            }
            // A cell is rock if its 8 m block is "rocky" (a hash) and the noise agrees.
            let block = (x / 8).wrapping_mul(0x9E37_79B9) ^ (y / 8).wrapping_mul(0x85EB_CA6B);
            let rocky = block.wrapping_mul(0xC2B2_AE35) >> 28 < 4;
            (rocky && rng.random_bool(0.7)) || rng.random_bool(0.08)
        });
        let treasures = (0..200)
            .map(|i| {
                let a = f64::from(i) * 0.7;
                TreasureSpec {
                    position: home + DVec2::from_angle(a) * (40.0 + f64::from(i)),
                    quantity: 5,
                }
            })
            .filter(|t| obstacles.is_disc_free(t.position, 0.2))
            .collect();
        Arc::new(MapData {
            obstacles,
            home: HomeBase::Disc {
                center: home,
                radius_m: 5.0,
            },
            treasures,
        })
    }

    /// The scenario on `map` (from [`Kernel::map`]).
    pub fn scenario(&self, map: &Arc<MapData>) -> Result<Scenario> {
        Ok(ScenarioBuilder::new(Arc::clone(map))
            .with_name(format!("bench-{}", self.robots))
            .with_seed(self.seed)
            .with_rounds(u64::MAX)
            .with_types(vec![RobotType::explorer().with_comm_radius_m(20.0)])
            .with_group(
                Group::new("cooperative", 0, self.robots)
                    .with_name("explorers")
                    .with_params(
                        self.max_detour_m
                            .into_iter()
                            .fold(Params::from_pairs([("share_every", "20")]), |p, d| {
                                p.with("max_detour_m", d.to_string())
                            }),
                    ),
            )
            .build(&StrategyRegistry::with_builtins())?)
    }
}
