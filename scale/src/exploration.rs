//! Exploration quality: the built-in explorers against a greedy nearest-frontier reference,
//! on indoor maps, by the distance walked to 90 % and 98 % of the free area explored.
//!
//! [`GreedyReference`] is the plain baseline researchers compare with: on its own known
//! grid it picks the frontier cell nearest by path length (Dijkstra over known cells its
//! body fits in, 8-connected without cutting corners), walks that path (straightened where
//! the known map allows), and picks again on arrival, when the target stops being a
//! frontier, or when a move fails (then searching from the open cells in a straight move's
//! reach, so that a wall that refused a step is not asked again). [`explore`] plays one
//! explorer (or a team) with the
//! comparison robot ([`explorer_robot`]): 3.5 m view, 0.25 m a round, no energy use.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use sim_core::agent::{Ctx, Needs, Params, Strategy, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, KnownMap, ObstacleMap};
use sim_core::world::{Action, HomeBase, MapData, RobotType};

/// The registry name of [`GreedyReference`].
pub const GREEDY_REFERENCE: &str = "greedy_reference";

/// Waypoints ahead that a straightened step may skip to.
const LOOK_AHEAD: usize = 24;

/// A cell of the robot's grid as the reference has seen it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Cell {
    /// Not known yet (asked again next time).
    Unknown,
    /// Known, and the robot's disc fits at its centre.
    Open,
    /// Known, and the disc does not fit.
    Closed,
}

/// The greedy nearest-frontier explorer (see the module docs). Its state is rebuilt on
/// a restore (it keeps none in checkpoints).
#[derive(Debug, Default)]
pub struct GreedyReference {
    /// Per cell, what it has learnt (cells only become known, and obstacles stay put).
    cells: Vec<Cell>,
    /// The frontier cell walked to.
    target: Option<(u32, u32)>,
    /// The cell centres left to walk, the next first.
    path: Vec<DVec2>,
    /// Where it asked to move from last round (`None`: it did not ask).
    moved_from: Option<DVec2>,
    /// Where it stood, and how many cells it knew, when its last search found no frontier:
    /// until one of them changes, the same search finds none again (its inputs are the
    /// same), so it is not run. The exploration table is the same with and without it;
    /// `the_reference_stays_put_once_no_frontier_is_in_reach` plays such a run.
    exhausted: Option<(DVec2, u64)>,
}

impl GreedyReference {
    /// What cell `(x, y)` is to the robot now.
    fn cell(&mut self, ctx: &Ctx, grid: &Grid, x: u32, y: u32) -> Cell {
        let k = (y * grid.width_cells() + x) as usize;
        if self.cells[k] == Cell::Unknown {
            self.cells[k] = match ctx.is_free(grid.cell_center(x, y)) {
                None => Cell::Unknown,
                Some(true) => Cell::Open,
                Some(false) => Cell::Closed,
            };
        }
        self.cells[k]
    }

    /// Whether cell `(x, y)` is open with an unknown cell beside it (4-neighbours, in the map).
    fn is_frontier(&mut self, ctx: &Ctx, grid: &Grid, (x, y): (u32, u32)) -> bool {
        self.cell(ctx, grid, x, y) == Cell::Open
            && neighbours4(grid, x, y)
                .into_iter()
                .flatten()
                .any(|(nx, ny)| self.cell(ctx, grid, nx, ny) == Cell::Unknown)
    }

