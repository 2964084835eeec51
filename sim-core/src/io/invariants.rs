//! An observer that checks the physical rules every round; tests run every simulation
//! through it. Each check recomputes the rule from the state, independently of how the
//! physical unit enforced it.

use glam::DVec2;

use crate::engine::Simulation;
use crate::io::observer::{Observer, ObserverError};
use crate::world::{Robot, RoundReport};

/// Checks, after every round: no robot inside an obstacle, outside the map or overlapping
/// another; energy within [0, capacity] and disabled robots stay disabled and still; no move
/// longer than the type's speed; cargo within capacity and only on carriers; digging only by
/// excavators; no message beyond the sender's range at send time; every treasure's units
/// conserved (buried + loose + carried + delivered = initial).
#[derive(Debug, Default)]
pub struct InvariantChecker {
    previous: Vec<(DVec2, bool, u64)>,
    /// Rounds checked.
    pub rounds_checked: u64,
}

impl InvariantChecker {
    /// A checker.
    pub fn new() -> Self {
        Self::default()
    }

    /// Check this round's state against the rules, then remember it for the next round.
    fn check(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), String> {
        let round = report.round;
        for r in sim.robots() {
            self.check_robot(sim, r, round)?;
        }
        self.check_message_ranges(sim, round)?;
        check_overlaps(sim, round)?;
        check_treasures(sim, round)?;
        self.previous = sim
            .robots()
            .iter()
            .map(|r| (r.position, r.alive, r.stats.units_dug))
            .collect();
        self.rounds_checked += 1;
        Ok(())
    }

    /// Check one robot: its place, energy, cargo and digging, and its move since the last
    /// round (within its speed, none once disabled).
    fn check_robot(&self, sim: &Simulation, r: &Robot, round: u64) -> Result<(), String> {
        let kind = &sim.types()[r.type_index];
        let who = format!("round {round}: robot {}", r.id);
        if !sim.obstacles().is_disc_free(r.position, kind.radius_m) {
            return Err(format!(
                "{who} at {} overlaps an obstacle or leaves the map",
                r.position
            ));
        }
        if !(r.energy >= 0.0 && r.energy <= kind.energy_capacity + 1e-9) {
            return Err(format!("{who} has energy {}", r.energy));
        }
        if r.load() > kind.carry_capacity {
            return Err(format!("{who} carries {} > capacity {}", r.load(), kind.carry_capacity));
        }
        if !kind.can_excavate() && r.stats.units_dug > 0 {
            return Err(format!("{who} ({}) dug without the ability", kind.name));
        }
        if let Some(&(before, was_alive, dug)) = self.previous.get(r.id.index()) {
            let moved = before.distance(r.position);
            if moved > kind.speed_m_per_round + 1e-9 {
                return Err(format!("{who} moved {moved} m > speed {}", kind.speed_m_per_round));
            }
            if !was_alive && (r.alive || moved > 0.0 || r.stats.units_dug != dug) {
                return Err(format!("{who} acted after being disabled"));
            }
        }
        Ok(())
    }

    /// Check that messages reach only robots in the sender's range when it sent them (the
    /// start of the round).
    fn check_message_ranges(&self, sim: &Simulation, round: u64) -> Result<(), String> {
        if self.previous.is_empty() {
            return Ok(());
        }
        let robots = sim.robots();
        for link in sim.links() {
            let (from, to) = (self.previous[link.from.index()].0, self.previous[link.to.index()].0);
            let range = sim.types()[robots[link.from.index()].type_index].comm_radius_m;
            if to.distance(from) > range + 1e-9 {
                return Err(format!(
                    "round {round}: robot {} reached robot {} beyond its range",
                    link.from, link.to
                ));
            }
        }
        Ok(())
    }
}

/// Check that no two robots overlap, brute force over nearby pairs (sorted by x: sweep).
fn check_overlaps(sim: &Simulation, round: u64) -> Result<(), String> {
    let robots = sim.robots();
    let mut order: Vec<usize> = (0..robots.len()).collect();
    order.sort_by(|&a, &b| robots[a].position.x.total_cmp(&robots[b].position.x));
    let max_r = sim.types().iter().map(|t| t.radius_m).fold(0.0, f64::max);
    for (k, &a) in order.iter().enumerate() {
        for &b in &order[k + 1..] {
            let (pa, pb) = (robots[a].position, robots[b].position);
            if pb.x - pa.x >= 2.0 * max_r {
                break;
            }
            let rr = sim.types()[robots[a].type_index].radius_m + sim.types()[robots[b].type_index].radius_m;
            if pa.distance_squared(pb) < rr * rr - 1e-12 {
                return Err(format!("round {round}: robots {a} and {b} overlap at {pa} and {pb}"));
            }
        }
    }
    Ok(())
}

/// Check that every treasure's units are conserved: buried + loose + carried + delivered
/// = initial.
fn check_treasures(sim: &Simulation, round: u64) -> Result<(), String> {
    let robots = sim.robots();
    for t in sim.treasures() {
        let carried: u64 = robots
            .iter()
            .flat_map(|r| &r.cargo)
            .filter(|c| c.0 == t.id)
            .map(|c| u64::from(c.1))
            .sum();
        let total = u64::from(t.buried) + u64::from(t.loose) + carried + u64::from(t.delivered);
        if total != u64::from(t.initial) {
            return Err(format!(
                "round {round}: treasure {} not conserved: {} buried + {} loose + {carried} carried + {} delivered ≠ {}",
                t.id, t.buried, t.loose, t.delivered, t.initial
            ));
        }
    }
    Ok(())
}

impl Observer for InvariantChecker {
    fn on_start(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        self.previous = sim
            .robots()
            .iter()
            .map(|r| (r.position, r.alive, r.stats.units_dug))
            .collect();
        Ok(())
    }

    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        self.check(sim, report).map_err(Into::into)
    }
}
