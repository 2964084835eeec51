//! The XML simulation config (quick-xml + serde), resolved into a [`Scenario`].
//!
//! ```xml
//! <simulation name="demo" seed="42" rounds="400">
//!   <map file="../maps/demo.stmap"/>               <!-- relative to this file -->
//!   <robot-type name="scout" base="explorer" view_radius_m="8"/>
//!   <group name="scouts" count="8" type="scout" strategy="cooperative" start="home">
//!     <param name="share_every" value="10"/>
//!   </group>
//!   <group name="diggers" count="2" type="excavator" strategy="excavator" start="30.5,12"/>
//!   <outputs metrics="demo-metrics.csv" robot-stats="demo-robots.csv" rrd="demo.rrd"/>
//! </simulation>
//! ```
//!
//! Robot types: `explorer`, `excavator` and `transporter` are built in; a `<robot-type>`
//! starts from `base` (default: the defaults of [`RobotType::new`]) and overrides any of
//! `radius_m, speed_m_per_round, view_radius_m, comm_radius_m, energy_capacity,
//! energy_per_m, energy_per_sense, energy_per_excavation, energy_per_message, energy_idle,
//! recharge_per_round, excavation_per_round, carry_capacity`.
//!
//! Every error names the file, and where it can, the line and column.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec2;
use quick_xml::events::Event as XmlEvent;
use serde::Deserialize;