    /// Dijkstra from the robot's cell over open cells to the nearest frontier cell; sets the
    /// target and the path. `false` if none is reachable. `failed`: the robot's last move
    /// went nowhere.
    fn plan(&mut self, ctx: &Ctx, grid: &Grid, failed: bool) -> bool {
        self.target = None;
        self.path.clear();
        let Some(start) = grid.cell_of(ctx.position()) else {
            return false;
        };
        let w = grid.width_cells();
        let index = |(x, y): (u32, u32)| (y * w + x) as usize;
        let n = self.cells.len();
        let mut dist = vec![f64::INFINITY; n];
        let mut prev = vec![u32::MAX; n];
        let mut heap = BinaryHeap::new();
        // After a move that went nowhere, or standing where the disc does not fit at its
        // cell's centre (pressed against a wall, a corner cut on the way), the search starts
        // from the open cells in a straight move's reach instead: a path from the robot's
        // cell could begin with the very step that failed, again every round.
        let seeds = if failed || self.cell(ctx, grid, start.0, start.1) != Cell::Open {
            self.open_cells_in_reach(ctx, grid, start)
        } else {
            Vec::new()
        };
        // The cell the path leaves from, not walked to (`None`: it starts at a seed, which is).
        let leave_from = seeds.is_empty().then_some(start);
        if seeds.is_empty() {
            dist[index(start)] = 0.0;
            heap.push(Reverse((Ordered(0.0), start)));
        }
        for (c, d) in seeds {
            dist[index(c)] = d;
            heap.push(Reverse((Ordered(d), c)));
        }
        let cell_m = grid.cell_m();
        while let Some(Reverse((Ordered(d), c))) = heap.pop() {
            if d > dist[index(c)] {
                continue;
            }
            if c != start && self.is_frontier(ctx, grid, c) {
                self.target = Some(c);
                self.path = walk_back(grid, &prev, c, leave_from);
                return true;
            }
            for (next, step) in self.open_neighbours(ctx, grid, c) {
                let nd = d + step * cell_m;
                if nd < dist[index(next)] {
                    dist[index(next)] = nd;
                    prev[index(next)] = u32::try_from(index(c)).expect("cells fit in u32");
                    heap.push(Reverse((Ordered(nd), next)));
                }
            }
        }
        false
    }

    /// The open cells within [`REACH_CELLS`] cells of `start` that the robot can move to in
    /// a straight line, with their distances from it.
    fn open_cells_in_reach(&mut self, ctx: &Ctx, grid: &Grid, start: (u32, u32)) -> Vec<((u32, u32), f64)> {
        let p = ctx.position();
        let (w, h) = (grid.width_cells(), grid.height_cells());
        let mut out = Vec::new();
        for y in start.1.saturating_sub(REACH_CELLS)..=(start.1 + REACH_CELLS).min(h - 1) {
            for x in start.0.saturating_sub(REACH_CELLS)..=(start.0 + REACH_CELLS).min(w - 1) {
                let centre = grid.cell_center(x, y);
                if self.cell(ctx, grid, x, y) == Cell::Open && ctx.can_move(p, centre) == Some(true) {
                    out.push(((x, y), p.distance(centre)));
                }
            }
        }
        out
    }

    /// The open 8-neighbours of `(x, y)` with their step lengths in cells; a diagonal step
    /// needs both cells beside it open.
    fn open_neighbours(&mut self, ctx: &Ctx, grid: &Grid, (x, y): (u32, u32)) -> Vec<((u32, u32), f64)> {
        let mut out = Vec::with_capacity(8);
        let [e, w, n, s] = neighbours4(grid, x, y);
        let open =
            |me: &mut Self, c: Option<(u32, u32)>| c.filter(|&(cx, cy)| me.cell(ctx, grid, cx, cy) == Cell::Open);
        let (e, w, n, s) = (open(self, e), open(self, w), open(self, n), open(self, s));
        out.extend([e, w, n, s].into_iter().flatten().map(|c| (c, 1.0)));
        for (a, b) in [(e, n), (n, w), (w, s), (s, e)] {
            if let (Some(a), Some(b)) = (a, b) {
                // The diagonal cell shares a's x or y and b's other coordinate.
                let d = if a.1 == y { (a.0, b.1) } else { (b.0, a.1) };
                if self.cell(ctx, grid, d.0, d.1) == Cell::Open {
                    out.push((d, std::f64::consts::SQRT_2));
                }
            }
        }
        out
    }

