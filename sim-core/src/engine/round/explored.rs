//! The collective explored map, for the metrics: every sensing robot's view marked from
//! where it perceived.
//!
//! The update reads only the start of the round (where each robot perceived, what its own
//! map gained), so it runs alongside step 3: [`ExploredUpdate::take`] moves what it needs
//! out of the simulation, [`ExploredUpdate::run`] does the work, and
//! [`ExploredUpdate::finish`] puts it back and credits the robots. The work is a pass on all
//! workers that sets aside the robots whose view may add to the map as it stood at the
//! start of the round (most add nothing: their view was explored already), then a pass in
//! id order that marks those robots' views, so that each free cell is credited to the
//! first robot in id order to see it. It also lists the robots whose known map changed, for
//! the round's report. `map_explored_once_and_every_free_cell_credited_once`,
//! `reports_list_changed_maps_and_first_sightings` (tests/kernel.rs) and
//! `results_do_not_depend_on_the_thread_count` check it.

use rayon::prelude::*;

use crate::engine::simulation::{ROBOTS_A_TASK, Simulation, Turn};
use crate::spatial::{BlockMemo, CellSet, Disc, DiscBeyond, KnownMap, ObstacleMap, RobotId};
use crate::world::Event;

/// A robot's known map changed this round.
const KNOWN_CHANGED: u8 = 1;
/// A robot's view may add to the collective map (it holds cells the map did not hold at
/// the start of the round).
const MAY_ADD: u8 = 2;
/// Robots a task of the pass that sorts out views: each robot's share is a few tree
/// descents.
const VIEWS_A_TASK: usize = 256;

/// The buffers the update keeps from round to round, so that it allocates nothing once warm.
#[derive(Debug, Default)]
pub(crate) struct ExploredBuffers {
    /// Free cells each robot was first to see this round.
    fresh: Vec<u64>,
    /// Each robot's [`KNOWN_CHANGED`] and [`MAY_ADD`] bits.
    flags: Vec<u8>,
    /// Each robot's view to be marked next time (this round's, or the last one's).
    next_views: Vec<Option<Disc>>,
}

/// The explored-map update of one round, detached from the simulation.
pub(super) struct ExploredUpdate {
    explored: KnownMap,
    /// Each robot's view last marked in `explored`.
    views: Vec<Option<Disc>>,
    buffers: ExploredBuffers,
    /// The robots whose known map changed this round, in id order (the report's list).
    known_changed: Vec<RobotId>,
    /// Blocks of `explored` known to be explored, to skip the squares that add nothing.
    memo: BlockMemo,
}

impl ExploredUpdate {
    /// Move the explored map, the robots' last views and the buffers out of `sim`.
    pub(super) fn take(sim: &mut Simulation) -> Self {
        let grid = *sim.explored.tree().grid();
        Self {
            explored: std::mem::replace(&mut sim.explored, KnownMap::new(grid)),
            views: std::mem::take(&mut sim.explored_views),
            buffers: std::mem::take(&mut sim.explored_buffers),
            known_changed: std::mem::take(&mut sim.report.known_changed),
            memo: std::mem::take(&mut sim.explored_memo),
        }
    }

    /// Mark every sensing robot's view (from step 2's `turns`), crediting each free cell to
    /// the first robot in id order to see it, and list the robots whose known map changed.
    /// Returns the time of the pass in id order.
    pub(super) fn run(&mut self, obstacles: &ObstacleMap, turns: &[Turn]) -> std::time::Duration {
        self.set_aside(turns);
        let t = std::time::Instant::now();
        self.mark_in_id_order(obstacles, turns);
        std::mem::swap(&mut self.views, &mut self.buffers.next_views);
        t.elapsed()
    }

