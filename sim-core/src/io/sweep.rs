//! Parameter sweeps: the full grid of runs a sweep file describes, run headless, written as
//! one tidy CSV; shards of it for a cluster, and the merge of their outputs.
//!
//! ```xml
//! <sweep name="demo-sweep" config="demo.xml" rounds="200">  <!-- config: relative to this file -->
//!   <seed from="1" to="3"/>                         <!-- or values="1,2,3" -->
//!   <count group="scouts" values="4,8"/>
//!   <strategy group="diggers" values="excavator,random_walk"/>
//!   <param group="scouts" name="share_every" values="5,20"/>
//!   <map values="../maps/demo.stmap,../maps/rooms.stmap"/>
//!   <rounds values="100,200"/>
//! </sweep>
//! ```
//!
//! Each element is an axis and adds a column (`seed`, `scouts.count`, `diggers.strategy`,
//! `scouts.share_every`, `map`, `rounds`); the runs are every combination of the axes'
//! values, the last axis varying fastest, numbered from 0 in that order. The CSV has one row
//! per run and round: `run`, the axes' columns, then the metrics columns.
//!
//! Every run is written, as soon as it ends, to its own file in `RESULTS.csv.parts/` (write
//! then rename), so a sweep that is stopped resumes where it was: finished runs are not
//! redone. When all runs are there the CSV is assembled in run order, a manifest is written
//! beside it (`RESULTS.manifest.json`) and the parts are removed.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use quick_xml::events::Event as XmlEvent;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::agent::StrategyRegistry;
use crate::engine::Simulation;
use crate::io::config::{SimConfig, attribute_error, line_col};
use crate::world::{METRICS_COLUMNS, MapData};
use crate::write_atomically;
use crate::{Error, Result};

/// The most runs a sweep may ask for (a typo such as an extra zero should not start a
/// month of computing).
pub const MAX_RUNS: usize = 10_000_000;

/// What one axis varies.
#[derive(Clone, Debug, PartialEq)]
enum Vary {
    Seed,
    Rounds,
    Map(Vec<PathBuf>),
    /// Robots in the group with this index.
    Count(usize),
    Strategy(usize),
    /// A strategy parameter of a group.
    Param(usize, String),
}

/// One axis of a sweep: a column and its values.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// CSV column (`seed`, `map`, `rounds`, `GROUP.count`, `GROUP.strategy`, `GROUP.PARAM`).
    pub column: String,
    /// The values, as written in the sweep file.
    pub values: Vec<String>,
    vary: Vary,
    at: (usize, usize),
}

/// A parsed sweep file.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The sweep file.
    pub path: PathBuf,
    /// Sweep name (default: the file stem).
    pub name: String,
    /// The base config every run starts from.
    pub base: SimConfig,
    /// Rounds of every run (`rounds` attribute; default: the base config's), unless an
    /// axis varies them.
    pub rounds: u64,
    /// The axes, slowest first.
    pub axes: Vec<Axis>,
    /// Fingerprint of the sweep and base config texts: parts of another sweep are refused.
    fingerprint: u32,
}

/// The `I`-th of `N` disjoint slices of a sweep's runs (runs `I`, `I + N`, `I + 2N`, …, so
/// that slices get a fair share of every axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which slice, from 0.
    pub index: usize,
    /// How many slices.
    pub count: usize,
}

impl Shard {
    /// The whole sweep.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// A slice, checked: `count ≥ 1` and `index < count`.
    pub fn new(index: usize, count: usize) -> Result<Self> {
        if count == 0 {
            return Err(Error::InvalidParameter("a sweep cannot be cut into 0 shards".into()));
        }
        if index >= count {
            return Err(Error::InvalidParameter(format!(
                "shard {index} of {count} does not exist (shards are numbered 0 to {})",
                count - 1
            )));
        }
        Ok(Self { index, count })
    }

    /// Whether run `run` belongs to this slice.
    pub fn holds(&self, run: usize) -> bool {
        run % self.count == self.index
    }
}

impl std::str::FromStr for Shard {
    type Err = Error;

    /// `I/N`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = || Error::InvalidParameter(format!("a shard is I/N with 0 ≤ I < N, got '{s}'"));
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let i = i.trim().parse().map_err(|_| bad())?;
        let n = n.trim().parse().map_err(|_| bad())?;
        Shard::new(i, n)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Progress of a running sweep, for a progress bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SweepProgress {
    /// Runs of this shard finished (those found from an earlier attempt included).
    pub done: usize,
    /// Runs of this shard.
    pub total: usize,
    /// Runs found finished from an earlier attempt.
    pub resumed: usize,
}

/// What a finished sweep (or shard) did.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSummary {
    /// Runs of the whole sweep.
    pub runs_total: usize,
    /// Runs of this shard.
    pub runs: usize,
    /// Of those, runs found finished from an earlier attempt (not redone).
    pub resumed: usize,
    /// Rows written (one per run and round).
    pub rows: usize,
    /// The CSV.
    pub output: PathBuf,
    /// The manifest beside it.
    pub manifest: PathBuf,
}

