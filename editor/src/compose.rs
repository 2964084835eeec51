//! `compose`: a map from an XML scene of shapes, rasterised conservatively (a cell touching a
//! shape is blocked, see [`crate::shapes`]).
//!
//! ```xml
//! <scene width-m="64" height-m="48" cell-m="1" origin-x="0" origin-y="0">
//!   <home x="8" y="8" radius="2"/>
//!   <treasure x="50" y="40" quantity="3"/>
//!   <disc x="20" y="20" radius="4"/>
//!   <rect x="40" y="10" width="10" height="3" rotation-deg="30"/>
//!   <capsule x1="5" y1="30" x2="25" y2="35" radius="1"/>
//!   <polygon x="45" y="30" rotation-deg="0">
//!     <point x="0" y="0"/><point x="6" y="0"/><point x="3" y="5"/>
//!   </polygon>
//! </scene>
//! ```
//! Positions are world metres; polygon points are relative to the polygon's `x`, `y` and
//! rotated about it. Every shape, the home base and every treasure must lie inside the world.

use std::path::Path;

use quick_xml::events::Event;
use serde::Deserialize;
use sim_core::glam::DVec2;
use sim_core::spatial::Aabb;
use sim_core::spatial::Grid;
use sim_core::world::{HomeBase, MapData, TreasureSpec};

use crate::progress::Progress;
use crate::shapes::{Obstacle, ShapeSet};
use crate::{EditorError, Result};

#[derive(Debug, Deserialize)]
#[serde(rename = "scene")]
struct SceneXml {
    #[serde(rename = "@width-m")]
    width_m: f64,
    #[serde(rename = "@height-m")]
    height_m: f64,
    #[serde(rename = "@cell-m", default = "one")]
    cell_m: f64,
    #[serde(rename = "@origin-x", default)]
    origin_x: f64,
    #[serde(rename = "@origin-y", default)]
    origin_y: f64,
    #[serde(rename = "$value", default)]
    items: Vec<Item>,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Item {
    Home {
        #[serde(rename = "@x")]
        x: f64,
        #[serde(rename = "@y")]
        y: f64,
        #[serde(rename = "@radius", default = "two")]
        radius: f64,
    },
    Treasure {
        #[serde(rename = "@x")]
        x: f64,
        #[serde(rename = "@y")]
        y: f64,
        #[serde(rename = "@quantity", default = "one_u32")]
        quantity: u32,
    },
    Disc {
        #[serde(rename = "@x")]
        x: f64,
        #[serde(rename = "@y")]
        y: f64,
        #[serde(rename = "@radius")]
        radius: f64,
    },
    Rect {
        #[serde(rename = "@x")]
        x: f64,
        #[serde(rename = "@y")]
        y: f64,
        #[serde(rename = "@width")]
        width: f64,
        #[serde(rename = "@height")]
        height: f64,
        #[serde(rename = "@rotation-deg", default)]
        rotation_deg: f64,
    },
    Capsule {
        #[serde(rename = "@x1")]
        x1: f64,
        #[serde(rename = "@y1")]
        y1: f64,
        #[serde(rename = "@x2")]
        x2: f64,
        #[serde(rename = "@y2")]
        y2: f64,
        #[serde(rename = "@radius")]
        radius: f64,
    },
    Polygon {
        #[serde(rename = "@x", default)]
        x: f64,
        #[serde(rename = "@y", default)]
        y: f64,
        #[serde(rename = "@rotation-deg", default)]
        rotation_deg: f64,
        #[serde(rename = "point", default)]
        points: Vec<PointXml>,
    },
}

fn two() -> f64 {
    2.0
}
fn one_u32() -> u32 {
    1
}

#[derive(Debug, Deserialize)]
struct PointXml {
    #[serde(rename = "@x")]
    x: f64,
    #[serde(rename = "@y")]
    y: f64,
}

/// A parsed scene.
#[derive(Debug)]
pub struct Scene {
    /// The world grid.
    pub grid: Grid,
    /// The obstacles.
    pub shapes: Vec<Obstacle>,
    /// The home base, if declared.
    pub home: Option<HomeBase>,
    /// Declared treasures.
    pub treasures: Vec<TreasureSpec>,
}

fn line_col(text: &str, offset: u64) -> (usize, usize) {
    let offset = (offset as usize).min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.split(|&b| b == b'\n').count();
    let col = offset - before.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1) + 1;
    (line, col)
}

/// What a scene's elements may hold: each element's name, its required and optional
/// attributes (all numbers; `quantity` a count), and the elements it may contain.
struct ElementForm {
    name: &'static str,
    required: &'static [&'static str],
    optional: &'static [&'static str],
    children: &'static [&'static str],
}

const SHAPES: &[&str] = &["home", "treasure", "disc", "rect", "capsule", "polygon"];

