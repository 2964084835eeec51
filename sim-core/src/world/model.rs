//! The simulated world's objects: robot types and their abilities, robots, treasures and
//! the elementary actions a strategy may ask for (paper §2, §3.1).

use glam::DVec2;

use crate::spatial::RobotId;
use crate::spatial::TreasureId;

/// A robot type: its body and abilities. Built-in presets: [`RobotType::explorer`],
/// [`RobotType::excavator`], [`RobotType::transporter`]; others are built with the `with_`
/// setters or declared in the XML config.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotType {
    /// Name used in configs and outputs.
    pub name: String,
    /// Body radius (default 0.125 m: the paper's 25 cm robots).
    pub radius_m: f64,
    /// Longest move per round (default 1 m).
    pub speed_m_per_round: f64,
    /// Radius of the 360° view (default 5 m).
    pub view_radius_m: f64,
    /// Radius within which messages are delivered (default 20 m).
    pub comm_radius_m: f64,
    /// Energy when full (default 5,000).
    pub energy_capacity: f64,
    /// Energy per metre moved (default 1).
    pub energy_per_m: f64,
    /// Energy per round of sensing (default 0.1; charged when the strategy perceives).
    pub energy_per_sense: f64,
    /// Energy per round of digging (default 2).
    pub energy_per_excavation: f64,
    /// Energy per message sent (default 0.2).
    pub energy_per_message: f64,
    /// Energy every round, whatever the robot does (default 0.05).
    pub energy_idle: f64,
    /// Energy regained per round inside the home base (default 200).
    pub recharge_per_round: f64,
    /// Whether it can dig (default false).
    pub can_excavate: bool,
    /// Units dug per round of excavation (default 0).
    pub excavation_per_round: u32,
    /// Units it can carry (default 0).
    pub carry_capacity: u32,
}

/// How close (centre to treasure, beyond the body radius) a robot must be to dig or load.
pub const REACH_M: f64 = 0.5;

impl RobotType {
    /// A type with the defaults listed on the fields, no excavation and no cargo.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            radius_m: 0.125,
            speed_m_per_round: 1.0,
            view_radius_m: 5.0,
            comm_radius_m: 20.0,
            energy_capacity: 5_000.0,
            energy_per_m: 1.0,
            energy_per_sense: 0.1,
            energy_per_excavation: 2.0,
            energy_per_message: 0.2,
            energy_idle: 0.05,
            recharge_per_round: 200.0,
            can_excavate: false,
            excavation_per_round: 0,
            carry_capacity: 0,
        }
    }

    /// Explorer: fast, wide view, no tools.
    pub fn explorer() -> Self {
        Self::new("explorer")
            .with_speed_m_per_round(1.0)
            .with_view_radius_m(6.0)
    }

    /// Excavator: slow, digs 1 unit a round.
    pub fn excavator() -> Self {
        Self::new("excavator")
            .with_speed_m_per_round(0.5)
            .with_view_radius_m(3.0)
            .with_excavation(1)
    }

    /// Transporter: carries 10 units.
    pub fn transporter() -> Self {
        Self::new("transporter")
            .with_speed_m_per_round(0.8)
            .with_view_radius_m(3.0)
            .with_carry_capacity(10)
    }

    /// The built-in type of that name.
    pub fn builtin(name: &str) -> Option<Self> {
        match name {
            "explorer" => Some(Self::explorer()),
            "excavator" => Some(Self::excavator()),
            "transporter" => Some(Self::transporter()),
            _ => None,
        }
    }

    /// Set the body radius.
    pub fn with_radius_m(mut self, v: f64) -> Self {
        self.radius_m = v;
        self
    }
    /// Set the speed.
    pub fn with_speed_m_per_round(mut self, v: f64) -> Self {
        self.speed_m_per_round = v;
        self
    }
    /// Set the view radius.
    pub fn with_view_radius_m(mut self, v: f64) -> Self {
        self.view_radius_m = v;
        self
    }
    /// Set the communication radius.
    pub fn with_comm_radius_m(mut self, v: f64) -> Self {
        self.comm_radius_m = v;
        self
    }
    /// Set the energy capacity.
    pub fn with_energy_capacity(mut self, v: f64) -> Self {
        self.energy_capacity = v;
        self
    }
    /// Enable digging at `units_per_round`.
    pub fn with_excavation(mut self, units_per_round: u32) -> Self {
        self.can_excavate = units_per_round > 0;
        self.excavation_per_round = units_per_round;
        self
    }
    /// Set the cargo capacity.
    pub fn with_carry_capacity(mut self, units: u32) -> Self {
        self.carry_capacity = units;
        self
    }

    /// Check that the numbers make sense.
    pub fn validate(&self) -> crate::Result<()> {
        let checks = [
            ("radius_m", self.radius_m, false),
            ("speed_m_per_round", self.speed_m_per_round, true),
            ("view_radius_m", self.view_radius_m, true),
            ("comm_radius_m", self.comm_radius_m, true),
            ("energy_capacity", self.energy_capacity, false),
            ("energy_per_m", self.energy_per_m, true),
            ("energy_per_sense", self.energy_per_sense, true),
            ("energy_per_excavation", self.energy_per_excavation, true),
            ("energy_per_message", self.energy_per_message, true),
            ("energy_idle", self.energy_idle, true),
            ("recharge_per_round", self.recharge_per_round, true),
        ];
        for (name, v, zero_ok) in checks {
            if !v.is_finite() || v < 0.0 || (v == 0.0 && !zero_ok) {
                let need = if zero_ok {
                    "a finite number ≥ 0"
                } else {
                    "a finite number > 0"
                };
                return Err(crate::Error::InvalidParameter(format!(
                    "robot type '{}': {name} must be {need}, got {v}",
                    self.name
                )));
            }
        }
        Ok(())
    }
}

