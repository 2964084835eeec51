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
//! starts from `base` (default: the defaults of [`RobotType::new`]) and overrides any field
//! of [`RobotType`] by an attribute of the same name ([`ROBOT_TYPE_ATTRIBUTES`](crate::world::ROBOT_TYPE_ATTRIBUTES)).
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
    /// Read from pass 1's events instead (attributes named by the [`RobotType`] table);
    /// serde only checks where they stand.
    #[serde(rename = "robot-type", default)]
    _robot_types: Vec<serde::de::IgnoredAny>,
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
    /// The text parsed (a checkpoint keeps it, so that a resumed run is set up from the
    /// config it started with, whatever became of the file).
    text: String,
}

/// Line and column (1-based) of a byte offset.
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(before.len(), |nl| before.len() - nl - 1) + 1;
    (line, col)
}

/// What pass 1 (quick-xml's event reader) finds: well-formedness, where each element
/// starts, and the attributes of each `<robot-type>` (read here so that their names come
/// from the [`RobotType`] table, not from a second list).
struct Scan {
    elements: Vec<ScannedElement>,
    robot_types: Vec<Vec<(String, String)>>,
}

struct ScannedElement {
    name: String,
    offset: usize,
    /// Its attributes' names.
    attributes: Vec<String>,
}

/// A malformed attribute of element `name`, whose tag starts at byte `lt` of `text`: the
/// byte offset of the fault and what is wrong. A tag whose `>` is missing swallows the next
/// tag as attributes: that is said.
pub(crate) fn attribute_error(
    text: &str,
    name: &str,
    lt: usize,
    err: &quick_xml::events::attributes::AttrError,
) -> (usize, String) {
    use quick_xml::events::attributes::AttrError;
    // Positions count from the byte after the tag's `<`.
    let (AttrError::ExpectedEq(pos)
    | AttrError::ExpectedValue(pos)
    | AttrError::UnquotedValue(pos)
    | AttrError::ExpectedQuote(pos, _)
    | AttrError::Duplicated(pos, _)) = *err;
    let mut at = (lt + 1 + pos).min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let full = err.to_string();
    let what = if let AttrError::Duplicated(..) = err {
        let key: String = text[at..]
            .chars()
            .take_while(|c| !c.is_whitespace() && *c != '=')
            .collect();
        format!("attribute `{key}` given twice")
    } else {
        full.split_once(": ").map_or(full.clone(), |(_, w)| w.to_owned())
    };
    let hint = if text[lt + 1..at].contains('<') {
        let (line, column) = line_col(text, lt);
        format!(" (the <{name}> at {line}:{column} lacks its `>` or `/>`)")
    } else {
        String::new()
    };
    (at, format!("malformed XML in <{name}>: {what}{hint}"))
}

impl Scan {
    /// Errors are (byte offset, message).
    fn new(text: &str) -> std::result::Result<Self, (usize, String)> {
        let mut reader = quick_xml::Reader::from_str(text);
        let mut scan = Scan {
            elements: Vec::new(),
            robot_types: Vec::new(),
        };
        loop {
            let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
            let malformed = |e: &dyn std::fmt::Display, at: u64| {
                (usize::try_from(at).unwrap_or(usize::MAX), format!("malformed XML: {e}"))
            };
            match reader.read_event() {
                Ok(XmlEvent::Eof) => break,
                Ok(XmlEvent::Start(e) | XmlEvent::Empty(e)) => {
                    let name = e.name().as_ref().to_owned();
                    // Every element's attributes are checked here, where the fault's place
                    // is known; serde's pass gives a position without a line.
                    let lt = before + text[before..].find('<').unwrap_or(0);
                    let mut attributes = Vec::new();
                    for a in e.attributes() {
                        let a = a.map_err(|err| attribute_error(text, &name, lt, &err))?;
                        let value = a
                            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                            .map_err(|err| malformed(&err, lt as u64))?;
                        attributes.push((a.key.as_ref().to_owned(), value.into_owned()));
                    }
                    let keys = attributes.iter().map(|(k, _)| k.clone()).collect();
                    if name == "robot-type" {
                        scan.robot_types.push(attributes);
                    }
                    scan.elements.push(ScannedElement {
                        name,
                        offset: before,
                        attributes: keys,
                    });
                }
                Ok(_) => {}
                Err(e) => return Err(malformed(&e, reader.error_position())),
            }
        }
        Ok(scan)
    }