use crate::agent::{Params, StrategyRegistry};
use crate::engine::{Group, Scenario, ScenarioBuilder, Start};
use crate::world::{MapData, RobotType};
use crate::{Error, Result};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlSimulation {
    #[serde(rename = "@name")]
    name: Option<String>,
    #[serde(rename = "@seed")]
    seed: Option<String>,
    #[serde(rename = "@rounds")]
    rounds: Option<String>,
    map: XmlMap,
    #[serde(rename = "robot-type", default)]
    robot_types: Vec<XmlRobotType>,
    #[serde(rename = "group", default)]
    groups: Vec<XmlGroup>,
    outputs: Option<XmlOutputs>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlMap {
    #[serde(rename = "@file")]
    file: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlRobotType {
    #[serde(rename = "@name")]
    name: String,
    #[serde(rename = "@base")]
    base: Option<String>,
    #[serde(rename = "@radius_m")]
    radius_m: Option<String>,
    #[serde(rename = "@speed_m_per_round")]
    speed_m_per_round: Option<String>,
    #[serde(rename = "@view_radius_m")]
    view_radius_m: Option<String>,
    #[serde(rename = "@comm_radius_m")]
    comm_radius_m: Option<String>,
    #[serde(rename = "@energy_capacity")]
    energy_capacity: Option<String>,
    #[serde(rename = "@energy_per_m")]
    energy_per_m: Option<String>,
    #[serde(rename = "@energy_per_sense")]
    energy_per_sense: Option<String>,
    #[serde(rename = "@energy_per_excavation")]
    energy_per_excavation: Option<String>,
    #[serde(rename = "@energy_per_message")]
    energy_per_message: Option<String>,
    #[serde(rename = "@energy_idle")]
    energy_idle: Option<String>,
    #[serde(rename = "@recharge_per_round")]
    recharge_per_round: Option<String>,
    #[serde(rename = "@excavation_per_round")]
    excavation_per_round: Option<String>,
    #[serde(rename = "@carry_capacity")]
    carry_capacity: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlGroup {
    #[serde(rename = "@name")]
    name: Option<String>,
    #[serde(rename = "@count")]
    count: String,
    #[serde(rename = "@type")]
    kind: String,
    #[serde(rename = "@strategy")]
    strategy: String,
    #[serde(rename = "@start")]
    start: Option<String>,
    #[serde(rename = "param", default)]
    params: Vec<XmlParam>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlParam {
    #[serde(rename = "@name")]
    name: String,
    #[serde(rename = "@value")]
    value: String,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct XmlOutputs {
    #[serde(rename = "@metrics")]
    metrics: Option<String>,
    #[serde(rename = "@robot-stats")]
    robot_stats: Option<String>,
    #[serde(rename = "@rrd")]
    rrd: Option<String>,
}

/// A group as configured (strategy not yet created).
#[derive(Clone, Debug, PartialEq)]
pub struct GroupConfig {
    /// Name.
    pub name: String,
    /// Robots in it.
    pub count: u32,
    /// Robot type name.
    pub type_name: String,
    /// Strategy name.
    pub strategy: String,
    /// Strategy parameters.
    pub params: Params,
    /// Start.
    pub start: Start,
    /// Where it is declared (line, column).
    pub at: (usize, usize),
}

/// Output files named in the config (relative paths resolved against the config's folder).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outputs {
    /// Per-round metrics CSV.
    pub metrics: Option<PathBuf>,
    /// Per-robot statistics CSV.
    pub robot_stats: Option<PathBuf>,
    /// Rerun recording.
    pub rrd: Option<PathBuf>,
}

/// A parsed config, before the map is loaded.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// The config file.
    pub path: PathBuf,
    /// Run name (default: the file stem).
    pub name: String,
    map_path: PathBuf,
    /// Seed (default 0).
    pub seed: u64,
    /// Rounds (default 1000).
    pub rounds: u64,
    /// Robot types: the three built-ins, then those declared.
    pub types: Vec<RobotType>,
    /// Groups.
    pub groups: Vec<GroupConfig>,
    /// Outputs.
    pub outputs: Outputs,
    map_at: (usize, usize),
    map_from_argument: bool,
}

/// Line and column (1-based) of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(before.len(), |nl| before.len() - nl - 1) + 1;
    (line, col)
}

impl SimConfig {
    fn error(&self, at: (usize, usize), message: impl Into<String>) -> Error {
        Error::Config {
            path: self.path.clone(),
            line: at.0,
            column: at.1,
            message: message.into(),
        }
    }

    /// Read and parse a config file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::parse(&text, path)
    }

    /// Parse config text read from `path` (relative paths inside resolve against its folder).
    #[allow(clippy::too_many_lines)] // one pass over the elements, in document order
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let err = |offset: usize, message: String| {
            let (line, column) = line_col(text, offset);
            Error::Config {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        };
        // Pass 1: well-formedness, and where each element starts.
        let mut reader = quick_xml::Reader::from_str(text);
        let mut starts: Vec<(String, usize)> = Vec::new();
        loop {
            let before = reader.buffer_position() as usize;
            match reader.read_event() {
                Ok(XmlEvent::Eof) => break,
                Ok(XmlEvent::Start(e) | XmlEvent::Empty(e)) => {
                    starts.push((e.name().as_ref().to_owned(), before));
                }
                Ok(_) => {}
                Err(e) => {
                    let at = reader.error_position() as usize;
                    return Err(err(at, format!("malformed XML: {e}")));
                }
            }
        }
        let position_of = |name: &str, nth: usize| {
            starts
                .iter()
                .filter(|(n, _)| n == name)
                .nth(nth)
                .map_or((1, 1), |&(_, at)| {
                    line_col(text, at + text[at..].find('<').unwrap_or(0))
                })
        };
        if starts.first().is_none_or(|(n, _)| n != "simulation") {
            return Err(err(0, "the root element must be <simulation>".into()));
        }
        // Pass 2: structure, by serde.
        let xml: XmlSimulation = quick_xml::de::from_str(text).map_err(|e| Error::Config {
            path: path.to_path_buf(),
            line: 0,
            column: 0,
            message: format!("in <simulation>: {e}"),
        })?;
        let base_dir = path.parent().unwrap_or(Path::new(""));
        let resolve = |p: &str| {
            let p = PathBuf::from(p);
            if p.is_absolute() { p } else { base_dir.join(p) }
        };
        let sim_at = position_of("simulation", 0);
        let number = |v: &Option<String>, what: &str, at: (usize, usize)| -> Result<Option<f64>> {
            v.as_deref()
                .map(|s| {
                    s.trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| Error::Config {
                            path: path.to_path_buf(),
                            line: at.0,
                            column: at.1,
                            message: format!("{what} must be a number, got '{s}'"),
                        })
                })
                .transpose()
        };
        let whole = |v: &Option<String>, what: &str, at: (usize, usize)| -> Result<Option<u64>> {
            v.as_deref()
                .map(|s| {
                    s.trim().parse::<u64>().map_err(|_| Error::Config {
                        path: path.to_path_buf(),
                        line: at.0,
                        column: at.1,
                        message: format!("{what} must be a whole number ≥ 0, got '{s}'"),
                    })
                })
                .transpose()
        };
        let name = xml
            .name
            .clone()
            .or_else(|| path.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "simulation".into());
        let mut config = SimConfig {
            path: path.to_path_buf(),
            name,
            map_path: resolve(&xml.map.file),
            seed: whole(&xml.seed, "seed", sim_at)?.unwrap_or(0),
            rounds: whole(&xml.rounds, "rounds", sim_at)?.unwrap_or(1000),
            types: vec![RobotType::explorer(), RobotType::excavator(), RobotType::transporter()],
            groups: Vec::new(),
            outputs: Outputs::default(),
            map_at: position_of("map", 0),
            map_from_argument: false,
        };
        for (i, t) in xml.robot_types.iter().enumerate() {
            let at = position_of("robot-type", i);
            let mut kind = match t.base.as_deref() {
                None => RobotType::new(&t.name),
                Some(b) => RobotType::builtin(b)
                    .or_else(|| config.types.iter().find(|k| k.name == b).cloned())
                    .ok_or_else(|| {
                        config.error(at, format!("unknown base type '{b}' (known: {})", config.type_names()))
                    })?,
            };
            kind.name.clone_from(&t.name);
            let fields: [(&Option<String>, &str, &mut f64); 11] = [
                (&t.radius_m, "radius_m", &mut kind.radius_m),
                (&t.speed_m_per_round, "speed_m_per_round", &mut kind.speed_m_per_round),
                (&t.view_radius_m, "view_radius_m", &mut kind.view_radius_m),
                (&t.comm_radius_m, "comm_radius_m", &mut kind.comm_radius_m),
                (&t.energy_capacity, "energy_capacity", &mut kind.energy_capacity),
                (&t.energy_per_m, "energy_per_m", &mut kind.energy_per_m),
                (&t.energy_per_sense, "energy_per_sense", &mut kind.energy_per_sense),
                (
                    &t.energy_per_excavation,
                    "energy_per_excavation",
                    &mut kind.energy_per_excavation,
                ),
                (
                    &t.energy_per_message,
                    "energy_per_message",
                    &mut kind.energy_per_message,
                ),
                (&t.energy_idle, "energy_idle", &mut kind.energy_idle),
                (
                    &t.recharge_per_round,
                    "recharge_per_round",
                    &mut kind.recharge_per_round,
                ),
            ];
            for (v, what, slot) in fields {
                if let Some(x) = number(v, what, at)? {
                    *slot = x;
                }
            }
            if let Some(x) = whole(&t.excavation_per_round, "excavation_per_round", at)? {
                kind = kind
                    .with_excavation(u32::try_from(x).map_err(|_| config.error(at, "excavation_per_round too large"))?);
            }
            if let Some(x) = whole(&t.carry_capacity, "carry_capacity", at)? {
                kind.carry_capacity = u32::try_from(x).map_err(|_| config.error(at, "carry_capacity too large"))?;
            }
            kind.validate().map_err(|e| config.error(at, e.to_string()))?;
            match config.types.iter_mut().find(|k| k.name == kind.name) {
                Some(slot) => *slot = kind,
                None => config.types.push(kind),
            }
        }
        for (i, g) in xml.groups.iter().enumerate() {
            let at = position_of("group", i);
            let count = whole(&Some(g.count.clone()), "count", at)?.unwrap_or(0);
            let count = u32::try_from(count).map_err(|_| config.error(at, format!("count {count} is too large")))?;
            let start = match g.start.as_deref().map(str::trim) {
                None | Some("home") => Start::Home,
                Some(s) => {
                    let parts: Vec<_> = s.split(',').map(|p| p.trim().parse::<f64>()).collect();
                    match parts.as_slice() {
                        [Ok(x), Ok(y)] if x.is_finite() && y.is_finite() => Start::At(DVec2::new(*x, *y)),
                        _ => {
                            return Err(config.error(at, format!("start must be 'home' or 'X,Y' in metres, got '{s}'")));
                        }
                    }
                }
            };
            config.groups.push(GroupConfig {
                name: g.name.clone().unwrap_or_else(|| format!("group{i}")),
                count,
                type_name: g.kind.clone(),
                strategy: g.strategy.clone(),
                params: g.params.iter().map(|p| (p.name.clone(), p.value.clone())).collect(),
                start,
                at,
            });
        }
        if let Some(o) = &xml.outputs {
            config.outputs = Outputs {
                metrics: o.metrics.as_deref().map(resolve),
                robot_stats: o.robot_stats.as_deref().map(resolve),
                rrd: o.rrd.as_deref().map(resolve),
            };
        }
        if config.groups.is_empty() {
            return Err(config.error(sim_at, "no <group> of robots"));
        }
        Ok(config)
    }

    fn type_names(&self) -> String {
        self.types
            .iter()
            .map(|t| t.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The map file (from the `<map>` element, resolved against the config's folder, or
    /// from [`with_map_argument`](Self::with_map_argument)).
    pub fn map_path(&self) -> &Path {
        &self.map_path
    }

    /// Take the map from a command-line argument instead of the `<map>` element; errors
    /// about the map then name the argument.
    pub fn with_map_argument(mut self, path: PathBuf) -> Self {
        self.map_path = path;
        self.map_from_argument = true;
        self
    }

    /// Where errors about the map point: the `--map` argument or the `<map>` element.
    fn map_error(&self, message: String) -> Error {
        if self.map_from_argument {
            Error::Argument {
                argument: format!("--map {}", self.map_path.display()),
                message,
            }
        } else {
            self.error(self.map_at, message)
        }
    }

    /// Load the map and resolve everything into a validated [`Scenario`], in one place:
    /// robot types, strategies (each robot's built once), starts and room for every robot.
    /// Each error names its source: the XML element, or the `--map` argument.
    pub fn scenario(&self, registry: &StrategyRegistry) -> Result<Scenario> {
        if !self.map_path.is_file() {
            return Err(self.map_error(format!("map file {} does not exist", self.map_path.display())));
        }
        let map = MapData::load(&self.map_path).map_err(|e| self.map_error(e.to_string()))?;
        let mut builder = ScenarioBuilder::new(Arc::new(map))
            .with_name(self.name.clone())
            .with_seed(self.seed)
            .with_rounds(self.rounds)
            .with_types(self.types.clone());
        for g in &self.groups {
            let type_index = self.types.iter().position(|t| t.name == g.type_name).ok_or_else(|| {
                self.error(
                    g.at,
                    format!(
                        "group '{}': unknown robot type '{}' (known: {})",
                        g.name,
                        g.type_name,
                        self.type_names()
                    ),
                )
            })?;
            builder = builder.with_group(
                Group::new(g.strategy.clone(), type_index, g.count)
                    .with_name(g.name.clone())
                    .with_params(g.params.clone())
                    .with_start(g.start),
            );
        }
        builder.build(registry).map_err(|e| match e {
            Error::Group { index, name, message } => {
                let at = self.groups.get(index).map_or((0, 0), |g| g.at);
                self.error(at, format!("group '{name}': {message}"))
            }
            other => other,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_are_one_based() {
        let t = "ab\ncde\nf";
        assert_eq!(line_col(t, 0), (1, 1));
        assert_eq!(line_col(t, 4), (2, 2));
        assert_eq!(line_col(t, 7), (3, 1));
    }
}
