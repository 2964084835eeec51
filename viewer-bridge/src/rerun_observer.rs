//! [`RerunObserver`]: sim-core's [`Observer`] over a [`rerun::RecordingStream`].
//!
//! Entities (time on the sequence timeline [`TIMELINE`]; 2D ones flipped, see [`crate::layers`]):
//!
//! | entity | what | when |
//! |---|---|---|
//! | `world` | `AnnotationContext`: one class per robot type (+ "disabled") | static |
//! | `world/obstacles/raster`, `world/obstacles/boxes` | obstacle raster; exact outlines if ≤ 50k | static |
//! | `world/home` | home base | static |
//! | `world/treasures` | remaining treasures, radius by remaining quantity | logged rounds |
//! | `world/robots` | robots (class id = type) + detail columns `energy`, `action`, `goal`, `load`, … | logged rounds |
//! | `world/paths`, `world/links` | planned paths; message links of the round | logged rounds |
//! | `world/explored` | collective explored region (raster) | every `explored_every` logged rounds |
//! | `world/known/<id>` | one robot's known region, coarse | when it changed, every `known_every` rounds |
//! | `world3d/…` | ground, obstacle boxes with heights, robots on the plane | static / logged rounds |
//! | `metrics/<column>` | one `Scalars` per metrics CSV column ([`METRIC_ENTITIES`]) | every round |
//! | `events` | `TextLog` of the round's events | every round with events |

use sim_core::geometry::Aabb;
use sim_core::model::{Action, Outcome};
use sim_core::observer::{Event, Observer, ObserverError, RoundReport};
use sim_core::{RobotId, Simulation};

use crate::layers::{self, Raster, draw_order, to_2d};

/// The sequence timeline every per-round entity is logged on.
pub const TIMELINE: &str = "round";

/// Metrics CSV column → entity path, for every column but `round` (the timeline itself).
pub const METRIC_ENTITIES: [(&str, &str); 11] = [
    ("explored_fraction", "metrics/exploration/explored_fraction"),
    ("treasures_found", "metrics/treasures/found"),
    ("treasures_excavated", "metrics/treasures/excavated"),
    ("treasures_delivered", "metrics/treasures/delivered"),
    ("robots_alive", "metrics/robots/alive"),
    ("mean_energy", "metrics/energy/mean_energy"),
    ("messages", "metrics/messages/messages"),
    ("distance_m", "metrics/totals/distance_m"),
    ("units_dug", "metrics/totals/units_dug"),
    ("units_delivered", "metrics/totals/units_delivered"),
    ("message_bytes", "metrics/messages/message_bytes"),
];

/// Most communication links drawn in one round (a dense swarm can send O(n²)).
pub const MAX_LINKS: usize = 20_000;

/// How much the observer logs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogOptions {
    /// Log the world every `log_every` rounds (metrics and events: every round; the last round
    /// always).
    pub log_every: u64,
    /// Re-log the collective explored raster every this many rounds (rounded up to a logged
    /// round).
    pub explored_every: u64,
    /// Per-robot known regions: `None` = off; `Some(k)` = every k rounds, for robots whose map
    /// changed since they were last logged.
    pub known_every: Option<u64>,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self {
            log_every: 1,
            explored_every: 10,
            known_every: Some(20),
        }
    }
}

/// Logs a simulation to Rerun. Log errors (serialisation only: transport trouble such as a
/// vanished viewer is absorbed by the sink) stop the run like any observer error.
pub struct RerunObserver {
    rec: rerun::RecordingStream,
    opts: LogOptions,
    explored: Option<Raster>,
    last_explored_round: Option<u64>,
    last_known_round: Option<u64>,
    /// Robots whose known map changed since their region was last logged.
    known_dirty: Vec<bool>,
    logged_rounds: u64,
    /// Wall time spent in this observer (the simulation thread's share of logging).
    busy: std::time::Duration,
}

impl RerunObserver {
    /// An observer logging to `rec` with `opts`.
    pub fn new(rec: rerun::RecordingStream, opts: LogOptions) -> Self {
        Self {
            rec,
            opts: LogOptions {
                log_every: opts.log_every.max(1),
                explored_every: opts.explored_every.max(1),
                known_every: opts.known_every.map(|k| k.max(1)),
            },
            explored: None,
            last_explored_round: None,
            last_known_round: None,
            known_dirty: Vec::new(),
            logged_rounds: 0,
            busy: std::time::Duration::ZERO,
        }
    }