/// One elementary action for one round. The physical unit refuses or trims what is illegal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Do nothing (still costs idle energy).
    Idle,
    /// Move in a straight line towards `to`, as far as speed, energy, obstacles and other
    /// robots allow.
    MoveTo {
        /// Target point.
        to: DVec2,
    },
    /// Dig at a treasure within reach.
    Excavate {
        /// The treasure.
        treasure: TreasureId,
    },
    /// Load dug units of a treasure within reach (as many as fit and lie there).
    Load {
        /// The treasure.
        treasure: TreasureId,
    },
    /// Drop the cargo in the home base (delivered).
    Unload,
}

impl Action {
    /// A short name for logs and outputs.
    pub fn name(&self) -> &'static str {
        match self {
            Action::Idle => "idle",
            Action::MoveTo { .. } => "move",
            Action::Excavate { .. } => "excavate",
            Action::Load { .. } => "load",
            Action::Unload => "unload",
        }
    }
}

/// What the physical unit made of a requested action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Carried out as asked.
    Done,
    /// Carried out in part (a move shortened, a load limited).
    Trimmed,
    /// Not carried out (the reason is in the event log when it matters).
    Refused,
}

/// Per-robot counters for the robot-stats output.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobotStats {
    /// Metres travelled.
    pub distance_m: f64,
    /// Free area this robot was first to explore (m²).
    pub explored_m2: f64,
    /// Treasures this robot was first to see.
    pub treasures_found: u32,
    /// Units dug.
    pub units_dug: u64,
    /// Units delivered home.
    pub units_delivered: u64,
    /// Energy spent.
    pub energy_used: f64,
    /// Messages sent.
    pub messages_sent: u64,
    /// Bytes of message payload sent.
    pub message_bytes: u64,
}

/// A robot's physical state, owned by the kernel.
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    /// Its id.
    pub id: RobotId,
    /// Index into the simulation's robot types.
    pub type_index: usize,
    /// Index of the config group it came from.
    pub group: usize,
    /// Centre position.
    pub position: DVec2,
    /// Energy left.
    pub energy: f64,
    /// Units carried, by treasure of origin.
    pub cargo: Vec<(TreasureId, u32)>,
    /// False once its energy ran out (for the rest of the run).
    pub alive: bool,
    /// The last action asked for, and what came of it.
    pub last_action: (Action, Outcome),
    /// The strategy's current goal, if it shares one (for viewers).
    pub goal: Option<DVec2>,
    /// The strategy's planned path, if it shares one (for viewers).
    pub path: Vec<DVec2>,
    /// Counters.
    pub stats: RobotStats,
}

impl Robot {
    /// Units carried in all.
    pub fn load(&self) -> u32 {
        self.cargo.iter().map(|c| c.1).sum()
    }
}

/// A treasure's state: every unit is buried, lying dug at the site, carried or delivered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreasureState {
    /// Its id.
    pub id: TreasureId,
    /// Position.
    pub position: DVec2,
    /// Units at the start.
    pub initial: u32,
    /// Units still in the ground.
    pub buried: u32,
    /// Units dug and lying at the site.
    pub loose: u32,
    /// Units delivered home.
    pub delivered: u32,
    /// Round it was first seen, if ever.
    pub found_round: Option<u64>,
}
