//! Per-round metrics and the CSV outputs.

use std::io::Write;

use crate::observer::{Observer, ObserverError, RoundReport};
use crate::sim::Simulation;

/// Columns of the per-round metrics CSV, in order.
pub const METRICS_COLUMNS: [&str; 12] = [
    "round",
    "explored_fraction",
    "treasures_found",
    "treasures_excavated",
    "treasures_delivered",
    "robots_alive",
    "mean_energy",
    "messages",
    "distance_m",
    "units_dug",
    "units_delivered",
    "message_bytes",
];

/// The state of a run after a round.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundMetrics {
    /// Round number (1-based).
    pub round: u64,
    /// Free area inside the union of all known regions ÷ total free area.
    pub explored_fraction: f64,
    /// Treasures seen by some robot so far.
    pub treasures_found: u32,
    /// Treasures with nothing left buried.
    pub treasures_excavated: u32,
    /// Treasures with every unit delivered.
    pub treasures_delivered: u32,
    /// Robots with energy left.
    pub robots_alive: u32,
    /// Mean energy of the live robots (0 when none).
    pub mean_energy: f64,
    /// Messages sent this round.
    pub messages: u64,
    /// Metres travelled by all robots since the start.
    pub distance_m: f64,
    /// Units dug since the start.
    pub units_dug: u64,
    /// Units delivered since the start.
    pub units_delivered: u64,
    /// Payload bytes sent this round.
    pub message_bytes: u64,
}

impl RoundMetrics {
    /// The values in [`METRICS_COLUMNS`] order, formatted for CSV.
    pub fn csv_record(&self) -> [String; 12] {
        [
            self.round.to_string(),
            format!("{:.6}", self.explored_fraction),
            self.treasures_found.to_string(),
            self.treasures_excavated.to_string(),
            self.treasures_delivered.to_string(),
            self.robots_alive.to_string(),
            format!("{:.3}", self.mean_energy),
            self.messages.to_string(),
            format!("{:.3}", self.distance_m),
            self.units_dug.to_string(),
            self.units_delivered.to_string(),
            self.message_bytes.to_string(),
        ]
    }
}

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
pub const ROBOT_STATS_COLUMNS: [&str; 14] = [
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
];

/// Write the per-robot statistics of a run as CSV.
pub fn write_robot_stats<W: Write>(sim: &Simulation, out: W) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(ROBOT_STATS_COLUMNS)?;
    for r in sim.robots() {
        let s = &r.stats;
        let group = &sim.groups()[r.group];
        w.write_record([
            r.id.0.to_string(),
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
        ])?;
    }
    w.flush()?;
    Ok(())
}