    /// A step along the path: towards the farthest of the next waypoints the known map shows
    /// a straight way to.
    fn follow(&mut self, ctx: &Ctx) -> Option<Action> {
        let p = ctx.position();
        let speed = ctx.kind.speed_m_per_round;
        while self.path.first().is_some_and(|w| w.distance(p) < 1e-6) {
            self.path.remove(0);
        }
        let ahead = self.path.len().min(LOOK_AHEAD);
        let k = (0..ahead)
            .rev()
            .find(|&k| ctx.can_move(p, self.path[k]) == Some(true))
            .unwrap_or(0);
        let to = *self.path.get(k)?;
        if to.distance(p) <= speed {
            self.path.drain(..=k);
        }
        Some(ctx.move_towards(to))
    }
}

impl Strategy for GreedyReference {
    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let Some(grid) = ctx.known().map(|k| *k.grid()) else {
            return Action::Idle;
        };
        if self.cells.is_empty() {
            self.cells = vec![Cell::Unknown; (grid.width_cells() * grid.height_cells()) as usize];
        }
        // A move that went nowhere (another robot in the way, a corner the grid allowed):
        // search again from here.
        let failed = self.moved_from.is_some_and(|p| p.distance(ctx.position()) < 1e-9);
        let stale = self.target.is_none_or(|t| !self.is_frontier(ctx, &grid, t));
        if self.path.is_empty() || stale || failed {
            let now = (ctx.position(), ctx.known().map_or(0, KnownMap::known_cells));
            if self.exhausted == Some(now) && !failed {
                return Action::Idle;
            }
            if !self.plan(ctx, &grid, failed) {
                self.exhausted = Some(now);
                return Action::Idle;
            }
        }
        ctx.set_goal(self.target.map(|(x, y)| grid.cell_center(x, y)));
        let action = self.follow(ctx).unwrap_or(Action::Idle);
        self.moved_from = matches!(action, Action::MoveTo { .. }).then(|| ctx.position());
        action
    }
}

/// A total order on path lengths (never NaN) for the heap.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ordered(f64);

impl Eq for Ordered {}

impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// East, west, north and south of `(x, y)`, where in the map.
fn neighbours4(grid: &Grid, x: u32, y: u32) -> [Option<(u32, u32)>; 4] {
    let (w, h) = (grid.width_cells(), grid.height_cells());
    [
        (x + 1 < w).then(|| (x + 1, y)),
        x.checked_sub(1).map(|x| (x, y)),
        (y + 1 < h).then(|| (x, y + 1)),
        y.checked_sub(1).map(|y| (x, y)),
    ]
}

/// The cell centres to `target`, following `prev` back to `start` (excluded) or, without
/// one, to the cell the search started from (included).
fn walk_back(grid: &Grid, prev: &[u32], target: (u32, u32), start: Option<(u32, u32)>) -> Vec<DVec2> {
    let w = grid.width_cells();
    let mut path = Vec::new();
    let mut c = target;
    while Some(c) != start {
        path.push(grid.cell_center(c.0, c.1));
        let k = prev[(c.1 * w + c.0) as usize];
        if k == u32::MAX {
            break;
        }
        c = (k % w, k / w);
    }
    path.reverse();
    path
}

/// How far (in cells) round a cell whose centre the robot does not fit at the reference
/// looks for open cells to start its search from.
const REACH_CELLS: u32 = 2;

/// The robot of the comparison: an explorer body with a 3.5 m view and 0.25 m a round that
/// uses no energy (exploration only, no trips home).
pub fn explorer_robot() -> RobotType {
    let mut t = RobotType::explorer()
        .with_speed_m_per_round(0.25)
        .with_view_radius_m(3.5);
    t.name = "explorer".into();
    t.energy_per_m = 0.0;
    t.energy_per_sense = 0.0;
    t.energy_idle = 0.0;
    t.energy_per_message = 0.0;
    t
}

