//! The simulated world's objects: robot types and their abilities, robots, treasures and
//! the elementary actions a strategy may ask for (paper §2, §3.1).

use glam::DVec2;

use crate::spatial::RobotId;
use crate::spatial::TreasureId;

/// Declares [`RobotType`] once: the struct's fields, their defaults, the range each must lie
/// in, and the XML attribute names (the field names) all come from this one table, so the
/// config parser, [`RobotType::new`], [`RobotType::validate`] and
/// [`ROBOT_TYPE_ATTRIBUTES`] cannot drift apart.
macro_rules! robot_type_table {
    ($($(#[doc = $doc:literal])* $field:ident: $ty:ident = $default:expr, $range:ident;)*) => {
        /// A robot type: its body and abilities. Built-in presets: [`RobotType::explorer`],
        /// [`RobotType::excavator`], [`RobotType::transporter`]; others are built with the
        /// `with_` setters or declared in the XML config (one attribute per field).
        #[derive(Clone, Debug, PartialEq)]
        pub struct RobotType {
            /// Name used in configs and outputs.
            pub name: String,
            $($(#[doc = $doc])* pub $field: $ty,)*
        }

        /// The XML attributes of `<robot-type>` besides `name` and `base`: one per field of
        /// [`RobotType`], in declaration order.
        pub const ROBOT_TYPE_ATTRIBUTES: &[&str] = &[$(stringify!($field)),*];

        impl RobotType {
            /// A type with the defaults listed on the fields, no excavation and no cargo.
            pub fn new(name: impl Into<String>) -> Self {
                Self { name: name.into(), $($field: $default,)* }
            }

            /// Check that every field lies in its range.
            pub fn validate(&self) -> crate::Result<()> {
                $(FieldRange::$range.check(&self.name, stringify!($field), self.$field)?;)*
                Ok(())
            }

            /// Set the field named `attribute` from its text (as written in the XML config).
            /// Errors say what was expected; an unknown name lists the known ones.
            pub fn set_attribute(&mut self, attribute: &str, text: &str) -> crate::Result<()> {
                match attribute {
                    $(stringify!($field) => self.$field = FieldValue::parse_field(attribute, text)?,)*
                    _ => {
                        return Err(crate::Error::InvalidParameter(format!(
                            "unknown robot-type attribute '{attribute}' (known: name, base, {})",
                            ROBOT_TYPE_ATTRIBUTES.join(", ")
                        )));
                    }
                }
                Ok(())
            }
        }
    };
}

robot_type_table! {
    /// Body radius (default 0.125 m: the paper's 25 cm robots).
    radius_m: f64 = 0.125, Positive;
    /// Longest move per round (default 1 m).
    speed_m_per_round: f64 = 1.0, NonNegative;
    /// Radius of the 360° view (default 5 m).
    view_radius_m: f64 = 5.0, NonNegative;
    /// Radius within which messages are delivered (default 20 m).
    comm_radius_m: f64 = 20.0, NonNegative;
    /// Energy when full (default 5,000).
    energy_capacity: f64 = 5_000.0, Positive;
    /// Energy per metre moved (default 1).
    energy_per_m: f64 = 1.0, NonNegative;
    /// Energy per round of sensing (default 0.1; charged when the strategy perceives).
    energy_per_sense: f64 = 0.1, NonNegative;
    /// Energy per round of digging (default 2).
    energy_per_excavation: f64 = 2.0, NonNegative;
    /// Energy per message sent (default 0.2).
    energy_per_message: f64 = 0.2, NonNegative;
    /// Energy every round, whatever the robot does (default 0.05).
    energy_idle: f64 = 0.05, NonNegative;
    /// Energy regained per round inside the home base (default 200).
    recharge_per_round: f64 = 200.0, NonNegative;
    /// Units dug per round of excavation (default 0: cannot dig).
    excavation_per_round: u32 = 0, NonNegative;
    /// Units it can carry (default 0).
    carry_capacity: u32 = 0, NonNegative;
    /// Bytes of messages it can receive per round (default: no limit). A radio has a
    /// bandwidth: a receiver takes messages addressed to it first, then broadcasts, until
    /// the next one would not fit; the rest are lost. A finite budget keeps crowds from
    /// making delivery quadratic in the number of robots. Broadcasts are taken in the order
    /// of the engine's index of senders: by grid cell, south to north and west to east,
    /// the lowest robot index first within a cell (the index's own order when the range
    /// spans more cells than there are senders). In a crowd that fills the budget a
    /// receiver therefore hears its south-western and low-id neighbours most (BENCHMARKS.md,
    /// "Radio budgets favour the south-west").
    radio_bytes_per_round: u64 = u64::MAX, NonNegative;
}

/// The range a numeric field of [`RobotType`] must lie in (always finite too).
#[derive(Clone, Copy)]
enum FieldRange {
    /// Greater than zero.
    Positive,
    /// Zero or more.
    NonNegative,
}

impl FieldRange {
    fn check(self, type_name: &str, field: &str, value: impl FieldValue) -> crate::Result<()> {
        let v = value.as_f64();
        let ok = v.is_finite()
            && match self {
                Self::Positive => v > 0.0,
                Self::NonNegative => v >= 0.0,
            };
        if ok {
            return Ok(());
        }
        let need = match self {
            Self::Positive => "a finite number > 0",
            Self::NonNegative => "a finite number ≥ 0",
        };
        Err(crate::Error::InvalidParameter(format!(
            "robot type '{type_name}': {field} must be {need}, got {v}"
        )))
    }
}

/// The value types a [`RobotType`] field may have.
trait FieldValue: Sized + Copy {
    fn as_f64(self) -> f64;
    fn parse_field(field: &str, text: &str) -> crate::Result<Self>;
}

impl FieldValue for f64 {
    fn as_f64(self) -> f64 {
        self
    }
    fn parse_field(field: &str, text: &str) -> crate::Result<Self> {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| crate::Error::InvalidParameter(format!("{field} must be a number, got '{text}'")))
    }
}

/// Whole-number fields: parsed as the type itself, so the range error names its bounds.
macro_rules! whole_field_value {
    ($($t:ty),*) => {$(
        impl FieldValue for $t {
            // Only compared with 0 in `validate`: precision above 2^53 does not matter.
            #[allow(clippy::cast_lossless)]
            fn as_f64(self) -> f64 {
                self as f64
            }
            fn parse_field(field: &str, text: &str) -> crate::Result<Self> {
                text.trim().parse::<$t>().map_err(|_| {
                    crate::Error::InvalidParameter(format!(
                        "{field} must be a whole number from 0 to {}, got '{text}'",
                        <$t>::MAX
                    ))
                })
            }
        }
    )*};
}

whole_field_value!(u32, u64);

/// How close (centre to treasure, beyond the body radius) a robot must be to dig or load.
pub const REACH_M: f64 = 0.5;

impl RobotType {
    /// Whether it can dig (`excavation_per_round > 0`).
    pub fn can_excavate(&self) -> bool {
        self.excavation_per_round > 0
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
        self.excavation_per_round = units_per_round;
        self
    }
    /// Set the bytes of messages it can receive per round.
    pub fn with_radio_bytes_per_round(mut self, bytes: u64) -> Self {
        self.radio_bytes_per_round = bytes;
        self
    }
    /// Set the cargo capacity.
    pub fn with_carry_capacity(mut self, units: u32) -> Self {
        self.carry_capacity = units;
        self
    }
}

/// One elementary action for one round. The physical unit refuses or trims what is illegal.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Outcome {
    /// Carried out as asked.
    Done,
    /// Carried out in part (a move shortened, a load limited).
    Trimmed,
    /// Not carried out (the reason is in the event log when it matters).
    Refused,
}

/// Per-robot counters for the robot-stats output.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// Metres travelled in rounds whose view showed nothing new to the team: walking
    /// through explored ground. A move is shorter than the view's radius, so it crosses
    /// only cells that view showed.
    pub overlap_m: f64,
}

/// A robot's physical state, owned by the kernel.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// A robot as it starts: alive, full of energy, carrying nothing, idle so far.
    pub fn new(id: RobotId, type_index: usize, group: usize, position: DVec2, kind: &RobotType) -> Self {
        Self {
            id,
            type_index,
            group,
            position,
            energy: kind.energy_capacity,
            cargo: Vec::new(),
            alive: true,
            last_action: (Action::Idle, Outcome::Done),
            goal: None,
            path: Vec::new(),
            stats: RobotStats::default(),
        }
    }

    /// Units carried in all.
    pub fn load(&self) -> u32 {
        self.cargo.iter().map(|c| c.1).sum()
    }
}

/// A treasure's state: every unit is buried, lying dug at the site, carried or delivered.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_attribute_in_the_table_sets_its_field_and_is_range_checked() {
        for &attribute in ROBOT_TYPE_ATTRIBUTES {
            let mut t = RobotType::new("t");
            t.set_attribute(attribute, " 7 ").unwrap();
            assert_ne!(t, RobotType::new("t"), "{attribute} changed nothing");
            t.validate().unwrap();
            assert!(t.set_attribute(attribute, "seven").is_err(), "{attribute}");
            if t.set_attribute(attribute, "-1").is_ok() {
                assert!(t.validate().is_err(), "{attribute} = -1 passed validate");
            }
        }
        let mut t = RobotType::new("t");
        let e = t.set_attribute("colour", "red").unwrap_err().to_string();
        assert!(
            e.contains("unknown robot-type attribute 'colour'") && e.contains("carry_capacity"),
            "{e}"
        );
        t.set_attribute("excavation_per_round", "3").unwrap();
        assert!(t.can_excavate());
        t.set_attribute("radius_m", "0").unwrap();
        assert!(
            t.validate()
                .unwrap_err()
                .to_string()
                .contains("radius_m must be a finite number > 0, got 0")
        );
    }
}