/// The manifest written beside a sweep's CSV: what was run, and how it went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Version of Smart Teams that ran it.
    pub smartteams_version: String,
    /// Sweep name.
    pub sweep: String,
    /// The sweep file.
    pub sweep_file: String,
    /// The base config.
    pub base_config: String,
    /// Columns of the CSV.
    pub columns: Vec<String>,
    /// Runs of the whole sweep.
    pub runs_total: usize,
    /// Which shards this file covers (`"0/1"`: the whole sweep; merged files list all).
    pub shards: Vec<String>,
    /// The runs in the CSV, in order.
    pub runs: Vec<ManifestRun>,
}

/// One run in a [`Manifest`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestRun {
    /// Run number.
    pub run: usize,
    /// Its values, by column.
    pub values: BTreeMap<String, String>,
    /// Rounds played.
    pub rounds: u64,
    /// Wall time in seconds (set-up included).
    pub seconds: f64,
}

/// Split a value list (`a, b ,c`).
fn list(s: &str) -> Vec<String> {
    s.split(',').map(|v| v.trim().to_owned()).collect()
}

/// An element of a sweep file: its name, attributes and byte offset.
struct Element {
    name: String,
    attributes: Vec<(String, String)>,
    at: usize,
}

impl Element {
    fn get(&self, key: &str) -> Option<&str> {
        self.attributes.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// An error unless every attribute is one of `allowed`.
    fn only(&self, allowed: &[&str], file: &SweepText) -> Result<()> {
        match self.attributes.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
            Some((k, _)) => Err(file.error(
                self.at,
                format!(
                    "<{}> has no attribute '{k}' (it takes: {})",
                    self.name,
                    allowed.join(", ")
                ),
            )),
            None => Ok(()),
        }
    }

    fn values(&self, file: &SweepText) -> Result<Vec<String>> {
        let v = self
            .get("values")
            .ok_or_else(|| file.error(self.at, format!("<{}> needs values=\"a,b,…\"", self.name)))?;
        Ok(list(v))
    }
}

/// A sweep file's text, for reading it with errors that point into it.
struct SweepText<'a> {
    text: &'a str,
    path: &'a Path,
}