const FORMS: &[ElementForm] = &[
    ElementForm {
        name: "scene",
        required: &["width-m", "height-m"],
        optional: &["cell-m", "origin-x", "origin-y"],
        children: SHAPES,
    },
    ElementForm {
        name: "home",
        required: &["x", "y"],
        optional: &["radius"],
        children: &[],
    },
    ElementForm {
        name: "treasure",
        required: &["x", "y"],
        optional: &["quantity"],
        children: &[],
    },
    ElementForm {
        name: "disc",
        required: &["x", "y", "radius"],
        optional: &[],
        children: &[],
    },
    ElementForm {
        name: "rect",
        required: &["x", "y", "width", "height"],
        optional: &["rotation-deg"],
        children: &[],
    },
    ElementForm {
        name: "capsule",
        required: &["x1", "y1", "x2", "y2", "radius"],
        optional: &[],
        children: &[],
    },
    ElementForm {
        name: "polygon",
        required: &[],
        optional: &["x", "y", "rotation-deg"],
        children: &["point"],
    },
    ElementForm {
        name: "point",
        required: &["x", "y"],
        optional: &[],
        children: &[],
    },
];

/// Check the scene's text before reading it, so that each fault carries a line and column:
/// well-formed XML, known elements where they stand, each element's attributes known,
/// present when required and numbers. A misspelt attribute would otherwise be ignored.
fn check_xml(text: &str, path: &Path) -> Result<()> {
    let mut reader = quick_xml::Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut open: Vec<&ElementForm> = Vec::new();
    let at = |offset: u64, problem: String| {
        let (line, column) = line_col(text, offset);
        EditorError::Xml {
            path: path.to_path_buf(),
            line,
            column,
            problem,
        }
    };
    loop {
        let before = reader.buffer_position();
        // An element's fault is placed at its `<` (what precedes it may be white space).
        let lt = |before: u64| {
            let from = usize::try_from(before).unwrap_or(usize::MAX).min(text.len());
            (from + text[from..].find('<').unwrap_or(0)) as u64
        };
        match reader.read_event() {
            Ok(Event::Eof) => return Ok(()),
            Ok(Event::Start(e)) => {
                let form = check_element(&e, open.last().copied()).map_err(|p| at(lt(before), p))?;
                open.push(form);
            }
            Ok(Event::Empty(e)) => {
                check_element(&e, open.last().copied()).map_err(|p| at(lt(before), p))?;
            }
            Ok(Event::End(_)) => {
                open.pop();
            }
            Ok(_) => {}
            Err(e) => return Err(at(reader.error_position(), e.to_string())),
        }
    }
}

/// Check one element against its form where it stands (inside `parent`, or at the top);
/// returns its form, or what is wrong.
fn check_element(
    e: &quick_xml::events::BytesStart<'_>,
    parent: Option<&ElementForm>,
) -> std::result::Result<&'static ElementForm, String> {
    let name = e.name().as_ref().to_owned();
    let allowed: &[&str] = parent.map_or(&["scene"], |p| p.children);
    let form = FORMS
        .iter()
        .find(|f| f.name == name && allowed.contains(&f.name))
        .ok_or_else(|| {
            let listed: Vec<String> = allowed.iter().map(|a| format!("<{a}>")).collect();
            match parent {
                Some(p) if allowed.is_empty() => format!("<{}> holds no elements, found <{name}>", p.name),
                _ => format!("unknown element <{name}> (expected here: {})", listed.join(", ")),
            }
        })?;
    let mut seen = Vec::new();
    for attribute in e.attributes() {
        let attribute = attribute.map_err(|err| err.to_string())?;
        let key = attribute.key.as_ref().to_owned();
        let Some(&known) = form.required.iter().chain(form.optional).find(|&&k| k == key) else {
            let all: Vec<&str> = form.required.iter().chain(form.optional).copied().collect();
            return Err(format!(
                "<{name}> has no attribute `{key}` (its attributes: {})",
                all.join(", ")
            ));
        };
        let value = attribute
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| err.to_string())?;
        let number = if known == "quantity" {
            value.trim().parse::<u32>().is_ok()
        } else {
            value.trim().parse::<f64>().is_ok_and(f64::is_finite)
        };
        if !number {
            let kind = if known == "quantity" {
                "a whole number"
            } else {
                "a number"
            };
            return Err(format!("<{name}> {known} must be {kind}, got '{value}'"));
        }
        seen.push(known);
    }
    if let Some(missing) = form.required.iter().find(|r| !seen.contains(r)) {
        return Err(format!("<{name}> needs the attribute `{missing}`"));
    }
    Ok(form)
}

