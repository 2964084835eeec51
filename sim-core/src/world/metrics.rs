//! Per-round metrics, declared once: the table below makes the [`RoundMetrics`] fields, the
//! CSV columns ([`METRICS_COLUMNS`], [`RoundMetrics::csv_record`]) and the chart series
//! ([`RoundMetrics::series`]) that viewers draw, so they can never drift apart.

/// Declares the metrics: `field: type, CSV format, chart path` with the field's docs.
macro_rules! metrics_table {
    ($($(#[$doc:meta])* $field:ident: $ty:ty, $fmt:literal, $chart:literal;)*) => {
        /// The state of a run after a round.
        #[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
        pub struct RoundMetrics {
            $($(#[$doc])* pub $field: $ty,)*
        }

        /// Columns of the per-round metrics CSV, in order.
        pub const METRICS_COLUMNS: [&str; METRICS_COUNT] = [$(stringify!($field)),*];

        /// Chart path (below `metrics/`) of every column but `round`, which is the timeline.
        const CHARTS: [&str; METRICS_COUNT] = [$($chart),*];

        impl RoundMetrics {
            /// The values in [`METRICS_COLUMNS`] order, formatted for CSV.
            pub fn csv_record(&self) -> [String; METRICS_COUNT] {
                [$(format!($fmt, self.$field)),*]
            }

            /// Every value in [`METRICS_COLUMNS`] order as `f64` (counts are exact below 2⁵³).
            #[allow(clippy::unnecessary_cast, clippy::cast_lossless)] // the table mixes f64 and integer columns
            pub fn values(&self) -> [f64; METRICS_COUNT] {
                [$(self.$field as f64),*]
            }
        }
    };
}

/// Number of metric columns (the round included).
pub const METRICS_COUNT: usize = 21;

metrics_table! {
    /// Round number (1-based).
    round: u64, "{}", "";
    /// Free area inside the union of all known regions ÷ total free area.
    explored_fraction: f64, "{:.6}", "exploration/explored_fraction";
    /// Treasures seen by some robot so far.
    treasures_found: u32, "{}", "treasures/found";
    /// Treasures with nothing left buried.
    treasures_excavated: u32, "{}", "treasures/excavated";
    /// Treasures with every unit delivered.
    treasures_delivered: u32, "{}", "treasures/delivered";
    /// Robots with energy left.
    robots_alive: u32, "{}", "robots/alive";
    /// Mean energy of the live robots (0 when none).
    mean_energy: f64, "{:.3}", "energy/mean_energy";
    /// Messages sent this round.
    messages: u64, "{}", "messages/messages";
    /// Metres travelled by all robots since the start.
    distance_m: f64, "{:.3}", "totals/distance_m";
    /// Units dug since the start.
    units_dug: u64, "{}", "totals/units_dug";
    /// Units delivered since the start.
    units_delivered: u64, "{}", "totals/units_delivered";
    /// Payload bytes sent this round.
    message_bytes: u64, "{}", "messages/message_bytes";
    /// Robots disabled since the start because their strategy failed (panicked).
    strategies_failed: u32, "{}", "robots/strategies_failed";
    /// Bytes held by all robots' known maps (what the paper's Fig. 4 plots).
    known_map_bytes: u64, "{}", "memory/known_map_bytes";
    /// Metres walked since the start in rounds whose view showed the team nothing new (the
    /// team's overlap; see [`RobotStats::overlap_m`](crate::world::RobotStats::overlap_m)).
    overlap_m: f64, "{:.3}", "totals/overlap_m";
    /// The first round at the end of which 50 % of the free area was explored (0: not yet).
    explored_50_round: u64, "{}", "milestones/explored_50_round";
    /// `distance_m` at that round (0: not yet).
    explored_50_distance_m: f64, "{:.3}", "milestones/explored_50_distance_m";
    /// The same for 90 %.
    explored_90_round: u64, "{}", "milestones/explored_90_round";
    /// `distance_m` at that round (0: not yet).
    explored_90_distance_m: f64, "{:.3}", "milestones/explored_90_distance_m";
    /// The same for 98 %.
    explored_98_round: u64, "{}", "milestones/explored_98_round";
    /// `distance_m` at that round (0: not yet).
    explored_98_distance_m: f64, "{:.3}", "milestones/explored_98_distance_m";
}

/// The explored fractions whose first reaching the metrics record: 50, 90 and 98 % of the
/// free area.
pub const EXPLORED_MILESTONES: [f64; 3] = [0.5, 0.9, 0.98];

/// When a run first reached each of [`EXPLORED_MILESTONES`]: the round, and the metres the
/// team had walked by its end. State of a run (kept in checkpoints).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExploredMilestones {
    /// Per milestone, `(round, distance_m)` once reached.
    pub reached: [Option<(u64, f64)>; 3],
}

impl ExploredMilestones {
    /// Note round `m` (a milestone is reached when `explored_fraction` is at least its
    /// fraction), then write the milestones into its columns.
    pub fn note(&mut self, m: &mut RoundMetrics) {
        for (reached, &fraction) in self.reached.iter_mut().zip(&EXPLORED_MILESTONES) {
            if reached.is_none() && m.explored_fraction >= fraction {
                *reached = Some((m.round, m.distance_m));
            }
        }
        let [(r50, d50), (r90, d90), (r98, d98)] = self.reached.map(|r| r.unwrap_or((0, 0.0)));
        (m.explored_50_round, m.explored_50_distance_m) = (r50, d50);
        (m.explored_90_round, m.explored_90_distance_m) = (r90, d90);
        (m.explored_98_round, m.explored_98_distance_m) = (r98, d98);
    }
}

impl RoundMetrics {
    /// Per fraction of [`EXPLORED_MILESTONES`], the round and `distance_m` at which it was
    /// first reached, as its columns hold them (`None`: not yet).
    pub fn explored_milestones(&self) -> [Option<(u64, f64)>; 3] {
        [
            (self.explored_50_round, self.explored_50_distance_m),
            (self.explored_90_round, self.explored_90_distance_m),
            (self.explored_98_round, self.explored_98_distance_m),
        ]
        .map(|(round, distance_m)| (round > 0).then_some((round, distance_m)))
    }

    /// `(column, chart path below "metrics/", value)` of every metric but the round.
    pub fn series(&self) -> impl Iterator<Item = (&'static str, &'static str, f64)> + use<> {
        let values = self.values();
        (1..METRICS_COUNT).map(move |i| (METRICS_COLUMNS[i], CHARTS[i], values[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::float_cmp)] // the values are exact decimal literals parsed back
    fn columns_records_and_series_line_up() {
        let m = RoundMetrics {
            round: 7,
            explored_fraction: 0.25,
            treasures_found: 3,
            mean_energy: 12.5,
            message_bytes: 99,
            ..RoundMetrics::default()
        };
        let record = m.csv_record();
        assert_eq!(METRICS_COLUMNS[0], "round");
        assert_eq!(record[0], "7");
        assert_eq!(record[1], "0.250000");
        assert_eq!(record[2], "3");
        assert_eq!(record[6], "12.500");
        let series: Vec<_> = m.series().collect();
        assert_eq!(series.len(), METRICS_COUNT - 1);
        assert_eq!(series[0], ("explored_fraction", "exploration/explored_fraction", 0.25));
        assert_eq!(series[10], ("message_bytes", "messages/message_bytes", 99.0));
    }
}