impl SweepText<'_> {
    fn error(&self, offset: usize, message: impl Into<String>) -> Error {
        let (line, column) = line_col(self.text, offset);
        Error::Config {
            path: self.path.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }

    /// A path in the file, relative to its folder.
    fn resolve(&self, p: &str) -> PathBuf {
        let p = PathBuf::from(p);
        if p.is_absolute() {
            p
        } else {
            self.path.parent().unwrap_or(Path::new("")).join(p)
        }
    }

    /// The root `<sweep>` and the axis elements inside it, checked for well-formedness.
    fn scan(&self) -> Result<(Element, Vec<Element>)> {
        let text = self.text;
        let mut reader = quick_xml::Reader::from_str(text);
        let mut depth = 0usize;
        let mut root = None;
        let mut elements = Vec::new();
        loop {
            let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
            let event = reader.read_event().map_err(|e| {
                self.error(
                    usize::try_from(reader.error_position()).unwrap_or(usize::MAX),
                    format!("malformed XML: {e}"),
                )
            })?;
            let at = before + text[before.min(text.len())..].find('<').unwrap_or(0);
            let (e, opens) = match event {
                XmlEvent::Eof => break,
                XmlEvent::Start(e) => (e, true),
                XmlEvent::Empty(e) => (e, false),
                XmlEvent::End(_) => {
                    depth = depth.saturating_sub(1);
                    continue;
                }
                XmlEvent::Text(t) if !AsRef::<str>::as_ref(&t).trim().is_empty() => {
                    return Err(self.error(before, "unexpected text (values go in attributes)"));
                }
                _ => continue,
            };
            let name = e.name().as_ref().to_owned();
            let mut attributes = Vec::new();
            for a in e.attributes() {
                let a = a.map_err(|err| {
                    let (offset, message) = attribute_error(text, &name, at, &err);
                    self.error(offset, message)
                })?;
                let value = a
                    .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                    .map_err(|err| self.error(at, format!("malformed XML: {err}")))?;
                attributes.push((a.key.as_ref().to_owned(), value.into_owned()));
            }
            let element = Element { name, attributes, at };
            match depth {
                0 if root.is_none() => {
                    if element.name != "sweep" {
                        return Err(self.error(
                            at,
                            format!("the root element must be <sweep>, found <{}>", element.name),
                        ));
                    }
                    root = Some(element);
                }
                1 => elements.push(element),
                _ => {
                    return Err(self.error(
                        at,
                        format!("<{}> cannot stand here (axes go directly in <sweep>)", element.name),
                    ));
                }
            }
            if opens {
                depth += 1;
            }
        }
        let root = root.ok_or_else(|| self.error(0, "no <sweep> element"))?;
        Ok((root, elements))
    }

    /// The group an axis names.
    fn group(&self, e: &Element, base: &SimConfig) -> Result<usize> {
        let g = e
            .get("group")
            .ok_or_else(|| self.error(e.at, format!("<{}> needs a group attribute", e.name)))?;
        base.groups.iter().position(|c| c.name == g).ok_or_else(|| {
            let known: Vec<_> = base.groups.iter().map(|c| c.name.as_str()).collect();
            self.error(
                e.at,
                format!(
                    "no group '{g}' in {} (its groups: {})",
                    base.path.display(),
                    known.join(", ")
                ),
            )
        })
    }

    /// Seeds: `values="1,2"` or `from="1" to="9"`.
    fn seeds(&self, e: &Element) -> Result<Vec<String>> {
        e.only(&["values", "from", "to"], self)?;
        match (e.get("values"), e.get("from"), e.get("to")) {
            (Some(v), None, None) => Ok(list(v)),
            (None, Some(from), Some(to)) => {
                let parse = |s: &str| {
                    s.trim()
                        .parse::<u64>()
                        .map_err(|_| self.error(e.at, format!("seeds are whole numbers ≥ 0, got '{s}'")))
                };
                let (a, b) = (parse(from)?, parse(to)?);
                if b < a || b - a >= MAX_RUNS as u64 {
                    return Err(self.error(
                        e.at,
                        format!("from=\"{a}\" to=\"{b}\" is no range of at most {MAX_RUNS} seeds"),
                    ));
                }
                Ok((a..=b).map(|s| s.to_string()).collect())
            }
            _ => Err(self.error(e.at, "<seed> takes values=\"…\" or from=\"…\" to=\"…\"")),
        }
    }

    /// One axis element.
    fn axis(&self, e: &Element, base: &SimConfig) -> Result<Axis> {
        let at = e.at;
        let (vary, column, values) = match e.name.as_str() {
            "seed" => (Vary::Seed, "seed".to_owned(), self.seeds(e)?),
            "rounds" => {
                e.only(&["values"], self)?;
                (Vary::Rounds, "rounds".to_owned(), e.values(self)?)
            }
            "map" => {
                e.only(&["values"], self)?;
                let values = e.values(self)?;
                let paths: Vec<PathBuf> = values.iter().map(|v| self.resolve(v)).collect();
                if let Some(missing) = paths.iter().find(|p| !p.is_file()) {
                    return Err(self.error(at, format!("map file {} does not exist", missing.display())));
                }
                (Vary::Map(paths), "map".to_owned(), values)
            }
            "count" | "strategy" => {
                e.only(&["group", "values"], self)?;
                let g = self.group(e, base)?;
                let column = format!("{}.{}", base.groups[g].name, e.name);
                let vary = if e.name == "count" {
                    Vary::Count(g)
                } else {
                    Vary::Strategy(g)
                };
                (vary, column, e.values(self)?)
            }
            "param" => {
                e.only(&["group", "name", "values"], self)?;
                let g = self.group(e, base)?;
                let p = e
                    .get("name")
                    .ok_or_else(|| self.error(at, "<param> needs a name attribute (the parameter)"))?;
                (
                    Vary::Param(g, p.to_owned()),
                    format!("{}.{p}", base.groups[g].name),
                    e.values(self)?,
                )
            }
            other => {
                return Err(self.error(
                    at,
                    format!("unknown axis <{other}> (axes: seed, count, strategy, param, map, rounds)"),
                ));
            }
        };
        if let Some(empty) = values.iter().position(String::is_empty) {
            return Err(self.error(at, format!("value {} of <{}> is empty", empty + 1, e.name)));
        }
        let whole = |kind: &str, ok: &dyn Fn(&str) -> bool| match values.iter().find(|v| !ok(v)) {
            Some(v) => Err(self.error(at, format!("{kind} must be whole numbers, got '{v}'"))),
            None => Ok(()),
        };
        match vary {
            Vary::Seed | Vary::Rounds => whole(&e.name, &|v| v.parse::<u64>().is_ok())?,
            Vary::Count(_) => whole("robot counts", &|v| v.parse::<u32>().is_ok())?,
            _ => {}
        }
        let mut seen = BTreeSet::new();
        if let Some(v) = values.iter().find(|v| !seen.insert(v.as_str())) {
            return Err(self.error(at, format!("value '{v}' is listed twice in <{}>", e.name)));
        }
        Ok(Axis {
            column,
            values,
            vary,
            at: line_col(self.text, at),
        })
    }
}