    /// The recording stream.
    pub fn recording(&self) -> &rerun::RecordingStream {
        &self.rec
    }

    /// Rounds whose world state was logged so far (round 0, the start, included).
    pub fn logged_rounds(&self) -> u64 {
        self.logged_rounds
    }

    /// Wall time spent logging on the simulation's thread so far (encoding and writing happen
    /// on Rerun's own threads besides).
    pub fn busy(&self) -> std::time::Duration {
        self.busy
    }

    /// Whether the world is logged after `round` of a run of `total` rounds.
    pub fn is_logged_round(&self, round: u64, total: u64) -> bool {
        round.is_multiple_of(self.opts.log_every) || round >= total
    }

    fn log_world(&mut self, sim: &Simulation, report: Option<&RoundReport>) -> rerun::RecordingStreamResult<()> {
        let round = sim.round();
        let rec = &self.rec;
        self.logged_rounds += 1;
        log_robots(rec, sim)?;
        log_treasures(rec, sim)?;
        log_paths(rec, sim)?;
        if let Some(report) = report {
            log_links(rec, sim, report)?;
        }
        let final_round = round >= sim.total_rounds();
        if final_round
            || self
                .last_explored_round
                .is_none_or(|r| round >= r + self.opts.explored_every)
        {
            self.last_explored_round = Some(round);
            let raster = self
                .explored
                .get_or_insert_with(|| Raster::for_grid(sim.obstacles().grid(), layers::MAX_EXPLORED_PX));
            raster.fill_from(sim.explored().tree(), true);
            rec.log(
                "world/explored",
                &[
                    &raster.transform_2d() as &dyn rerun::AsComponents,
                    &rerun::Image::from_l8(raster.to_l8(), [raster.width, raster.height])
                        .with_opacity(0.3)
                        .with_draw_order(draw_order::EXPLORED),
                ],
            )?;
        }
        if let Some(every) = self.opts.known_every
            && (final_round || self.last_known_round.is_none_or(|r| round >= r + every))
        {
            self.last_known_round = Some(round);
            for robot in sim.robots() {
                let i = robot.id.0 as usize;
                if !self.known_dirty.get(i).copied().unwrap_or(false) {
                    continue;
                }
                self.known_dirty[i] = false;
                if let Some(known) = sim.known_map(robot.id) {
                    let boxes: Vec<Aabb> = layers::coarse_known_boxes(known.tree());
                    rec.log(
                        format!("world/known/{}", robot.id.0),
                        &layers::boxes_2d(&boxes)
                            .with_class_ids([class_of(sim, robot.type_index, true)])
                            .with_draw_order(draw_order::KNOWN),
                    )?;
                }
            }
        }
        Ok(())
    }
}

/// The class id of a robot of type `type_index` (disabled robots share one extra class).
fn class_of(sim: &Simulation, type_index: usize, alive: bool) -> u16 {
    if alive {
        type_index as u16
    } else {
        sim.types().len() as u16
    }
}

/// Colours of robot types, cycled.
const TYPE_COLORS: [[u8; 3]; 6] = [
    [80, 220, 120],
    [255, 170, 40],
    [90, 170, 255],
    [240, 90, 200],
    [250, 240, 90],
    [160, 120, 255],
];

fn log_annotations(rec: &rerun::RecordingStream, sim: &Simulation) -> rerun::RecordingStreamResult<()> {
    let mut classes: Vec<rerun::datatypes::ClassDescriptionMapElem> = sim
        .types()
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let [r, g, b] = TYPE_COLORS[i % TYPE_COLORS.len()];
            (i as u16, t.name.as_str(), rerun::datatypes::Rgba32::from_rgb(r, g, b)).into()
        })
        .collect();
    classes.push(
        (
            sim.types().len() as u16,
            "disabled",
            rerun::datatypes::Rgba32::from_rgb(120, 120, 120),
        )
            .into(),
    );
    let ctx = rerun::AnnotationContext::new(classes);
    rec.log_static("world", &ctx)?;
    rec.log_static("world3d", &ctx)
}