    /// On all workers: each robot's flags, and the view to mark next time. A robot without
    /// [`MAY_ADD`] would mark nothing: every cell its view could add was explored at the
    /// start of the round (the test may be conservative, never the other way).
    fn set_aside(&mut self, turns: &[Turn]) {
        let (explored, memo) = (&self.explored, &self.memo);
        let ExploredBuffers { flags, next_views, .. } = &mut self.buffers;
        flags.resize(turns.len(), 0);
        next_views.resize(turns.len(), None);
        turns
            .par_iter()
            .zip(&self.views)
            .zip(next_views)
            .zip(flags)
            .with_min_len(VIEWS_A_TASK)
            .for_each(|(((turn, &seen), next), flag)| {
                *flag = if turn.known_changed { KNOWN_CHANGED } else { 0 };
                *next = seen;
                let Some(radius) = turn.sensed_m else {
                    return;
                };
                let disc = Disc {
                    center: turn.start,
                    radius,
                };
                *next = Some(disc);
                let may_add = if turn.has_known {
                    turn.new_squares
                        .iter()
                        .any(|&set| !memo.holds(set) && explored.tree().count_cells_in_set(set, false) > 0)
                } else {
                    explored.may_mark(&DiscBeyond { disc, seen })
                };
                if may_add {
                    *flag |= MAY_ADD;
                }
            });
    }

    /// In id order: list the robots whose known map changed, and mark the views set aside,
    /// counting the free cells each robot was first to see.
    fn mark_in_id_order(&mut self, obstacles: &ObstacleMap, turns: &[Turn]) {
        let fresh = &mut self.buffers.fresh;
        fresh.clear();
        fresh.resize(turns.len(), 0);
        self.known_changed.clear();
        for (i, &flag) in self.buffers.flags.iter().enumerate() {
            if flag == 0 {
                continue;
            }
            if flag & KNOWN_CHANGED != 0 {
                self.known_changed
                    .push(RobotId::new(u32::try_from(i).expect("robot ids are u32")));
            }
            if flag & MAY_ADD != 0 {
                // A robot set aside sensed this round: its view is the one to mark next time.
                let view = self.buffers.next_views[i].expect("a robot that may add sensed");
                fresh[i] = mark_view(
                    &mut self.explored,
                    &mut self.memo,
                    obstacles,
                    &turns[i],
                    view,
                    self.views[i],
                );
            }
        }
    }

    /// Put the explored map back, credit each robot's first sightings (on all workers) and
    /// insert [`Event::MapExplored`] at `event_at` (before step 3's events) if this round
    /// completed the map.
    pub(super) fn finish(self, sim: &mut Simulation, event_at: usize) {
        let cell_area = sim.map.obstacles.grid().cell_area_m2();
        let before = sim.explored_free_cells;
        sim.explored = self.explored;
        sim.explored_views = self.views;
        sim.report.known_changed = self.known_changed;
        sim.explored_memo = self.memo;
        let fresh = &self.buffers.fresh;
        // Each robot's own stats; the cells are a sum of integers, in any order the same.
        let credited: u64 = sim
            .robots
            .par_iter_mut()
            .zip(fresh)
            .zip(&sim.turns)
            .with_min_len(ROBOTS_A_TASK)
            .map(|((robot, &fresh), turn)| {
                if fresh > 0 {
                    robot.stats.explored_m2 += fresh as f64 * cell_area;
                } else if turn.sensed_m.is_some() {
                    // Step 3 has moved it: this round's move went through explored ground.
                    robot.stats.overlap_m += robot.position.distance(turn.start);
                }
                fresh
            })
            .sum();
        sim.explored_free_cells += credited;
        sim.explored_buffers = self.buffers;
        if before < sim.total_free_cells && sim.explored_free_cells == sim.total_free_cells {
            sim.report.events.insert(event_at, Event::MapExplored);
        }
    }
}

/// Mark one robot's view `disc` in `explored` (given the view it marked last time), returning
/// the free cells it was first to see.
fn mark_view(
    explored: &mut KnownMap,
    memo: &mut BlockMemo,
    obstacles: &ObstacleMap,
    turn: &Turn,
    disc: Disc,
    seen: Option<Disc>,
) -> u64 {
    let mut fresh = 0;
    let mut count_free = |set| fresh += obstacles.tree().count_cells_in_set(set, false);
    if turn.has_known {
        // Only what its own map gained can be new to everyone (a descent per square
        // instead of a walk along the view's rim).
        for &set in &turn.new_squares {
            if memo.holds(set) {
                continue;
            }
            if let Some(after) = explored.mark_cells_reporting(set, &mut count_free) {
                memo.put(set.square(), after);
            }
        }
    } else {
        // What lay wholly inside this robot's last view is explored already.
        explored.mark_reporting(&DiscBeyond { disc, seen }, |sq| count_free(CellSet::whole(sq)));
    }
    fresh
}
