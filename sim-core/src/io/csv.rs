//! The CSV outputs: per-round metrics and per-robot statistics.

use std::io::Write;

use crate::engine::Simulation;
use crate::io::observer::{Observer, ObserverError};
use crate::world::{METRICS_COLUMNS, RoundMetrics, RoundReport};

/// Writes one CSV row of metrics per round.
pub struct MetricsCsv<W: Write> {
    out: csv::Writer<W>,
}

impl<W: Write> MetricsCsv<W> {
    /// A writer that emits the header at once.
    pub fn new(out: W) -> Result<Self, csv::Error> {
        let mut out = csv::Writer::from_writer(out);
        out.write_record(METRICS_COLUMNS)?;
        Ok(Self { out })
    }

    /// A writer that emits the header and the rows of rounds already played (a resumed
    /// run's, from its checkpoint), so that its file is the one an uninterrupted run writes.
    pub fn with_rows(out: W, rows: &[RoundMetrics]) -> Result<Self, csv::Error> {
        let mut this = Self::new(out)?;
        for r in rows {
            this.out.write_record(r.csv_record())?;
        }
        Ok(this)
    }

    /// Flush and hand back the writer (for example the bytes written to a `Vec<u8>`).
    pub fn into_inner(self) -> std::io::Result<W> {
        self.out.into_inner().map_err(csv::IntoInnerError::into_error)
    }
}

impl<W: Write> Observer for MetricsCsv<W> {
    fn on_round(&mut self, _sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        self.out.write_record(report.metrics.csv_record())?;
        Ok(())
    }
    fn on_finish(&mut self, _sim: &Simulation) -> Result<(), ObserverError> {
        self.out.flush()?;
        Ok(())
    }
}

/// Columns of the per-robot statistics CSV.
pub const ROBOT_STATS_COLUMNS: [&str; 15] = [
    "robot",
    "group",
    "type",
    "strategy",
    "alive",
    "distance_m",
    "explored_m2",
    "treasures_found",
    "units_dug",
    "units_delivered",
    "energy_used",
    "energy_left",
    "messages_sent",
    "message_bytes",
    "overlap_m",
];

/// Write the per-robot statistics of a run as CSV.
pub fn write_robot_stats<W: Write>(sim: &Simulation, out: W) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(ROBOT_STATS_COLUMNS)?;
    for r in sim.robots() {
        let s = &r.stats;
        let group = &sim.groups()[r.group];
        w.write_record([
            r.id.to_string(),
            group.name.clone(),
            sim.types()[r.type_index].name.clone(),
            group.strategy.clone(),
            r.alive.to_string(),
            format!("{:.3}", s.distance_m),
            format!("{:.3}", s.explored_m2),
            s.treasures_found.to_string(),
            s.units_dug.to_string(),
            s.units_delivered.to_string(),
            format!("{:.3}", s.energy_used),
            format!("{:.3}", r.energy),
            s.messages_sent.to_string(),
            s.message_bytes.to_string(),
            format!("{:.3}", s.overlap_m),
        ])?;
    }
    w.flush()?;
    Ok(())
}