/// What one exploration run reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exploration {
    /// Rounds played.
    pub rounds: u64,
    /// The explored fraction at the end.
    pub explored: f64,
    /// The round and the team's distance walked when 90 % was first explored.
    pub at_90: Option<(u64, f64)>,
    /// The same for 98 %.
    pub at_98: Option<(u64, f64)>,
    /// Metres walked in all.
    pub distance_m: f64,
    /// Of those, metres walked in rounds whose view showed nothing new.
    pub overlap_m: f64,
}

/// Play `robots` robots of [`explorer_robot`] running `strategy` (a built-in or
/// [`GREEDY_REFERENCE`]) from the map's home until 98 % of the free area is explored or
/// `max_rounds` have passed.
pub fn explore(map: &Arc<MapData>, strategy: &str, robots: u32, max_rounds: u64) -> Result<Exploration> {
    explore_with(map, strategy, &Params::default(), robots, max_rounds)
}

/// [`explore`] with the strategy's `params` (as a config's `<param>` elements give them;
/// one the strategy does not take is an error naming it).
pub fn explore_with(
    map: &Arc<MapData>,
    strategy: &str,
    params: &Params,
    robots: u32,
    max_rounds: u64,
) -> Result<Exploration> {
    Ok(play(map, strategy, params, robots, max_rounds, |_| {})?.0)
}

/// [`explore_with`], keeping where the robots stood at the start and after every round, and
/// what they explored, for [`crate::trace::picture`]. The run is the same.
pub fn explore_traced(
    map: &Arc<MapData>,
    strategy: &str,
    params: &Params,
    robots: u32,
    max_rounds: u64,
) -> Result<(Exploration, Walks)> {
    let mut positions = Vec::new();
    let mut explored_at_90 = None;
    let (run, sim) = play(map, strategy, params, robots, max_rounds, |sim| {
        positions.push(sim.robots().iter().map(|r| r.position).collect());
        if explored_at_90.is_none() && sim.report().metrics.explored_90_round > 0 {
            explored_at_90 = Some(sim.explored().clone());
        }
    })?;
    let walks = Walks {
        positions,
        explored: sim.explored().clone(),
        explored_at_90,
    };
    Ok((run, walks))
}

/// Play a run of [`explore_with`], calling `observe` before the first round and after each.
fn play(
    map: &Arc<MapData>,
    strategy: &str,
    params: &Params,
    robots: u32,
    max_rounds: u64,
    mut observe: impl FnMut(&Simulation),
) -> Result<(Exploration, Simulation)> {
    let mut sim = simulation(map, strategy, params, robots, max_rounds)?;
    observe(&sim);
    while sim.round() < max_rounds {
        let done = sim.step().metrics.explored_98_round > 0;
        observe(&sim);
        if done {
            break;
        }
    }
    let m = sim.report().metrics;
    let [_, at_90, at_98] = m.explored_milestones();
    let run = Exploration {
        rounds: sim.round(),
        explored: m.explored_fraction,
        at_90,
        at_98,
        distance_m: m.distance_m,
        overlap_m: m.overlap_m,
    };
    Ok((run, sim))
}

/// Where a run's robots stood and what they explored ([`explore_traced`]).
#[derive(Clone, Debug)]
pub struct Walks {
    /// `positions[r][i]`: robot `i` at the start (`r` = 0) and after round `r`.
    pub positions: Vec<Vec<DVec2>>,
    /// The union of their views at the end.
    pub explored: KnownMap,
    /// The union of their views when 90 % of the free area was first explored (`None` if
    /// it never was): what is explored at the end but not here was seen on the way on.
    pub explored_at_90: Option<KnownMap>,
}

/// The built-in strategies and [`GREEDY_REFERENCE`].
fn registry() -> StrategyRegistry {
    let mut registry = StrategyRegistry::with_builtins();
    registry.register(GREEDY_REFERENCE, "greedy nearest-frontier reference explorer", |_| {
        Ok(Box::new(GreedyReference::default()))
    });
    registry
}