fn log_robots(rec: &rerun::RecordingStream, sim: &Simulation) -> rerun::RecordingStreamResult<()> {
    use rerun::external::arrow::array::{ArrayRef, BooleanArray, Float64Array, StringArray, UInt32Array};
    use std::sync::Arc;

    let robots = sim.robots();
    let positions: Vec<[f32; 2]> = robots.iter().map(|r| to_2d(r.position)).collect();
    let classes: Vec<u16> = robots.iter().map(|r| class_of(sim, r.type_index, r.alive)).collect();
    let labels: Vec<String> = robots
        .iter()
        .map(|r| match r.load() {
            0 => r.id.0.to_string(),
            load => format!("{} +{load}", r.id.0),
        })
        .collect();
    let action = |a: &(Action, Outcome)| {
        let outcome = match a.1 {
            Outcome::Done => "done",
            Outcome::Trimmed => "trimmed",
            Outcome::Refused => "refused",
        };
        format!("{} ({outcome})", a.0.name())
    };
    let detail = rerun::AnyValues::default()
        .with_component_from_data(
            "type",
            Arc::new(StringArray::from_iter_values(
                robots.iter().map(|r| sim.types()[r.type_index].name.as_str()),
            )) as ArrayRef,
        )
        .with_component_from_data(
            "energy",
            Arc::new(Float64Array::from_iter_values(robots.iter().map(|r| r.energy))),
        )
        .with_component_from_data(
            "alive",
            Arc::new(robots.iter().map(|r| Some(r.alive)).collect::<BooleanArray>()),
        )
        .with_component_from_data(
            "action",
            Arc::new(StringArray::from_iter_values(
                robots.iter().map(|r| action(&r.last_action)),
            )),
        )
        .with_component_from_data(
            "goal",
            Arc::new(StringArray::from_iter_values(robots.iter().map(|r| match r.goal {
                Some(g) => format!("({:.1}, {:.1})", g.x, g.y),
                None => "none".to_owned(),
            }))),
        )
        .with_component_from_data(
            "load",
            Arc::new(UInt32Array::from_iter_values(robots.iter().map(sim_core::Robot::load))),
        )
        .with_component_from_data(
            "position",
            Arc::new(StringArray::from_iter_values(
                robots
                    .iter()
                    .map(|r| format!("({:.2}, {:.2})", r.position.x, r.position.y)),
            )),
        );
    rec.log(
        "world/robots",
        &[
            &rerun::Points2D::new(positions)
                .with_radii([rerun::Radius::new_ui_points(4.0)])
                .with_class_ids(classes.clone())
                .with_labels(labels)
                .with_draw_order(draw_order::ROBOTS) as &dyn rerun::AsComponents,
            &detail,
        ],
    )?;
    rec.log(
        "world3d/robots",
        &rerun::Points3D::new(robots.iter().map(|r| {
            let z = sim.types()[r.type_index].radius_m as f32;
            [r.position.x as f32, r.position.y as f32, z]
        }))
        .with_radii([rerun::Radius::new_ui_points(3.0)])
        .with_class_ids(classes),
    )
}

fn log_treasures(rec: &rerun::RecordingStream, sim: &Simulation) -> rerun::RecordingStreamResult<()> {
    let cell_m = sim.obstacles().grid().cell_m();
    let remaining: Vec<_> = sim.treasures().iter().filter(|t| t.buried + t.loose > 0).collect();
    let color = |found: bool| {
        if found {
            rerun::Color::from_rgb(255, 215, 0)
        } else {
            rerun::Color::from_unmultiplied_rgba(255, 215, 0, 110)
        }
    };
    rec.log(
        "world/treasures",
        &rerun::Points2D::new(remaining.iter().map(|t| to_2d(t.position)))
            .with_radii(
                remaining
                    .iter()
                    .map(|t| layers::treasure_radius(t.buried + t.loose, cell_m)),
            )
            .with_colors(remaining.iter().map(|t| color(t.found_round.is_some())))
            .with_labels(remaining.iter().map(|t| (t.buried + t.loose).to_string()))
            .with_draw_order(draw_order::TREASURES),
    )?;
    rec.log(
        "world3d/treasures",
        &rerun::Points3D::new(
            remaining
                .iter()
                .map(|t| [t.position.x as f32, t.position.y as f32, 0.2]),
        )
        .with_radii(
            remaining
                .iter()
                .map(|t| layers::treasure_radius(t.buried + t.loose, cell_m)),
        )
        .with_colors(remaining.iter().map(|t| color(t.found_round.is_some()))),
    )
}

fn log_paths(rec: &rerun::RecordingStream, sim: &Simulation) -> rerun::RecordingStreamResult<()> {
    let with_path: Vec<_> = sim.robots().iter().filter(|r| r.alive && !r.path.is_empty()).collect();
    rec.log(
        "world/paths",
        &rerun::LineStrips2D::new(with_path.iter().map(|r| {
            std::iter::once(to_2d(r.position))
                .chain(r.path.iter().map(|&p| to_2d(p)))
                .collect::<Vec<_>>()
        }))
        .with_class_ids(with_path.iter().map(|r| r.type_index as u16))
        .with_radii([rerun::Radius::new_ui_points(1.0)])
        .with_draw_order(draw_order::PATHS),
    )
}