impl Sweep {
    /// Read and parse a sweep file (and the base config it names).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::parse(&text, path)
    }

    /// Parse sweep text read from `path` (relative paths inside resolve against its folder).
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let file = SweepText { text, path };
        let (root, elements) = file.scan()?;
        root.only(&["name", "config", "rounds"], &file)?;
        let config = root
            .get("config")
            .ok_or_else(|| file.error(root.at, "<sweep> needs a config attribute (the base config file)"))?;
        let base =
            SimConfig::load(&file.resolve(config)).map_err(|e| file.error(root.at, format!("its base config: {e}")))?;
        let rounds = match root.get("rounds") {
            None => base.rounds,
            Some(r) => r
                .trim()
                .parse()
                .map_err(|_| file.error(root.at, format!("rounds must be a whole number ≥ 0, got '{r}'")))?,
        };
        let name = root
            .get("name")
            .map(str::to_owned)
            .or_else(|| path.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "sweep".into());
        let mut axes: Vec<Axis> = Vec::new();
        for element in &elements {
            let axis = file.axis(element, &base)?;
            if let Some(twice) = axes.iter().find(|a| a.column == axis.column) {
                return Err(file.error(
                    element.at,
                    format!(
                        "column '{}' is varied twice (first at line {})",
                        axis.column, twice.at.0
                    ),
                ));
            }
            axes.push(axis);
        }
        let runs = axes
            .iter()
            .try_fold(1usize, |n, a| n.checked_mul(a.values.len()).filter(|&n| n <= MAX_RUNS));
        if runs.is_none() {
            return Err(file.error(root.at, format!("the grid has more than {MAX_RUNS} runs")));
        }
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(text.as_bytes());
        hasher.update(&std::fs::read(&base.path).unwrap_or_default());
        Ok(Self {
            path: path.to_path_buf(),
            name,
            base,
            rounds,
            axes,
            fingerprint: hasher.finalize(),
        })
    }

    /// Number of runs: the product of the axes' lengths.
    pub fn run_count(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// The CSV columns: `run`, the axes', the metrics'.
    pub fn columns(&self) -> Vec<String> {
        std::iter::once("run".to_owned())
            .chain(self.axes.iter().map(|a| a.column.clone()))
            .chain(METRICS_COLUMNS.iter().map(|&c| c.to_owned()))
            .collect()
    }

    /// The values of run `run` (one per axis; the last axis varies fastest).
    pub fn values(&self, run: usize) -> Vec<&str> {
        let mut rest = run;
        let mut out = vec![""; self.axes.len()];
        for (slot, axis) in out.iter_mut().zip(&self.axes).rev() {
            let n = axis.values.len();
            *slot = &axis.values[rest % n];
            rest /= n;
        }
        out
    }

    /// The config of run `run`, and the map file it uses.
    pub fn config(&self, run: usize) -> (SimConfig, PathBuf) {
        let mut config = self.base.clone();
        config.rounds = self.rounds;
        let mut map = config.map_path().to_path_buf();
        for (axis, value) in self.axes.iter().zip(self.values(run)) {
            // Values were checked when the file was read.
            match &axis.vary {
                Vary::Seed => config.seed = value.parse().unwrap_or_default(),
                Vary::Rounds => config.rounds = value.parse().unwrap_or_default(),
                Vary::Map(paths) => {
                    let i = axis.values.iter().position(|v| v == value).unwrap_or(0);
                    map.clone_from(&paths[i]);
                }
                Vary::Count(g) => config.groups[*g].count = value.parse().unwrap_or_default(),
                Vary::Strategy(g) => value.clone_into(&mut config.groups[*g].strategy),
                Vary::Param(g, name) => {
                    let params = std::mem::take(&mut config.groups[*g].params);
                    config.groups[*g].params = params.with(name.clone(), value);
                }
            }
        }
        (config, map)
    }

    fn error_at(&self, at: (usize, usize), message: String) -> Error {
        Error::Config {
            path: self.path.clone(),
            line: at.0,
            column: at.1,
            message,
        }
    }

    /// Check what needs the strategies: every strategy named exists, and takes its group's
    /// parameters and the values of every parameter axis.
    pub fn check(&self, registry: &StrategyRegistry) -> Result<()> {
        for axis in &self.axes {
            if let Vary::Strategy(_) = axis.vary
                && let Some(v) = axis.values.iter().find(|v| !registry.contains(v))
            {
                let known: Vec<_> = registry.names().collect();
                return Err(self.error_at(axis.at, format!("unknown strategy '{v}' (known: {})", known.join(", "))));
            }
        }
        // The group's parameters in the base config go to every strategy it runs.
        for axis in &self.axes {
            if let Vary::Strategy(g) = axis.vary {
                for strategy in &axis.values {
                    if let Err(e) = registry.create(strategy, &self.base.groups[g].params) {
                        let message = format!(
                            "{}={strategy}: {e} (the group's parameters in the base config go to every strategy it runs)",
                            axis.column
                        );
                        return Err(self.error_at(axis.at, message));
                    }
                }
            }
        }
        for axis in &self.axes {
            if let Vary::Param(g, name) = &axis.vary {
                self.check_param(registry, *g, name, axis)?;
            }
        }
        Ok(())
    }

    /// Each value of a parameter `axis` of group `g` as each strategy the group may run
    /// takes it (its own, or those a strategy axis gives it): a misspelt name or a bad
    /// value is placed at the axis, before any run starts.
    fn check_param(&self, registry: &StrategyRegistry, g: usize, name: &str, axis: &Axis) -> Result<()> {
        let group = &self.base.groups[g];
        let mut strategies = vec![group.strategy.as_str()];
        for other in &self.axes {
            if matches!(other.vary, Vary::Strategy(h) if h == g) {
                strategies.extend(other.values.iter().map(String::as_str));
            }
        }
        for strategy in strategies {
            for value in &axis.values {
                let params = group.params.clone().with(name, value.as_str());
                if let Err(e) = registry.create(strategy, &params) {
                    let message = format!("{}={value}: {e}", axis.column);
                    return Err(self.error_at(axis.at, message));
                }
            }
        }
        Ok(())
    }

    /// `run 3 (seed=1, scouts.count=8)`.
    fn describe(&self, run: usize) -> String {
        let values: Vec<String> = self
            .axes
            .iter()
            .zip(self.values(run))
            .map(|(a, v)| format!("{}={v}", a.column))
            .collect();
        format!("run {run} ({})", values.join(", "))
    }

    /// Play run `run` headless: its CSV rows (no header) and rounds played.
    /// Run `run` and its CSV rows, or `None` if `stop` asked for a stop before its last round.
    fn play(
        &self,
        run: usize,
        registry: &StrategyRegistry,
        maps: &HashMap<PathBuf, Arc<MapData>>,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Vec<u8>>> {
        let (config, map_path) = self.config(run);
        let within = |e: Error| self.error_at((0, 0), format!("{}: {e}", self.describe(run)));
        let map = maps.get(&map_path).cloned().ok_or_else(|| {
            within(Error::InvalidParameter(format!(
                "map {} was not loaded",
                map_path.display()
            )))
        })?;
        let scenario = config.scenario_with_map(registry, map).map_err(within)?;
        let mut sim = Simulation::new(scenario).map_err(within)?;
        let prefix: Vec<String> = std::iter::once(run.to_string())
            .chain(self.values(run).into_iter().map(str::to_owned))
            .collect();
        let mut out = csv::Writer::from_writer(Vec::new());
        let csv_error = |e: csv::Error| within(Error::Malformed(format!("writing CSV: {e}")));
        while sim.round() < sim.total_rounds() {
            if stop() {
                return Ok(None);
            }
            let report = sim.step();
            out.write_record(
                prefix
                    .iter()
                    .map(String::as_str)
                    .chain(report.metrics.csv_record().iter().map(String::as_str)),
            )
            .map_err(csv_error)?;
        }
        out.into_inner()
            .map(Some)
            .map_err(|e| within(Error::Malformed(format!("writing CSV: {}", e.error()))))
    }
}

/// `RESULTS.csv` → `RESULTS.manifest.json`.
pub fn manifest_path(output: &Path) -> PathBuf {
    output.with_extension("manifest.json")
}

/// `RESULTS.csv` → `RESULTS.csv.parts`.
fn parts_dir(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".parts");
    PathBuf::from(s)
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    }
}

