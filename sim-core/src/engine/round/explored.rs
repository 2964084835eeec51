//! The collective explored map, for the metrics: every sensing robot's view marked from
//! where it perceived.
//!
//! The update reads only the start of the round (where each robot perceived, what its own
//! map gained), so it runs alongside step 3 on another thread: [`ExploredUpdate::take`]
//! moves what it needs out of the simulation, [`ExploredUpdate::run`] does the work, and
//! [`ExploredUpdate::finish`] puts it back and credits the robots in id order. It also lists
//! the robots whose known map changed, for the round's report, in the same pass over the
//! turns. `map_explored_once_and_every_free_cell_credited_once` and
//! `reports_list_changed_maps_and_first_sightings` (tests/kernel.rs) check both.

use crate::engine::simulation::{Simulation, Turn};
use crate::spatial::{BlockMemo, CellSet, Disc, DiscBeyond, KnownMap, ObstacleMap, RobotId};
use crate::world::Event;

/// The explored-map update of one round, detached from the simulation.
pub(super) struct ExploredUpdate {
    explored: KnownMap,
    views: Vec<Option<Disc>>,
    /// Free cells each robot was first to see (a buffer kept from round to round).
    fresh: Vec<u64>,
    /// The robots whose known map changed this round, in id order (the report's list).
    known_changed: Vec<RobotId>,
    /// Blocks of `explored` known to be explored, to skip the squares that add nothing.
    memo: BlockMemo,
}

impl ExploredUpdate {
    /// Move the explored map, the robots' last views and the buffer out of `sim`.
    pub(super) fn take(sim: &mut Simulation) -> Self {
        let grid = *sim.explored.tree().grid();
        Self {
            explored: std::mem::replace(&mut sim.explored, KnownMap::new(grid)),
            views: std::mem::take(&mut sim.explored_views),
            fresh: std::mem::take(&mut sim.explored_fresh),
            known_changed: std::mem::take(&mut sim.report.known_changed),
            memo: std::mem::take(&mut sim.explored_memo),
        }
    }

    /// Mark every sensing robot's view (from step 2's `turns`), in id order, counting the
    /// free cells it was first to see; and list the robots whose known map changed.
    pub(super) fn run(&mut self, obstacles: &ObstacleMap, turns: &[Turn]) {
        self.fresh.clear();
        self.fresh.resize(turns.len(), 0);
        self.known_changed.clear();
        for (i, turn) in turns.iter().enumerate() {
            if turn.known_changed {
                self.known_changed
                    .push(RobotId::new(u32::try_from(i).expect("robot ids are u32")));
            }
            let Some(radius) = turn.sensed_m else {
                continue;
            };
            let disc = Disc {
                center: turn.start,
                radius,
            };
            let mut fresh = 0;
            let mut count_free = |set| fresh += obstacles.tree().count_cells_in_set(set, false);
            if turn.has_known {
                // Only what its own map gained can be new to everyone (a descent per square
                // instead of a walk along the view's rim).
                for &set in &turn.new_squares {
                    if self.memo.holds(set) {
                        continue;
                    }
                    if let Some(after) = self.explored.mark_cells_reporting(set, &mut count_free) {
                        self.memo.put(set.square(), after);
                    }
                }
            } else {
                // What lay wholly inside this robot's last view is explored already.
                let seen = self.views[i];
                self.explored
                    .mark_reporting(&DiscBeyond { disc, seen }, |sq| count_free(CellSet::whole(sq)));
            }
            self.views[i] = Some(disc);
            self.fresh[i] = fresh;
        }
    }

    /// Put the explored map back, credit each robot's first sightings (in id order) and
    /// insert [`Event::MapExplored`] at `event_at` (before step 3's events) if this round
    /// completed the map.
    pub(super) fn finish(self, sim: &mut Simulation, event_at: usize) {
        let cell_area = sim.map.obstacles.grid().cell_area_m2();
        let before = sim.explored_free_cells;
        sim.explored = self.explored;
        sim.explored_views = self.views;
        sim.report.known_changed = self.known_changed;
        sim.explored_memo = self.memo;
        for ((robot, &fresh), turn) in sim.robots.iter_mut().zip(&self.fresh).zip(&sim.turns) {
            if fresh > 0 {
                sim.explored_free_cells += fresh;
                robot.stats.explored_m2 += fresh as f64 * cell_area;
            } else if turn.sensed_m.is_some() {
                // Step 3 has moved it: this round's move went through explored ground.
                robot.stats.overlap_m += robot.position.distance(turn.start);
            }
        }
        sim.explored_fresh = self.fresh;
        if before < sim.total_free_cells && sim.explored_free_cells == sim.total_free_cells {
            sim.report.events.insert(event_at, Event::MapExplored);
        }
    }
}