/// Whether [`explore_with`] knows `strategy` and it takes `params`: the error it would give,
/// without a map or a simulation.
pub fn check_strategy(strategy: &str, params: &Params) -> Result<()> {
    registry().create(strategy, params)?;
    Ok(())
}

/// The simulation of [`explore`]: `robots` robots running `strategy` from `map`'s home.
fn simulation(map: &Arc<MapData>, strategy: &str, params: &Params, robots: u32, max_rounds: u64) -> Result<Simulation> {
    let registry = registry();
    let scenario = ScenarioBuilder::new(Arc::clone(map))
        .with_name("exploration")
        .with_seed(1)
        .with_rounds(max_rounds)
        .with_types(vec![explorer_robot()])
        .with_group(Group::new(strategy, 0, robots).with_params(params.clone()))
        .build(&registry)?;
    Ok(Simulation::new(scenario)?)
}

/// `k` more starts for a map: where the reference robot stands at `k` evenly spaced rounds
/// of its run from home to 90 % explored (so each is free, reachable and inside the part to
/// explore). None if the run does not reach 90 % within `max_rounds`, or reaches it in its
/// first round.
pub fn starts_along_the_reference(map: &Arc<MapData>, k: usize, max_rounds: u64) -> Result<Vec<DVec2>> {
    let mut sim = simulation(map, GREEDY_REFERENCE, &Params::default(), 1, max_rounds)?;
    let mut path = Vec::new();
    while sim.round() < max_rounds && sim.step().metrics.explored_90_round == 0 {
        path.push(sim.robots()[0].position);
    }
    if path.is_empty() || sim.report().metrics.explored_90_round == 0 {
        return Ok(Vec::new());
    }
    Ok((1..=k).map(|i| path[path.len() * i / (k + 1)]).collect())
}

/// `map` with its home moved to a disc of 0.2 m round `start` (the start of every robot).
pub fn starting_at(map: &MapData, start: DVec2) -> Arc<MapData> {
    Arc::new(MapData {
        home: HomeBase::Disc {
            center: start,
            radius_m: 0.2,
        },
        ..map.clone()
    })
}

/// A map of the comparison set: its name and map.
pub type NamedMap = (String, Arc<MapData>);

/// The comparison set: the example maps (those under `maps/` small enough to explore in
/// minutes), the indoor maps [`indoor_maps`] draws, and, with `data` (the shared map
/// folder), its ROS maps and the Stage cave.
pub fn comparison_maps(workspace: &Path, data: Option<&Path>) -> Result<Vec<NamedMap>> {
    let mut maps = Vec::new();
    for name in ["demo", "rooms", "caves", "maze"] {
        let path = workspace.join("maps").join(format!("{name}.stmap"));
        let map = MapData::load(&path).with_context(|| format!("loading {}", path.display()))?;
        maps.push((name.to_owned(), Arc::new(map)));
    }
    maps.extend(indoor_maps()?);
    if let Some(data) = data {
        for (name, file, resolution_m) in [
            ("depot (ROS)", "ros/nav2/depot.yaml", None),
            ("turtlebot3 (ROS)", "ros/turtlebot3/map.yaml", None),
            ("cave (Stage)", "images/stage/cave.png", Some(16.0 / 500.0)),
        ] {
            let path = data.join(file);
            let opts = editor::import::ImportOptions {
                resolution_m,
                ..editor::import::ImportOptions::default()
            };
            let obstacles =
                editor::import::import(&path, &opts).with_context(|| format!("importing {}", path.display()))?;
            maps.push((name.to_owned(), Arc::new(with_home(obstacles)?)));
        }
    }
    Ok(maps)
}

/// `obstacles` with a home of 0.3 m near the centre of its largest free region.
fn with_home(obstacles: ObstacleMap) -> Result<MapData> {
    let home = editor::place::auto_home(&obstacles, 0.3)?;
    Ok(MapData {
        obstacles,
        home,
        treasures: Vec::new(),
    })
}

