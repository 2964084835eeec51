//! A progress bar observer (drawn only on a terminal).

use indicatif::{ProgressBar, ProgressStyle};
use sim_core::engine::Simulation;
use sim_core::io::{Observer, ObserverError};
use sim_core::world::RoundReport;

/// Shows rounds done, rate and the explored fraction.
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar for `rounds` rounds, `done` of them already played (a resumed run);
    /// `enabled = false` (or no terminal) draws nothing.
    pub fn new(enabled: bool, done: u64, rounds: u64) -> Self {
        let bar = enabled.then(|| {
            let bar = ProgressBar::new(rounds);
            bar.set_position(done);
            // Rate and finish time from the rounds played here, not those before.
            bar.reset_eta();
            bar.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} rounds ({per_sec}, eta {eta}) {msg}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar
        });
        Self { bar }
    }
}

impl Observer for Progress {
    fn on_round(&mut self, _sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        if let Some(bar) = &self.bar {
            bar.set_position(report.round);
            if report.round.is_multiple_of(10) {
                let m = &report.metrics;
                bar.set_message(format!(
                    "explored {:.1} %, delivered {}",
                    100.0 * m.explored_fraction,
                    m.treasures_delivered
                ));
            }
        }
        Ok(())
    }

    fn on_finish(&mut self, _sim: &Simulation) -> Result<(), ObserverError> {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        Ok(())
    }
}