/// Parse scene XML text; `path` names the file in errors.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene> {
    check_xml(text, path)?;
    let raw: SceneXml = quick_xml::de::from_str(text)
        .map_err(|e| EditorError::bad_input(path, format!("scene does not match the expected form: {e}")))?;
    let bad = |p: String| EditorError::bad_input(path, p);
    let grid = Grid::from_size_m(
        DVec2::new(raw.origin_x, raw.origin_y),
        raw.cell_m,
        raw.width_m,
        raw.height_m,
    )
    .map_err(|e| bad(format!("world: {e}")))?;
    let world = grid.extent();
    let mut scene = Scene {
        grid,
        shapes: Vec::new(),
        home: None,
        treasures: Vec::new(),
    };
    for (i, item) in raw.items.into_iter().enumerate() {
        add_item(&mut scene, &world, i + 1, item).map_err(bad)?;
    }
    Ok(scene)
}

/// Add item `n` of a scene (counted from 1) to `scene`: its home base, a treasure or an
/// obstacle, each checked to lie inside `world`; the error says what is wrong with it.
fn add_item(scene: &mut Scene, world: &Aabb, n: usize, item: Item) -> Result<(), String> {
    match item {
        Item::Home { x, y, radius } => {
            let h = HomeBase::Disc {
                center: DVec2::new(x, y),
                radius_m: radius,
            };
            if !(radius > 0.0 && radius.is_finite() && world.contains_box(&h.bounds())) {
                return Err(format!(
                    "item {n} (home at {x}, {y}, radius {radius}) must be a positive-radius disc inside the world"
                ));
            }
            if scene.home.replace(h).is_some() {
                return Err(format!("item {n}: a second home base"));
            }
        }
        Item::Treasure { x, y, quantity } => {
            let p = DVec2::new(x, y);
            if !world.contains_box(&Aabb { min: p, max: p }) || quantity == 0 {
                return Err(format!(
                    "item {n} (treasure at {x}, {y}) must lie inside the world and have a quantity ≥ 1"
                ));
            }
            scene.treasures.push(TreasureSpec { position: p, quantity });
        }
        shape => scene.shapes.push(obstacle(shape, world, n)?),
    }
    Ok(())
}

/// The obstacle of shape item `n`, checked to be non-degenerate and to lie inside `world`;
/// the error says what is wrong with it.
fn obstacle(item: Item, world: &Aabb, n: usize) -> Result<Obstacle, String> {
    let (kind, built) = match item {
        Item::Disc { x, y, radius } => ("disc", Obstacle::disc(DVec2::new(x, y), radius)),
        Item::Rect {
            x,
            y,
            width,
            height,
            rotation_deg,
        } => (
            "rect",
            Obstacle::rect(DVec2::new(x, y), width, height, rotation_deg.to_radians()),
        ),
        Item::Capsule { x1, y1, x2, y2, radius } => (
            "capsule",
            Obstacle::capsule(DVec2::new(x1, y1), DVec2::new(x2, y2), radius),
        ),
        Item::Polygon {
            x,
            y,
            rotation_deg,
            points,
        } => {
            let pts: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.x, p.y)).collect();
            (
                "polygon",
                Obstacle::polygon(DVec2::new(x, y), &pts, rotation_deg.to_radians()),
            )
        }
        Item::Home { .. } | Item::Treasure { .. } => unreachable!("homes and treasures are not obstacles"),
    };
    let Some(s) = built else {
        return Err(format!(
            "item {n} ({kind}) is degenerate (non-positive size, fewer than 3 points, or a self-intersecting polygon)"
        ));
    };
    let b = s.bounds();
    if !world.contains_box(&Aabb {
        min: b.min + 2e-3,
        max: b.max - 2e-3,
    }) {
        return Err(format!(
            "item {n} ({kind}, spanning ({:.3}, {:.3})–({:.3}, {:.3})) reaches outside the world ({}, {})–({}, {})",
            b.min.x, b.min.y, b.max.x, b.max.y, world.min.x, world.min.y, world.max.x, world.max.y
        ));
    }
    Ok(s)
}

/// Rasterise a scene. Without a declared home base, one is chosen automatically.
pub fn compose(scene: Scene) -> Result<MapData> {
    let set = ShapeSet::new(scene.grid, scene.shapes);
    let obstacles = set.rasterise(&mut Progress::hidden());
    let home = match scene.home {
        Some(h) => h,
        None => crate::place::auto_home(&obstacles, 2.0)?,
    };
    Ok(MapData {
        obstacles,
        home,
        treasures: scene.treasures,
    })
}

/// Read, parse and rasterise the scene file at `path`.
pub fn compose_file(path: &Path) -> Result<MapData> {
    let bytes = std::fs::read(path).map_err(EditorError::io(path))?;
    let text = String::from_utf8(bytes).map_err(|_| EditorError::bad_input(path, "scene is not UTF-8 text"))?;
    let map = compose(parse_scene(&text, path)?)?;
    // A map `validate` would refuse (a home or treasure inside an obstacle) is not written.
    let problems = crate::validate::validate(&map);
    if !problems.is_empty() {
        let listed: Vec<String> = problems.iter().map(ToString::to_string).collect();
        return Err(EditorError::bad_input(
            path,
            format!("the scene's map would not be valid: {}", listed.join("; ")),
        ));
    }
    Ok(map)
}
