//! [`TestWorld`]: a tiny world drawn in ASCII, with one robot in it, for testing a strategy
//! or a tactic alone (no simulation, no other robots unless the test adds what they see).

use glam::DVec2;
use rand::SeedableRng;

use crate::agent::ctx::{Ctx, Mind, RobotRng, WorldView};
use crate::agent::perception::DataModule;
use crate::spatial::{Aabb, Grid, KnownMap, LazyNavGraph, ObstacleMap, RobotId};
use crate::world::{Action, HomeBase, Outcome, Retention, Robot, RobotType};
use crate::{Error, Result};

/// A tiny world for unit tests: a map from ASCII art, one robot and its mind.
///
/// In the art, the first line is the top row (largest y); each character is one cell of
/// `cell_m` metres: `#` blocked, `.` free, `R` free with the robot at the cell's centre,
/// `H` free with the home base (a disc of one cell's radius) at the cell's centre. The
/// robot knows nothing yet; [`knowing_all`](Self::knowing_all) or
/// [`knowing_disc`](Self::knowing_disc) change that.
///
/// ```
/// use sim_core::agent::TestWorld;
/// use sim_core::glam::DVec2;
///
/// // One string per row, top row first (rows starting with `#` cannot open a doc-test line).
/// let art = ["#####", "#R..#", "#..H#", "#####"].join("\n");
/// let mut w = TestWorld::from_ascii(&art, 1.0)?.knowing_all();
/// assert_eq!(w.robot.position, DVec2::new(1.5, 2.5));
/// let ctx = w.ctx();
/// assert_eq!(ctx.can_move(DVec2::new(1.5, 2.5), DVec2::new(3.5, 2.5)), Some(true));
/// assert_eq!(ctx.can_move(DVec2::new(1.5, 2.5), DVec2::new(1.5, 3.5)), Some(false));
/// # Ok::<(), sim_core::Error>(())
/// ```
pub struct TestWorld {
    /// The obstacles.
    pub obstacles: ObstacleMap,
    nav: LazyNavGraph,
    /// The home base.
    pub home: HomeBase,
    /// Robot types; the robot has type 0 (default: [`RobotType::explorer`]).
    pub types: Vec<RobotType>,
    /// The robot (id 0).
    pub robot: Robot,
    /// Its mind: perception, data module and what its strategy left behind.
    pub mind: Mind,
    /// The round the next [`ctx`](Self::ctx) is for (default 1).
    pub round: u64,
    /// Seed of the robot's random generator (default 0).
    pub seed: u64,
}

impl TestWorld {
    /// Parse the art (leading and trailing blank lines and each line's indentation are
    /// ignored; all rows must have the same width).
    pub fn from_ascii(art: &str, cell_m: f64) -> Result<Self> {
        let rows: Vec<&str> = art.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
        let width = rows.first().map_or(0, |r| r.chars().count());
        if rows.iter().any(|r| r.chars().count() != width) {
            return Err(Error::InvalidParameter(format!(
                "ASCII map rows differ in width (the first row has {width} characters)"
            )));
        }
        let height = rows.len();
        let grid = Grid::new(DVec2::ZERO, cell_m, width as u32, height as u32)?;
        let cell = |x: usize, y: usize| rows[height - 1 - y].chars().nth(x).unwrap_or('#');
        let centre = |x: usize, y: usize| DVec2::new((x as f64 + 0.5) * cell_m, (y as f64 + 0.5) * cell_m);
        let mut robot_at = None;
        let mut home_at = None;
        for y in 0..height {
            for x in 0..width {
                match cell(x, y) {
                    'R' => robot_at = Some(centre(x, y)),
                    'H' => home_at = Some(centre(x, y)),
                    '.' | '#' => {}
                    c => return Err(Error::InvalidParameter(format!("unknown map character '{c}'"))),
                }
            }
        }
        let robot_at = robot_at.ok_or_else(|| Error::InvalidParameter("no 'R' in the ASCII map".into()))?;
        let obstacles = ObstacleMap::from_fn(grid, |x, y| cell(x as usize, y as usize) == '#');
        let kind = RobotType::explorer();
        let robot = Robot::new(RobotId::new(0), 0, 0, robot_at, &kind);
        Ok(Self {
            obstacles,
            nav: LazyNavGraph::new(),
            home: HomeBase::Disc {
                center: home_at.unwrap_or(robot_at),
                radius_m: 0.5 * cell_m,
            },
            types: vec![kind],
            robot,
            mind: Mind::new(DataModule::new(
                Some(KnownMap::new(grid)),
                Retention::LastN(64),
                Retention::LastN(64),
            )),
            round: 1,
            seed: 0,
        })
    }

    /// Give the robot another type (it keeps full energy of the new type).
    pub fn with_type(mut self, kind: RobotType) -> Self {
        self.robot.energy = kind.energy_capacity;
        self.types[0] = kind;
        self
    }

    /// The robot knows the whole map.
    pub fn knowing_all(mut self) -> Self {
        let grid = *self.obstacles.grid();
        let mut known = KnownMap::new(grid);
        known.mark(&grid.extent());
        self.mind.data.known = Some(known);
        self
    }

    /// The robot knows (in addition) a disc.
    pub fn knowing_disc(mut self, center: DVec2, radius_m: f64) -> Self {
        if let Some(k) = self.mind.data.known.as_mut() {
            k.mark_disc(center, radius_m);
        }
        self
    }

    /// The map's extent.
    pub fn extent(&self) -> Aabb {
        self.obstacles.grid().extent()
    }

    /// The context the robot's strategy gets this round (its generator seeded from the
    /// world's seed and round).
    pub fn ctx(&mut self) -> Ctx<'_> {
        let world = WorldView::new(&self.obstacles, &self.nav, self.home, &self.types);
        let rng = RobotRng::seed_from_u64(self.seed ^ self.round.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        Ctx::new(self.round, &self.robot, &self.types[0], world, rng, &mut self.mind)
    }

    /// Carry out a move the way the kernel would for a lone robot (trimmed to speed and to
    /// the obstacles), record its outcome and advance the round: enough for tactics that
    /// react to being held back.
    pub fn apply(&mut self, action: Action) {
        let kind = &self.types[0];
        let outcome = match action {
            Action::MoveTo { to } => {
                let from = self.robot.position;
                let d = (to - from).clamp_length_max(kind.speed_m_per_round);
                if d.length() <= 1e-12 {
                    Outcome::Done
                } else if self.obstacles.is_swept_disc_free(from, from + d, kind.radius_m) {
                    self.robot.position = from + d;
                    if d.length() + 1e-9 < (to - from).length() {
                        Outcome::Trimmed
                    } else {
                        Outcome::Done
                    }
                } else {
                    Outcome::Refused
                }
            }
            _ => Outcome::Done,
        };
        self.robot.last_action = (action, outcome);
        self.round += 1;
    }
}
