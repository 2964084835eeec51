//! The collective explored map, for the metrics: every sensing robot's view marked from
//! where it perceived.
//!
//! The update reads only the start of the round (where each robot perceived, what its own
//! map gained), so it runs alongside step 3 on another thread: [`ExploredUpdate::take`]
//! moves what it needs out of the simulation, [`ExploredUpdate::run`] does the work, and
//! [`ExploredUpdate::finish`] puts it back and credits the robots in id order.

use glam::DVec2;

use crate::engine::simulation::Simulation;
use crate::spatial::{CellSet, Disc, DiscBeyond, KnownMap, ObstacleMap};
use crate::world::Event;

/// One robot as the explored-map update sees it at the start of the round.
struct Viewer {
    position: DVec2,
    view_radius_m: f64,
    /// Alive and sensing.
    senses: bool,
    /// Keeps its own known map (then `new_squares` is what it gained this round).
    has_known: bool,
}

/// The explored-map update of one round, detached from the simulation.
pub(super) struct ExploredUpdate {
    explored: KnownMap,
    views: Vec<Option<Disc>>,
    viewers: Vec<Viewer>,
    /// Each robot's new squares (moved out of its agent, given back in `finish`).
    new_squares: Vec<Vec<CellSet>>,
    /// Free cells each robot was first to see.
    fresh: Vec<u64>,
}

impl ExploredUpdate {
    /// Move the explored map and each robot's start-of-round view out of `sim`.
    pub(super) fn take(sim: &mut Simulation) -> Self {
        let viewers = sim
            .robots
            .iter()
            .zip(&sim.agents)
            .zip(&sim.start_positions)
            .map(|((robot, agent), &position)| Viewer {
                position,
                view_radius_m: sim.types[robot.type_index].view_radius_m,
                senses: agent.needs.senses() && robot.alive,
                has_known: agent.mind.data.known.is_some(),
            })
            .collect();
        let new_squares = sim
            .agents
            .iter_mut()
            .map(|a| std::mem::take(&mut a.new_squares))
            .collect();
        let grid = *sim.explored.tree().grid();
        Self {
            explored: std::mem::replace(&mut sim.explored, KnownMap::new(grid)),
            views: std::mem::take(&mut sim.explored_views),
            viewers,
            new_squares,
            fresh: Vec::new(),
        }
    }

    /// Mark every sensing robot's view, in id order, counting the free cells it was first to
    /// see.
    pub(super) fn run(&mut self, obstacles: &ObstacleMap) {
        self.fresh = vec![0; self.viewers.len()];
        for (i, viewer) in self.viewers.iter().enumerate() {
            if !viewer.senses {
                continue;
            }
            let disc = Disc {
                center: viewer.position,
                radius: viewer.view_radius_m,
            };
            let mut fresh = 0;
            let mut count_free = |set| fresh += obstacles.tree().count_cells_in_set(set, false);
            if viewer.has_known {
                // Only what its own map gained can be new to everyone (a descent per square
                // instead of a walk along the view's rim).
                for &set in &self.new_squares[i] {
                    self.explored.mark_cells_reporting(set, &mut count_free);
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
        for ((robot, agent), (fresh, squares)) in sim
            .robots
            .iter_mut()
            .zip(&mut sim.agents)
            .zip(self.fresh.into_iter().zip(self.new_squares))
        {
            agent.new_squares = squares;
            sim.explored_free_cells += fresh;
            robot.stats.explored_m2 += fresh as f64 * cell_area;
        }
        if before < sim.total_free_cells && sim.explored_free_cells == sim.total_free_cells {
            sim.report.events.insert(event_at, Event::MapExplored);
        }
    }
}