fn log_links(rec: &rerun::RecordingStream, sim: &Simulation, report: &RoundReport) -> rerun::RecordingStreamResult<()> {
    let robots = sim.robots();
    let pos = |id: RobotId| robots.get(id.0 as usize).map(|r| to_2d(r.position));
    // A broadcast and its answer are one line. Only a bounded prefix is sorted: a dense swarm
    // sends O(n²) deliveries a round and sorting them all cost more than drawing them.
    let mut pairs: Vec<(u32, u32)> = report
        .links
        .iter()
        .take(2 * MAX_LINKS)
        .map(|l| (l.from.0.min(l.to.0), l.from.0.max(l.to.0)))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs.truncate(MAX_LINKS);
    rec.log(
        "world/links",
        &rerun::LineStrips2D::new(
            pairs
                .iter()
                .filter_map(|&(a, b)| Some([pos(RobotId(a))?, pos(RobotId(b))?])),
        )
        .with_colors([rerun::Color::from_unmultiplied_rgba(120, 220, 255, 140)])
        .with_radii([rerun::Radius::new_ui_points(0.75)])
        .with_draw_order(draw_order::LINKS),
    )
}

fn log_metrics(rec: &rerun::RecordingStream, report: &RoundReport) -> rerun::RecordingStreamResult<()> {
    let m = &report.metrics;
    let values: [f64; 11] = [
        m.explored_fraction,
        f64::from(m.treasures_found),
        f64::from(m.treasures_excavated),
        f64::from(m.treasures_delivered),
        f64::from(m.robots_alive),
        m.mean_energy,
        m.messages as f64,
        m.distance_m,
        m.units_dug as f64,
        m.units_delivered as f64,
        m.message_bytes as f64,
    ];
    for ((_, path), v) in METRIC_ENTITIES.iter().zip(values) {
        rec.log(*path, &rerun::Scalars::single(v))?;
    }
    Ok(())
}

fn log_events(rec: &rerun::RecordingStream, report: &RoundReport) -> rerun::RecordingStreamResult<()> {
    for e in &report.events {
        let level = match e {
            Event::RobotDisabled { .. } => rerun::TextLogLevel::WARN,
            _ => rerun::TextLogLevel::INFO,
        };
        rec.log(
            "events",
            &rerun::TextLog::new(format!("round {}: {e}", report.round)).with_level(level),
        )?;
    }
    Ok(())
}

fn log_series_styles(rec: &rerun::RecordingStream) -> rerun::RecordingStreamResult<()> {
    for (column, path) in METRIC_ENTITIES {
        rec.log_static(path, &rerun::SeriesLines::new().with_names([column]))?;
    }
    Ok(())
}

impl Observer for RerunObserver {
    fn on_start(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        self.rec.set_time_sequence(TIMELINE, 0);
        log_annotations(&self.rec, sim)?;
        layers::log_static_map(&self.rec, sim.map())?;
        log_series_styles(&self.rec)?;
        self.known_dirty = vec![true; sim.robots().len()];
        self.log_world(sim, None)?;
        Ok(())
    }

    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        let t0 = std::time::Instant::now();
        self.on_round_inner(sim, report)?;
        self.busy += t0.elapsed();
        Ok(())
    }

    fn on_finish(&mut self, _sim: &Simulation) -> Result<(), ObserverError> {
        // Transport trouble (a viewer gone) must not fail a finished run: report and go on.
        let t0 = std::time::Instant::now();
        if let Err(e) = self.rec.flush_with_timeout(std::time::Duration::from_secs(10)) {
            eprintln!("warning: could not flush the Rerun stream: {e}");
        }
        self.busy += t0.elapsed();
        Ok(())
    }
}

impl RerunObserver {
    fn on_round_inner(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        self.rec.set_time_sequence(TIMELINE, report.round as i64);
        for id in &report.known_changed {
            if let Some(d) = self.known_dirty.get_mut(id.0 as usize) {
                *d = true;
            }
        }
        log_metrics(&self.rec, report)?;
        log_events(&self.rec, report)?;
        if self.is_logged_round(report.round, sim.total_rounds()) {
            self.log_world(sim, Some(report))?;
        }
        Ok(())
    }
}
