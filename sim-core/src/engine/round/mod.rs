//! The round loop, top-down: perceive → decide → resolve → observe.
//!
//! 1. **Perceive** (parallel): every live robot sees the state as it was at the start of the
//!    round and reads the messages delivered to it.
//! 2. **Decide** (parallel, fused with 1): its strategy picks one action and any messages;
//!    each robot owns its strategy and data, nothing shared is written.
//! 3. **Resolve** (the outcome of one pass by robot id): the physical unit charges energy
//!    and refuses or trims what is illegal (speed, energy, obstacles, other robots,
//!    abilities, capacity), then applies the rest; messages are addressed to whoever was in
//!    range at send time. A robot whose turn depends on nobody has it in step 2. The rest go
//!    in id order, or side by side (see `TurnSharing`): the moves settled by strips of the
//!    map, then the turns taken at once (those at treasures in id order). Meanwhile the views
//!    of step 1 are marked in the collective explored map (see `explored`).
//! 4. **Observe**: metrics update (their terms gathered on all workers, the floating-point
//!    sums taken in id order); the caller notifies observers with the round's report.
//!
//! Randomness comes from generators seeded by (run seed, robot, round), and step 3's outcome
//! is that of its pass in id order however its work is shared, so results do not depend on
//! the thread count.
//!
//! Modules: `decide` and `perceive` (steps 1 and 2), `resolve` (step 3's order), `turn` (one
//! robot's turn), `moves` (moves settled side by side), `contact` (who could be in a move's
//! way), `deliver` (messages within radio budgets), `explored` (the collective map).

mod contact;
mod decide;
mod deliver;
mod explored;
mod moves;
mod perceive;
mod resolve;
mod turn;

use std::time::{Duration, Instant};

use explored::ExploredUpdate;

pub(crate) use explored::ExploredBuffers;
pub use perceive::MAX_MAP_MERGES_PER_ROUND;
pub(crate) use resolve::{Step3, TurnKind};

use crate::engine::simulation::Simulation;
use crate::world::{RoundMetrics, RoundReport};

impl Simulation {
    /// Play one round and return its report.
    pub fn step(&mut self) -> &RoundReport {
        self.round += 1;
        let round = self.round;
        // Cleared, not replaced: in crowds the links alone are millions a round, and fresh
        // vectors would be grown (and their pages faulted in) again every round.
        self.report.round = round;
        self.report.metrics = RoundMetrics::default();
        self.report.events.clear();
        self.report.known_changed.clear();
        self.report.slow_decisions.clear();
        let started = Instant::now();
        // The steps timed apart this round (the rest is `other`).
        let mut apart = Duration::ZERO;
        // 1 + 2: perceive and decide, in parallel.
        let t = Instant::now();
        let mailbag = self.take_mailbag();
        self.phase_times.inboxes += t.elapsed();
        let t = Instant::now();
        let any_news = self.perceive_and_decide(round, mailbag.as_ref());
        let took = t.elapsed();
        self.phase_times.perceive_decide += took;
        apart += took;
        let t = Instant::now();
        self.record_discoveries(round, any_news);
        self.phase_times.discoveries += t.elapsed();
        // 3: resolve, while the collective explored map is updated beside it (it reads only
        // the start of the round).
        let mut explored = ExploredUpdate::take(self);
        let event_at = self.report.events.len();
        let map = std::sync::Arc::clone(&self.map);
        // Both sides read the turns; neither writes them.
        let turns = std::mem::take(&mut self.turns);
        let t = Instant::now();
        let ((messages, bytes), (explored_took, marking_took)) = rayon::join(
            || self.resolve(round, &turns),
            || {
                let t = Instant::now();
                let marking = explored.run(&map.obstacles, &turns);
                (t.elapsed(), marking)
            },
        );
        let took = t.elapsed();
        self.phase_times.resolve += took;
        self.phase_times.explored += explored_took;
        self.phase_times.explored_marking += marking_took;
        apart += took;
        self.turns = turns;
        let t = Instant::now();
        explored.finish(self, event_at);
        let mut crediting_took = t.elapsed();
        if self.radio_limited {
            let t = Instant::now();
            self.deliver_within_budget();
            let took = t.elapsed();
            self.phase_times.deliver += took;
            apart += took;
        }
        // 4: observe (the caller hands the report to the observers), its terms gathered
        // beside the rebuild of the robot indexes for the next round.
        let (tallies, indexes_took, terms_took) = self.rebuild_indexes_beside_metric_terms();
        self.phase_times.indexes += indexes_took;
        self.phase_times.indexes_in_order += self.robot_indexes_in_order_time();
        crediting_took += terms_took;
        self.phase_times.crediting += crediting_took;
        let t = Instant::now();
        self.report.metrics = self.sum_metrics(round, messages, bytes, tallies.known_bytes, tallies);
        self.milestones.note(&mut self.report.metrics);
        self.phase_times.metrics += t.elapsed();
        self.phase_times.other += started.elapsed().saturating_sub(apart);
        &self.report
    }
}