/// Six indoor maps of 0.1 m cells, 20 m × 20 m unless said: rooms with doors (the editor's
/// generator, two seeds), a loop (a ring corridor round a block), a long corridor with
/// side rooms (40 m × 12 m), a corner maze (the editor's maze, 1.2 m corridors), and open
/// halls with pillars.
pub fn indoor_maps() -> Result<Vec<NamedMap>> {
    let cell_m = 0.1;
    let generated = |kind, seed, scale_m| -> Result<ObstacleMap> {
        let opts = editor::generate::GenerateOptions {
            width_m: 20.0,
            height_m: 20.0,
            cell_m,
            seed,
            scale_m: Some(scale_m),
            ..editor::generate::GenerateOptions::default()
        };
        Ok(editor::generate::generate(kind, &opts)?)
    };
    let drawn = |width_m: f64, height_m: f64, blocked: &dyn Fn(f64, f64) -> bool| -> Result<ObstacleMap> {
        let grid = Grid::from_size_m(DVec2::ZERO, cell_m, width_m, height_m)?;
        Ok(ObstacleMap::from_fn(grid, |x, y| {
            blocked((f64::from(x) + 0.5) * cell_m, (f64::from(y) + 0.5) * cell_m)
        }))
    };
    let border = |x: f64, y: f64, w: f64, h: f64| x < 0.3 || y < 0.3 || x > w - 0.3 || y > h - 0.3;
    // A ring corridor 3.7 m wide round a 12 m block, with a dead-end room off two of its sides.
    let ring = |x: f64, y: f64| {
        let block = (4.0..16.0).contains(&x) && (4.0..16.0).contains(&y);
        let outer = border(x, y, 20.0, 20.0);
        let inner_rooms = (5.0..8.0).contains(&x) && (5.0..8.0).contains(&y)
            || (12.0..15.0).contains(&x) && (12.0..15.0).contains(&y);
        let doors = (6.0..7.0).contains(&x) && (4.0..5.0).contains(&y)
            || (13.0..14.0).contains(&x) && (15.0..16.0).contains(&y);
        outer || (block && !inner_rooms && !doors)
    };
    // A 2 m corridor along y = 5..7 with 4 m × 4.5 m rooms on both sides, a 1 m door each.
    let corridor = |x: f64, y: f64| {
        if border(x, y, 40.0, 12.0) {
            return true;
        }
        let in_corridor = (5.0..7.0).contains(&y);
        let wall_x = (x % 5.0) < 0.2;
        let wall_y = (4.8..5.0).contains(&y) || (7.0..7.2).contains(&y);
        let door = (2.0..3.0).contains(&(x % 5.0));
        !in_corridor && (wall_x || (wall_y && !door))
    };
    // Pillars 0.6 m square every 3 m in two halls joined by a wide opening.
    let halls = |x: f64, y: f64| {
        let pillar = (x % 3.0) > 1.2 && (x % 3.0) < 1.8 && (y % 3.0) > 1.2 && (y % 3.0) < 1.8;
        let wall = (9.9..10.1).contains(&x) && !(8.0..12.0).contains(&y);
        border(x, y, 20.0, 20.0) || pillar || wall
    };
    let maps = vec![
        ("indoor rooms A", generated(editor::generate::Kind::Rooms, 1, 4.0)?),
        ("indoor rooms B", generated(editor::generate::Kind::Rooms, 2, 5.0)?),
        ("indoor loop", drawn(20.0, 20.0, &ring)?),
        ("indoor corridor", drawn(40.0, 12.0, &corridor)?),
        ("indoor corner maze", generated(editor::generate::Kind::Maze, 3, 1.2)?),
        ("indoor halls", drawn(20.0, 20.0, &halls)?),
    ];
    maps.into_iter()
        .map(|(name, obstacles)| Ok((name.to_owned(), Arc::new(with_home(obstacles)?))))
        .collect()
}