    /// Serde's error `message` about the config's structure, with its place: an unknown
    /// attribute at the first element that has it, an unknown element where it is, anything
    /// else at the root. Serde names attributes `@name` and gives no line.
    fn structure_error(&self, text: &str, message: &str) -> ((usize, usize), String) {
        // The names serde quotes: the field, then those expected.
        let quoted: Vec<&str> = message.split('`').skip(1).step_by(2).collect();
        let listed = |attributes: bool| {
            quoted
                .iter()
                .skip(1)
                .filter(|n| n.starts_with('@') == attributes)
                .map(|n| {
                    if attributes {
                        n.trim_start_matches('@').to_owned()
                    } else {
                        format!("<{n}>")
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let at = |e: &ScannedElement| line_col(text, e.offset + text[e.offset..].find('<').unwrap_or(0));
        let root = self.position(text, "simulation", 0);
        match (message.split('`').next(), quoted.first()) {
            (Some("unknown field "), Some(field)) => match field.strip_prefix('@') {
                Some(attribute) => {
                    if let Some(e) = self
                        .elements
                        .iter()
                        .find(|e| e.attributes.iter().any(|a| a == attribute))
                    {
                        let known = listed(true);
                        return (
                            at(e),
                            format!("<{}> has no attribute `{attribute}` (its attributes: {known})", e.name),
                        );
                    }
                }
                None => {
                    if let Some(e) = self.elements.iter().find(|e| e.name == *field) {
                        return (
                            at(e),
                            format!("unknown element <{field}> (expected here: {})", listed(false)),
                        );
                    }
                }
            },
            (Some("missing field "), Some(field)) => {
                return match field.strip_prefix('@') {
                    Some(attribute) => (root, format!("an element lacks its required attribute `{attribute}`")),
                    None => (root, format!("<simulation> lacks a <{field}> element")),
                };
            }
            _ => {}
        }
        (root, format!("in <simulation>: {message}"))
    }

    /// Line and column of the `nth` element called `name` ((1, 1) if there is none).
    fn position(&self, text: &str, name: &str, nth: usize) -> (usize, usize) {
        self.elements
            .iter()
            .filter(|e| e.name == name)
            .nth(nth)
            .map_or((1, 1), |e| {
                line_col(text, e.offset + text[e.offset..].find('<').unwrap_or(0))
            })
    }
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
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let at_offset = |offset: usize, message: String| {
            let (line, column) = line_col(text, offset);
            Error::Config {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        };
        let scan = Scan::new(text).map_err(|(offset, message)| at_offset(offset, message))?;
        if scan.elements.first().is_none_or(|e| e.name != "simulation") {
            return Err(at_offset(0, "the root element must be <simulation>".into()));
        }
        // Pass 2: structure, by serde.
        let xml: XmlSimulation = quick_xml::de::from_str(text).map_err(|e| {
            let ((line, column), message) = scan.structure_error(text, &e.to_string());
            Error::Config {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        })?;
        let base_dir = path.parent().unwrap_or(Path::new(""));
        let resolve = |p: &str| {
            let p = PathBuf::from(p);
            if p.is_absolute() { p } else { base_dir.join(p) }
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
            seed: 0,
            rounds: 1000,
            types: vec![RobotType::explorer(), RobotType::excavator(), RobotType::transporter()],
            groups: Vec::new(),
            outputs: Outputs::default(),
            map_at: scan.position(text, "map", 0),
            map_from_argument: false,
            text: text.to_owned(),
        };
        let sim_at = scan.position(text, "simulation", 0);
        config.seed = config.whole(xml.seed.as_deref(), "seed", sim_at)?.unwrap_or(0);
        config.rounds = config.whole(xml.rounds.as_deref(), "rounds", sim_at)?.unwrap_or(1000);
        config.read_robot_types(&scan, text)?;
        config.read_groups(&xml.groups, &scan, text)?;
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

    /// The `<robot-type>` elements, each replacing the built-in type of its name or added
    /// after them.
    fn read_robot_types(&mut self, scan: &Scan, text: &str) -> Result<()> {
        for (i, attributes) in scan.robot_types.iter().enumerate() {
            let kind = self.robot_type(attributes, scan.position(text, "robot-type", i))?;
            match self.types.iter_mut().find(|k| k.name == kind.name) {
                Some(slot) => *slot = kind,
                None => self.types.push(kind),
            }
        }
        Ok(())
    }

    /// The `<group>` elements, in order; a second group of a name is an error.
    fn read_groups(&mut self, groups: &[XmlGroup], scan: &Scan, text: &str) -> Result<()> {
        for (i, g) in groups.iter().enumerate() {
            let group = self.group(i, g, scan.position(text, "group", i))?;
            // Sweeps, metrics and events name groups: two of one name could not be told apart.
            if let Some(first) = self.groups.iter().find(|f| f.name == group.name) {
                let (line, column) = first.at;
                return Err(self.error(
                    group.at,
                    format!(
                        "a second group named '{}' (the first is at {line}:{column})",
                        group.name
                    ),
                ));
            }
            self.groups.push(group);
        }
        Ok(())
    }

    /// A whole number attribute, if present.
    fn whole(&self, text: Option<&str>, what: &str, at: (usize, usize)) -> Result<Option<u64>> {
        text.map(|s| {
            s.trim()
                .parse::<u64>()
                .map_err(|_| self.error(at, format!("{what} must be a whole number ≥ 0, got '{s}'")))
        })
        .transpose()
    }

    /// One `<robot-type>`: its base (a built-in or a type declared above), then each
    /// attribute by name, then the ranges.
    fn robot_type(&self, attributes: &[(String, String)], at: (usize, usize)) -> Result<RobotType> {
        let get = |key: &str| attributes.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
        let name = get("name").ok_or_else(|| self.error(at, "<robot-type> needs a name attribute"))?;
        let mut kind = match get("base") {
            None => RobotType::new(name),
            Some(b) => RobotType::builtin(b)
                .or_else(|| self.types.iter().find(|k| k.name == b).cloned())
                .ok_or_else(|| self.error(at, format!("unknown base type '{b}' (known: {})", self.type_names())))?,
        };
        name.clone_into(&mut kind.name);
        let problem = |e: Error| {
            let message = match e {
                Error::InvalidParameter(m) => m,
                other => other.to_string(),
            };
            self.error(at, format!("robot type '{name}': {message}"))
        };
        for (key, value) in attributes.iter().filter(|(k, _)| k != "name" && k != "base") {
            kind.set_attribute(key, value).map_err(problem)?;
        }
        kind.validate().map_err(|e| self.error(at, e.to_string()))?;
        Ok(kind)
    }

    /// One `<group>`.
    fn group(&self, index: usize, g: &XmlGroup, at: (usize, usize)) -> Result<GroupConfig> {
        let count = self.whole(Some(&g.count), "count", at)?.unwrap_or(0);
        let count = u32::try_from(count).map_err(|_| self.error(at, format!("count {count} is too large")))?;
        let start = match g.start.as_deref().map(str::trim) {
            None | Some("home") => Start::Home,
            Some(s) => {
                let parts: Vec<_> = s.split(',').map(|p| p.trim().parse::<f64>()).collect();
                match parts.as_slice() {
                    [Ok(x), Ok(y)] if x.is_finite() && y.is_finite() => Start::At(DVec2::new(*x, *y)),
                    _ => {
                        return Err(self.error(at, format!("start must be 'home' or 'X,Y' in metres, got '{s}'")));
                    }
                }
            }
        };
        let twice = (0..g.params.len()).find(|&k| g.params[..k].iter().any(|q| q.name == g.params[k].name));
        if let Some(k) = twice {
            let param = &g.params[k].name;
            return Err(self.error(at, format!("the group gives the parameter '{param}' twice")));
        }
        Ok(GroupConfig {
            name: g.name.clone().unwrap_or_else(|| format!("group{index}")),
            count,
            type_name: g.kind.clone(),
            strategy: g.strategy.clone(),
            params: g.params.iter().map(|p| (p.name.clone(), p.value.clone())).collect(),
            start,
            at,
        })
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

    /// The map given on the command line in place of the `<map>` element, if any.
    pub fn map_argument(&self) -> Option<&Path> {
        self.map_from_argument.then_some(self.map_path.as_path())
    }

    /// The config text as parsed.
    pub fn text(&self) -> &str {
        &self.text
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
        self.scenario_with_map(registry, Arc::new(self.load_map()?))
    }

    /// Load the config's map; an error names where the map was given (the `<map>` element
    /// or the `--map` argument).
    pub fn load_map(&self) -> Result<MapData> {
        if !self.map_path.is_file() {
            return Err(self.map_error(format!("map file {} does not exist", self.map_path.display())));
        }
        MapData::load(&self.map_path).map_err(|e| self.map_error(e.to_string()))
    }

    /// [`scenario`](Self::scenario) on a map already loaded (a sweep loads each of its maps
    /// once for all its runs).
    pub fn scenario_with_map(&self, registry: &StrategyRegistry, map: Arc<MapData>) -> Result<Scenario> {
        if let Some(first) = self.groups.first().filter(|_| self.groups.iter().all(|g| g.count == 0)) {
            return Err(self.error(first.at, "no robots to simulate: every <group> has count 0"));
        }
        let mut builder = ScenarioBuilder::new(map)
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

    /// The error of a config `text` that must not parse.
    fn parse_error(text: &str) -> String {
        match SimConfig::parse(text, Path::new("c.xml")) {
            Ok(_) => panic!("a malformed config parsed"),
            Err(e) => e.to_string(),
        }
    }

    /// A config whose groups are all empty is refused at its first group.
    #[test]
    fn a_config_without_robots_is_refused() {
        let grid = crate::spatial::Grid::new(glam::DVec2::ZERO, 1.0, 16, 16).unwrap();
        let map = MapData {
            obstacles: crate::spatial::ObstacleMap::empty(grid),
            home: crate::world::HomeBase::Disc {
                center: glam::DVec2::splat(8.0),
                radius_m: 2.0,
            },
            treasures: Vec::new(),
        };
        let text = "<simulation>\n  <map file=\"x.stmap\"/>\n  <group count=\"0\" type=\"explorer\" strategy=\"random_walk\"/>\n</simulation>";
        let config = SimConfig::parse(text, Path::new("c.xml")).unwrap();
        let err = config
            .scenario_with_map(&StrategyRegistry::with_builtins(), Arc::new(map))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert_eq!(err, "c.xml:3:3: no robots to simulate: every <group> has count 0");
    }

    /// A malformed attribute is reported where it is, in the element that holds it.
    #[test]
    fn malformed_attributes_are_reported_at_their_place() {
        let head = "<simulation name=\"m\" rounds=\"10\">\n  <map file=\"x.stmap\"/>\n";
        // Column 25 of line 3 is the `2`.
        let err = parse_error(&format!(
            "{head}  <group name=\"g\" count=2 type=\"explorer\"/>\n</simulation>\n"
        ));
        assert!(
            err.starts_with("c.xml:3:25: malformed XML in <group>: attribute value must be enclosed"),
            "{err}"
        );
        // Column 19 of line 3 is the second `name`.
        let err = parse_error(&format!("{head}  <group name=\"g\" name=\"h\"/>\n</simulation>\n"));
        assert_eq!(
            err,
            "c.xml:3:19: malformed XML in <group>: attribute `name` given twice"
        );
    }

    /// Two groups of one name are refused at the second.
    #[test]
    fn group_names_are_unique() {
        let group =
            |name: &str| format!("<group name=\"{name}\" count=\"1\" type=\"explorer\" strategy=\"random_walk\"/>");
        let err = parse_error(&format!(
            "<simulation>\n  <map file=\"x.stmap\"/>\n  {}\n  {}\n  {}\n</simulation>\n",
            group("a"),
            group("b"),
            group("a")
        ));
        assert_eq!(err, "c.xml:5:3: a second group named 'a' (the first is at 3:3)");
    }

    /// A parameter given twice in a group is refused at the group, rather than one of the
    /// two silently winning.
    #[test]
    fn a_parameter_given_twice_is_refused() {
        let err = parse_error(
            "<simulation>\n  <map file=\"x.stmap\"/>\n  <group count=\"1\" type=\"explorer\" strategy=\"tactics\">\n    \
             <param name=\"goal\" value=\"1,1\"/><param name=\"goal\" value=\"2,2\"/>\n  </group>\n</simulation>\n",
        );
        assert_eq!(err, "c.xml:3:3: the group gives the parameter 'goal' twice");
    }

    /// Unknown attributes and elements, and a missing <map>, are placed and named.
    #[test]
    fn structure_errors_name_their_element_and_place() {
        let head = "<simulation rounds=\"5\">\n  <map file=\"x.stmap\"/>\n";
        let group = "<group count=\"1\" type=\"explorer\" strategy=\"random_walk\"";
        let err = parse_error(&format!("{head}  {group} colour=\"red\"/>\n</simulation>\n"));
        assert_eq!(
            err,
            "c.xml:3:3: <group> has no attribute `colour` (its attributes: name, count, type, strategy, start)"
        );
        let err = parse_error(&format!("{head}  {group}/>\n  <foo/>\n</simulation>\n"));
        assert!(
            err.starts_with("c.xml:4:3: unknown element <foo> (expected here: <map>,"),
            "{err}"
        );
        let err = parse_error(&format!("<simulation rounds=\"5\">\n  {group}/>\n</simulation>\n"));
        assert_eq!(err, "c.xml:1:1: <simulation> lacks a <map> element");
    }

    /// A tag left without its `>` takes in the next tag, whose place is reported, with the
    /// tag that lacks the end.
    #[test]
    fn a_tag_without_its_end_is_named() {
        let text = "<simulation name=\"m\" rounds=\"10\">\n  <map file=\"x.stmap\"/>\n  \
                    <group name=\"g\" type=\"explorer\"\n</simulation>\n";
        let err = parse_error(text);
        assert!(err.starts_with("c.xml:4:"), "{err}");
        assert!(
            err.contains("malformed XML in <group>") && err.contains("the <group> at 3:3 lacks its `>` or `/>`"),
            "{err}"
        );
    }
}
