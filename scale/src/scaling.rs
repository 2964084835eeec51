//! The scaling report: where a round's time goes on one thread, which of it runs on one
//! thread only, and what Amdahl's law then allows on more cores.
//!
//! A round whose one-thread share `s` cannot be spread over workers runs at most
//! `1 / (s + (1 − s) / n)` times faster on `n` cores, however fast the rest becomes.
//!
//! ```
//! use scale::scaling::amdahl;
//!
//! // A quarter of the round on one thread: 4 cores give at most 1 / (0.25 + 0.75 / 4).
//! assert!((amdahl(0.25, 4) - 1.0 / 0.4375).abs() < 1e-12);
//! ```

use std::time::Duration;

use sim_core::engine::PhaseTimes;

/// One step of the round in the report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phase {
    /// What the step does.
    pub name: &'static str,
    /// Whether the step runs on one thread whatever the workers (a step of a few tasks side
    /// by side counts as one thread: more cores do not shorten it).
    pub one_thread: bool,
    /// Its wall time over the timed rounds.
    pub time: Duration,
}

/// The round's steps as [`PhaseTimes`] measured them, in round order. On one thread their
/// times add up to the rounds' wall time; "rest" is what no other step holds (clearing the
/// report, the join around step 3). On more, steps run beside each other overlap (the
/// explored map beside resolve, the robot indexes beside the metrics' terms).
pub fn phases(p: &PhaseTimes) -> Vec<Phase> {
    let named_other = p.inboxes + p.discoveries + p.indexes + p.crediting + p.metrics;
    let resolve_apart = p.in_order + p.ordering + p.side_by_side + p.events + p.addressing + p.fan_out + p.explored;
    let rest = p.other.saturating_sub(named_other) + p.resolve.saturating_sub(resolve_apart);
    let phase = |name, one_thread, time| Phase { name, one_thread, time };
    vec![
        phase("mailbag (last round's messages)", true, p.inboxes),
        phase("perceive + decide", false, p.perceive_decide),
        phase("discoveries", true, p.discoveries),
        phase("resolve: turns in id order", true, p.in_order),
        phase("resolve: sorting; at treasures", true, p.ordering),
        phase("resolve: turns side by side", false, p.side_by_side),
        phase("resolve: events; sends joined", true, p.events),
        phase("resolve: addressing sends", false, p.addressing),
        phase("resolve: fan-out to inboxes", false, p.fan_out),
        phase(
            "explored map: sorting out views",
            false,
            p.explored.saturating_sub(p.explored_marking),
        ),
        phase("explored map: marking in id order", true, p.explored_marking),
        phase("deliver within radio budgets", false, p.deliver),
        phase(
            "robot indexes: cells, copies",
            false,
            p.indexes.saturating_sub(p.indexes_in_order),
        ),
        phase("robot indexes: counting, places", true, p.indexes_in_order),
        phase("crediting; metrics' terms", false, p.crediting),
        phase("metrics: sums in id order", true, p.metrics),
        phase("rest", true, rest),
    ]
}

/// The share of `phases`' time spent in steps that run on one thread (0 when there is no
/// time at all).
pub fn sequential_share(phases: &[Phase]) -> f64 {
    let total: f64 = phases.iter().map(|p| p.time.as_secs_f64()).sum();
    if total == 0.0 {
        return 0.0;
    }
    phases
        .iter()
        .filter(|p| p.one_thread)
        .map(|p| p.time.as_secs_f64())
        .sum::<f64>()
        / total
}

/// Amdahl's law: the most a round whose sequential share is `s` can gain on `cores` cores.
pub fn amdahl(s: f64, cores: u32) -> f64 {
    1.0 / (s + (1.0 - s) / f64::from(cores))
}

/// The Karp–Flatt metric: the serial fraction that a measured speed-up `speedup` on
/// `threads` threads implies, `(1/speedup − 1/threads) / (1 − 1/threads)`. It also counts
/// what parallel steps lose to imbalance and waking workers. `None` for one thread.
pub fn karp_flatt(speedup: f64, threads: usize) -> Option<f64> {
    if threads < 2 {
        return None;
    }
    let p = threads as f64;
    Some((1.0 / speedup - 1.0 / p) / (1.0 - 1.0 / p))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use sim_core::engine::PhaseTimes;

    use super::{amdahl, karp_flatt, phases, sequential_share};

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    /// A one-thread round worked out by hand: resolve 50 ms = 8 in id order + 2 ordering +
    /// 15 side by side + 2 events + 3 addressing + 5 fan-out + 10 explored (3 of them
    /// marking) + 5 rest; other 40 ms = 4 inboxes + 6 discoveries + 10 indexes (4 of them
    /// counting and placing) + 7 crediting + 5 metrics + 8 rest. The phases add up to the
    /// round, and 8 + 2 + 2 + 3 + 4 + 6 + 4 + 5 + 13 of the 200 ms run on one thread.
    #[test]
    fn phases_partition_the_round_and_the_one_thread_share_is_theirs() {
        let p = PhaseTimes {
            perceive_decide: ms(100),
            resolve: ms(50),
            deliver: ms(10),
            other: ms(40),
            in_order: ms(8),
            ordering: ms(2),
            side_by_side: ms(15),
            events: ms(2),
            addressing: ms(3),
            fan_out: ms(5),
            explored: ms(10),
            explored_marking: ms(3),
            inboxes: ms(4),
            discoveries: ms(6),
            indexes: ms(10),
            indexes_in_order: ms(4),
            crediting: ms(7),
            metrics: ms(5),
            ..PhaseTimes::default()
        };
        let list = phases(&p);
        let total: Duration = list.iter().map(|p| p.time).sum();
        assert_eq!(total, ms(200));
        let rest = list.iter().find(|p| p.name == "rest").unwrap();
        assert_eq!(rest.time, ms(13));
        let s = sequential_share(&list);
        assert!((s - 47.0 / 200.0).abs() < 1e-12, "{s}");
        assert!(sequential_share(&phases(&PhaseTimes::default())).abs() < f64::MIN_POSITIVE);
    }

    /// Amdahl's and Karp–Flatt's formulas against hand values: 17 % sequential allows
    /// 1 / (0.17 + 0.83 / 16) ≈ 4.507 on 16 cores; a speed-up of 1.8 on 2 threads means a
    /// serial fraction of 2 / 1.8 − 1 ≈ 0.111; a perfect one, none.
    #[test]
    fn amdahl_and_karp_flatt_match_hand_values() {
        assert!((amdahl(0.17, 16) - 4.507_042_253_521_127).abs() < 1e-9);
        assert!((amdahl(0.0, 64) - 64.0).abs() < 1e-12);
        assert!((amdahl(1.0, 64) - 1.0).abs() < 1e-12);
        assert!((karp_flatt(1.8, 2).unwrap() - (2.0 / 1.8 - 1.0)).abs() < 1e-12);
        assert!(karp_flatt(2.0, 2).unwrap().abs() < 1e-12);
        assert_eq!(karp_flatt(1.0, 1), None);
    }
}
