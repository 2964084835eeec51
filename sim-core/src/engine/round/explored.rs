//! The collective explored map, for the metrics: every sensing robot's view marked from
//! where it perceived.

use crate::engine::simulation::Simulation;
use crate::spatial::{Disc, DiscBeyond};
use crate::world::Event;

impl Simulation {
    /// Mark every sensing robot's view (from where it perceived) in the collective explored
    /// map, crediting the free area it was first to see; feeds the step-4 metrics.
    pub(super) fn update_explored(&mut self) {
        let obstacles = &self.map.obstacles;
        let cell_area = obstacles.grid().cell_area_m2();
        let before = self.explored_free_cells;
        let last_views = &mut self.explored_views;
        for ((robot, agent), seen) in self.robots.iter_mut().zip(&self.agents).zip(last_views) {
            if !agent.needs.senses() || !robot.alive {
                continue;
            }
            let disc = Disc {
                center: robot.position,
                radius: self.types[robot.type_index].view_radius_m,
            };
            let mut fresh = 0;
            let mut count_free = |sq| fresh += obstacles.tree().count_cells_in(sq, false);
            if agent.mind.data.known.is_some() {
                // Only what its own map gained can be new to everyone (a descent per square
                // instead of a walk along the view's rim).
                for &sq in &agent.new_squares {
                    let square = obstacles.grid().square(sq.x, sq.y, sq.level);
                    self.explored.mark_reporting(&square, &mut count_free);
                }
            } else {
                // What lay wholly inside this robot's last view is explored already.
                self.explored
                    .mark_reporting(&DiscBeyond { disc, seen: *seen }, &mut count_free);
            }
            *seen = Some(disc);
            self.explored_free_cells += fresh;
            robot.stats.explored_m2 += fresh as f64 * cell_area;
        }
        if before < self.total_free_cells && self.explored_free_cells == self.total_free_cells {
            self.report.events.push(Event::MapExplored);
        }
    }
}