/// Run the runs of `shard` (all of them with [`Shard::ALL`]) on the current rayon pool,
/// several at a time, and write the CSV `output` and its manifest. Runs finished by an
/// earlier, interrupted attempt at the same sweep and output are not redone. `progress` is
/// called at the start and after every run.
pub fn run_sweep(
    sweep: &Sweep,
    registry: &StrategyRegistry,
    shard: Shard,
    output: &Path,
    progress: &(dyn Fn(SweepProgress) + Sync),
) -> Result<SweepSummary> {
    run_sweep_until(sweep, registry, shard, output, progress, &|| false)
}

/// [`run_sweep`], stopping when `stop` says so (it is asked before each round): the runs in
/// progress are dropped at the end of their round, those finished are kept for a resumed
/// sweep, and the answer is [`Error::Stopped`].
pub fn run_sweep_until(
    sweep: &Sweep,
    registry: &StrategyRegistry,
    shard: Shard,
    output: &Path,
    progress: &(dyn Fn(SweepProgress) + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<SweepSummary> {
    sweep.check(registry)?;
    let runs: Vec<usize> = (0..sweep.run_count()).filter(|&r| shard.holds(r)).collect();
    let maps = load_maps(sweep, &runs)?;
    let parts = open_parts(sweep, output)?;
    let part = |run: usize| parts.join(format!("run-{run:07}.csv"));
    let seconds_file = |run: usize| parts.join(format!("run-{run:07}.seconds"));
    let pending: Vec<usize> = runs.iter().copied().filter(|&r| !part(r).is_file()).collect();
    let resumed = runs.len() - pending.len();
    let done = std::sync::atomic::AtomicUsize::new(resumed);
    let report = |done: usize| {
        progress(SweepProgress {
            done,
            total: runs.len(),
            resumed,
        });
    };
    report(resumed);
    pending.par_iter().try_for_each(|&run| -> Result<()> {
        if stop() {
            return Ok(());
        }
        let started = Instant::now();
        let Some(rows) = sweep.play(run, registry, &maps, stop)? else {
            return Ok(());
        };
        write_atomically(
            &seconds_file(run),
            format!("{}\n", started.elapsed().as_secs_f64()).as_bytes(),
        )?;
        write_atomically(&part(run), &rows)?;
        report(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
        Ok(())
    })?;

    let done = done.into_inner();
    if done < runs.len() {
        return Err(Error::Stopped {
            done,
            total: runs.len(),
            parts,
        });
    }
    // All there: assemble in run order.
    let (rows, manifest) = assemble(sweep, shard, &runs, &part, &seconds_file, output)?;
    std::fs::remove_dir_all(&parts).map_err(io_error(&parts))?;
    Ok(SweepSummary {
        runs_total: sweep.run_count(),
        runs: runs.len(),
        resumed,
        rows,
        output: output.to_path_buf(),
        manifest,
    })
}

/// The maps of `runs`, each loaded once and shared by the runs that use it.
fn load_maps(sweep: &Sweep, runs: &[usize]) -> Result<HashMap<PathBuf, Arc<MapData>>> {
    let mut maps = HashMap::new();
    for &run in runs {
        let (_, path) = sweep.config(run);
        if let std::collections::hash_map::Entry::Vacant(slot) = maps.entry(path) {
            let map = MapData::load(slot.key())?;
            slot.insert(Arc::new(map));
        }
    }
    Ok(maps)
}

/// The folder of `output`'s finished runs: made (with the sweep's key) for a new attempt,
/// checked to be this sweep's for a resumed one.
fn open_parts(sweep: &Sweep, output: &Path) -> Result<PathBuf> {
    let parts = parts_dir(output);
    let key_file = parts.join("sweep.key");
    let key = format!("{:08x} {}\n", sweep.fingerprint, sweep.path.display());
    if parts.is_dir() {
        let found = std::fs::read_to_string(&key_file).unwrap_or_default();
        if found != key {
            return Err(Error::InvalidParameter(format!(
                "{} holds runs of another sweep (or another version of this one); remove it to start afresh",
                parts.display()
            )));
        }
    } else {
        std::fs::create_dir_all(&parts).map_err(io_error(&parts))?;
        write_atomically(&key_file, key.as_bytes())?;
    }
    Ok(parts)
}

/// Join the parts of `runs` into `output` (header, then the runs in order) and write the
/// manifest beside it. Returns the rows written and the manifest's path.
fn assemble(
    sweep: &Sweep,
    shard: Shard,
    runs: &[usize],
    part: &dyn Fn(usize) -> PathBuf,
    seconds_file: &dyn Fn(usize) -> PathBuf,
    output: &Path,
) -> Result<(usize, PathBuf)> {
    let mut out = csv::Writer::from_writer(Vec::new());
    out.write_record(sweep.columns())
        .map_err(|e| Error::Malformed(format!("writing CSV: {e}")))?;
    let mut bytes = out
        .into_inner()
        .map_err(|e| Error::Malformed(format!("writing CSV: {}", e.error())))?;
    let mut manifest_runs = Vec::with_capacity(runs.len());
    let mut rows = 0;
    for &run in runs {
        let path = part(run);
        bytes.extend_from_slice(&std::fs::read(&path).map_err(io_error(&path))?);
        let seconds = std::fs::read_to_string(seconds_file(run))
            .ok()
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(f64::NAN);
        let (config, _) = sweep.config(run);
        // One row a round.
        rows += usize::try_from(config.rounds).unwrap_or(usize::MAX);
        manifest_runs.push(ManifestRun {
            run,
            values: sweep
                .axes
                .iter()
                .zip(sweep.values(run))
                .map(|(a, v)| (a.column.clone(), v.to_owned()))
                .collect(),
            rounds: config.rounds,
            seconds,
        });
    }
    let manifest = Manifest {
        smartteams_version: env!("CARGO_PKG_VERSION").to_owned(),
        sweep: sweep.name.clone(),
        sweep_file: sweep.path.display().to_string(),
        base_config: sweep.base.path.display().to_string(),
        columns: sweep.columns(),
        runs_total: sweep.run_count(),
        shards: vec![shard.to_string()],
        runs: manifest_runs,
    };
    // The manifest first: a CSV is never seen without it (a merge that finds the CSVs of
    // all shards but one checks from the manifests that the sweep is whole).
    let manifest_file = manifest_path(output);
    write_manifest(&manifest_file, &manifest)?;
    write_atomically(output, &bytes)?;
    Ok((rows, manifest_file))
}

fn write_manifest(path: &Path, manifest: &Manifest) -> Result<()> {
    let mut json = serde_json::to_string_pretty(manifest)
        .map_err(|e| Error::Malformed(format!("{}: cannot write the manifest: {e}", path.display())))?;
    json.push('\n');
    write_atomically(path, json.as_bytes())
}

/// The manifests beside `parts`, merged, when every part has one; an error if runs of the
/// sweep they describe are in none of the parts (`owner`: which part holds each run).
fn merged_manifest(parts: &[PathBuf], owner: &BTreeMap<usize, &Path>) -> Result<Option<Manifest>> {
    let manifests: Option<Vec<Manifest>> = parts
        .iter()
        .map(|p| {
            let text = std::fs::read_to_string(manifest_path(p)).ok()?;
            serde_json::from_str(&text).ok()
        })
        .collect();
    let Some(all) = manifests else {
        return Ok(None);
    };
    let total = all[0].runs_total;
    let missing: Vec<usize> = (0..total).filter(|r| !owner.contains_key(r)).collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(ToString::to_string).collect();
        return Err(Error::InvalidParameter(format!(
            "the sweep has {total} runs but {} are in none of the parts (runs {}{}); a shard missing?",
            missing.len(),
            shown.join(", "),
            if missing.len() > 10 { ", …" } else { "" }
        )));
    }
    let mut m = all[0].clone();
    m.shards = all.iter().flat_map(|m| m.shards.clone()).collect();
    m.runs = all.into_iter().flat_map(|m| m.runs).collect();
    m.runs.sort_by_key(|r| r.run);
    Ok(Some(m))
}

/// What [`merge`] joined.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MergeSummary {
    /// Distinct runs in the output.
    pub runs: usize,
    /// Rows written.
    pub rows: usize,
    /// Runs of the whole sweep, if the parts' manifests say (then every run is there).
    pub runs_total: Option<usize>,
}

/// Join the CSVs of a sweep's shards into `output`: the same bytes a sweep of all runs on
/// one machine writes (rows in run order). Parts must share their header and may not share
/// a run. When every part has its manifest beside it, runs missing from the sweep are an
/// error and a merged manifest is written beside `output`.
pub fn merge(parts: &[PathBuf], output: &Path) -> Result<MergeSummary> {
    if parts.is_empty() {
        return Err(Error::InvalidParameter("nothing to merge: no part files given".into()));
    }
    let mut read = MergeInput::default();
    for path in parts {
        read.add_part(path)?;
    }
    // Stable: rows of a run keep their order (rounds).
    read.rows.sort_by_key(|(run, _)| *run);
    let (header, _) = read.header.expect("at least one part");

    let merged_manifest = merged_manifest(parts, &read.owner)?;

    write_merged_csv(output, &header, &read.rows)?;
    let runs_total = merged_manifest.as_ref().map(|m| m.runs_total);
    if let Some(m) = &merged_manifest {
        write_manifest(&manifest_path(output), m)?;
    }
    Ok(MergeSummary {
        runs: read.owner.len(),
        rows: read.rows.len(),
        runs_total,
    })
}

/// The parts of a merge read so far: the first part's header and path, every row with its
/// run, and the part that holds each run.
#[derive(Default)]
struct MergeInput<'a> {
    header: Option<(csv::StringRecord, &'a Path)>,
    rows: Vec<(usize, csv::StringRecord)>,
    owner: BTreeMap<usize, &'a Path>,
}

impl<'a> MergeInput<'a> {
    /// Read the part at `path`: check its header, then take its rows.
    fn add_part(&mut self, path: &'a Path) -> Result<()> {
        let file = std::fs::File::open(path).map_err(io_error(path))?;
        let mut reader = csv::ReaderBuilder::new().from_reader(std::io::BufReader::new(file));
        let h = reader
            .headers()
            .map_err(|e| part_error(path, 1, format!("not a sweep CSV: {e}")))?
            .clone();
        self.check_header(h, path)?;
        self.take_rows(&mut reader, path)
    }

    /// Check a part's header `h`: a sweep CSV's, with the same columns as the first part's
    /// (which it becomes if this part is the first).
    fn check_header(&mut self, h: csv::StringRecord, path: &'a Path) -> Result<()> {
        if h.get(0) != Some("run") {
            return Err(part_error(
                path,
                1,
                "not a sweep CSV: the first column must be 'run'".into(),
            ));
        }
        match &self.header {
            None => self.header = Some((h, path)),
            Some((first, first_path)) if *first != h => {
                return Err(part_error(
                    path,
                    1,
                    format!(
                        "its columns differ from those of {} (parts of different sweeps?)",
                        first_path.display()
                    ),
                ));
            }
            Some(_) => {}
        }
        Ok(())
    }

    /// Take the rows of the part at `path`, refusing a run that an earlier part also holds.
    fn take_rows(&mut self, reader: &mut csv::Reader<std::io::BufReader<std::fs::File>>, path: &'a Path) -> Result<()> {
        let mut seen_here = BTreeSet::new();
        for record in reader.records() {
            let record = record.map_err(|e| {
                part_error(
                    path,
                    e.position().map_or(0, csv::Position::line),
                    format!("malformed CSV: {e}"),
                )
            })?;
            let line = record.position().map_or(0, csv::Position::line);
            let run: usize = record.get(0).and_then(|r| r.parse().ok()).ok_or_else(|| {
                part_error(
                    path,
                    line,
                    format!("run must be a whole number, got '{}'", record.get(0).unwrap_or("")),
                )
            })?;
            if seen_here.insert(run)
                && let Some(other) = self.owner.insert(run, path)
            {
                return Err(part_error(
                    path,
                    line,
                    format!("run {run} is also in {}", other.display()),
                ));
            }
            self.rows.push((run, record));
        }
        Ok(())
    }
}

/// An error in the part at `path`, at `line` (0 if unknown).
fn part_error(path: &Path, line: u64, message: String) -> Error {
    Error::Config {
        path: path.to_path_buf(),
        line: usize::try_from(line).unwrap_or(0),
        column: 1,
        message,
    }
}

/// Write the merged CSV to `output`: the header, then every row in the order given.
fn write_merged_csv(output: &Path, header: &csv::StringRecord, rows: &[(usize, csv::StringRecord)]) -> Result<()> {
    let mut out = csv::Writer::from_writer(Vec::new());
    let write_error = |e: csv::Error| Error::Malformed(format!("{}: writing CSV: {e}", output.display()));
    out.write_record(header).map_err(write_error)?;
    for (_, record) in rows {
        out.write_record(record).map_err(write_error)?;
    }
    let bytes = out
        .into_inner()
        .map_err(|e| Error::Malformed(format!("{}: writing CSV: {}", output.display(), e.error())))?;
    write_atomically(output, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep_with(axes: &[&[&str]]) -> Sweep {
        let dir = std::env::temp_dir();
        let base = SimConfig::parse(
            r#"<simulation><map file="x.stmap"/><group name="g" count="1" type="explorer" strategy="random_walk"/></simulation>"#,
            &dir.join("base.xml"),
        )
        .unwrap();
        Sweep {
            path: dir.join("s.xml"),
            name: "s".into(),
            rounds: 1,
            axes: axes
                .iter()
                .enumerate()
                .map(|(i, v)| Axis {
                    column: format!("g.p{i}"),
                    values: v.iter().map(|&s| s.to_owned()).collect(),
                    vary: Vary::Param(0, format!("p{i}")),
                    at: (1, 1),
                })
                .collect(),
            base,
            fingerprint: 0,
        }
    }

    /// A malformed attribute is reported where it is, in the element that holds it.
    #[test]
    fn a_sweep_tag_without_its_end_is_named() {
        let text = "<sweep config=\"base.xml\" rounds=\"5\"\n  <seed values=\"1,2\"/>\n</sweep>\n";
        let err = Sweep::parse(text, Path::new("s.xml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.starts_with("s.xml:2:"), "{err}");
        assert!(
            err.contains("malformed XML in <sweep>") && err.contains("the <sweep> at 1:1 lacks its"),
            "{err}"
        );
    }

    #[test]
    fn runs_are_the_grid_in_nested_loop_order() {
        let s = sweep_with(&[&["a", "b"], &["1", "2", "3"], &["x", "y"]]);
        let mut want = Vec::new();
        for a in ["a", "b"] {
            for b in ["1", "2", "3"] {
                for c in ["x", "y"] {
                    want.push(vec![a, b, c]);
                }
            }
        }
        assert_eq!(s.run_count(), 12);
        let got: Vec<Vec<&str>> = (0..12).map(|r| s.values(r)).collect();
        assert_eq!(got, want);
        let (config, _) = s.config(5);
        let params: Vec<_> = config.groups[0].params.iter().collect();
        assert_eq!(params, [("p0", "a"), ("p1", "3"), ("p2", "y")]);
    }

    #[test]
    fn shards_cut_the_runs_into_disjoint_slices_that_cover_them() {
        for n in 1..7 {
            let mut owners = vec![0; 50];
            for i in 0..n {
                let shard = Shard::new(i, n).unwrap();
                (0..50).filter(|&r| shard.holds(r)).for_each(|r| owners[r] += 1);
            }
            assert!(owners.iter().all(|&k| k == 1), "{n} shards: {owners:?}");
        }
        assert_eq!("2/5".parse::<Shard>().unwrap(), Shard { index: 2, count: 5 });
        for bad in ["5/5", "1/0", "x/2", "3", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
