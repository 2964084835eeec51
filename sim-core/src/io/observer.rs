//! The observer interface: how viewers, recorders and tests watch a run (as rapier's
//! `DebugRenderBackend`). sim-core calls it; viewer-bridge implements it for Rerun.

use crate::engine::Simulation;
use crate::world::RoundReport;

/// The error an observer may stop a run with.
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

/// Watches a run. Every method sees the full simulation state (read only).
pub trait Observer {
    /// Before the first round.
    fn on_start(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        let _ = sim;
        Ok(())
    }
    /// After every round.
    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError>;
    /// After the last round.
    fn on_finish(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        let _ = sim;
        Ok(())
    }
}

impl Simulation {
    /// Run every remaining round, notifying the observers; stops at the first observer error.
    pub fn run(&mut self, observers: &mut [&mut dyn Observer]) -> Result<(), ObserverError> {
        for o in observers.iter_mut() {
            o.on_start(self)?;
        }
        while self.round() < self.total_rounds() {
            self.step();
            let sim = &*self;
            for o in observers.iter_mut() {
                o.on_round(sim, sim.report())?;
            }
        }
        for o in observers.iter_mut() {
            o.on_finish(self)?;
        }
        Ok(())
    }
}
