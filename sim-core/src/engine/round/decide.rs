//! Step 2: every live robot's strategy decides one action and its messages, in parallel;
//! each robot owns its strategy and data, nothing shared is written.

use rayon::prelude::*;

use super::perceive::{Snapshot, perceive};
use crate::agent::{Ctx, WorldView};
use crate::engine::simulation::Simulation;
use crate::world::Action;

impl Simulation {
    /// Steps 1 and 2, in parallel over robots.
    pub(super) fn perceive_and_decide(&mut self, round: u64) {
        let world = WorldView::new(&self.map.obstacles, &self.nav, self.map.home, &self.types);
        let snapshot = Snapshot {
            robots: &self.robots,
            treasures: &self.treasures,
            treasure_index: &self.treasure_index,
            robot_index: &self.robot_index,
        };
        let seed = self.seed;
        let types = &self.types;
        self.agents
            .par_iter_mut()
            .zip(self.robots.par_iter())
            .for_each(|(agent, robot)| {
                agent.mind.output.begin_round();
                agent.known_changed = false;
                if !robot.alive {
                    agent.action = Action::Idle;
                    return;
                }
                let kind = &types[robot.type_index];
                perceive(agent, robot, kind, &snapshot, round);
                let rng = Simulation::rng_for(seed, robot.id, round);
                let mut ctx = Ctx::new(round, robot, kind, world, rng, &mut agent.mind);
                agent.action = agent.strategy.decide(&mut ctx);
            });
    }
}
