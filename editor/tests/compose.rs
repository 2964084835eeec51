//! Scene rasterisation checked against parry2d queries on every cell, and scene errors.

use std::path::Path;

use editor::EditorError;
use editor::compose::{compose, parse_scene};
use editor::shapes::TOUCH_EPS;
use parry2d::math::{Pose, Vector};
use parry2d::shape::Cuboid;

const SCENE: &str = r#"<?xml version="1.0"?>
<scene width-m="40" height-m="30" cell-m="1" origin-x="-5" origin-y="2">
  <home x="0" y="6" radius="1.5"/>
  <treasure x="30" y="25" quantity="4"/>
  <disc x="10.3" y="12.7" radius="3.2"/>
  <rect x="22" y="8" width="9" height="2.5" rotation-deg="33"/>
  <rect x="0" y="25" width="4" height="4"/>
  <capsule x1="-2" y1="15" x2="8" y2="22.5" radius="0.8"/>
  <polygon x="25" y="20" rotation-deg="-20">
    <point x="0" y="0"/><point x="7" y="0"/><point x="7" y="6"/><point x="5" y="6"/>
    <point x="5" y="2"/><point x="2" y="2"/><point x="2" y="6"/><point x="0" y="6"/>
  </polygon>
  <polygon x="30" y="6"><point x="0" y="0"/><point x="4" y="1"/><point x="1" y="4"/></polygon>
</scene>"#;

#[test]
fn rasterisation_matches_parry_on_every_cell() {
    let scene = parse_scene(SCENE, Path::new("scene.xml")).unwrap();
    let shapes = scene.shapes.clone();
    let grid = scene.grid;
    let map = compose(scene).unwrap();
    assert_eq!(shapes.len(), 6);
    let mut blocked_cells = 0;
    let mut borderline = 0;
    for y in 0..grid.height_cells() {
        for x in 0..grid.width_cells() {
            let cell = grid.square(x, y, 0);
            let c = cell.center();
            let half = 0.5 - TOUCH_EPS;
            let cuboid = Cuboid::new(Vector::new(half as f32, half as f32));
            // Brute force with parry2d's distance query, one shape at a time. parry2d is f32 and
            // its intersection test has a tolerance of ~1e-4 m, so cells whose distance to a
            // shape is within 1e-3 m of touching may go either way; all others must agree.
            let d = shapes
                .iter()
                .map(|s| {
                    parry2d::query::distance(&Pose::identity(), &cuboid, &s.pose_from(c), s.shape().as_ref())
                        .unwrap()
                        .distance
                })
                .fold(f32::INFINITY, f32::min);
            let touched = d <= 0.0;
            let blocked = map.obstacles.tree().cell_value(x, y);
            if touched || d > 1e-3 {
                assert_eq!(blocked, touched, "cell ({x}, {y}) at distance {d}");
            } else {
                borderline += 1;
            }
            blocked_cells += u32::from(blocked);
            // Point queries: any sample point of the cell inside a shape ⇒ blocked.
            for k in 0..25 {
                let p =
                    cell.min + sim_core::glam::DVec2::new(0.1 + 0.2 * f64::from(k % 5), 0.1 + 0.2 * f64::from(k / 5));
                let inside = shapes.iter().any(|s| {
                    let q = s.pose_from(c);
                    let local = p - c;
                    s.shape()
                        .contains_point(&q, Vector::new(local.x as f32, local.y as f32))
                });
                if inside {
                    assert!(touched, "cell ({x}, {y}) has a point inside a shape but is free");
                }
            }
        }
    }
    assert!(blocked_cells > 100);
    assert!(borderline < 60, "{borderline} borderline cells");
    // The axis-aligned square [-2, 2] × [23, 27] blocks exactly cells 3..7 × 21..25: a shape
    // edge lying on a cell border does not block the neighbour.
    for y in 19..27 {
        for x in 1..9 {
            let inside = (3..7).contains(&x) && (21..25).contains(&y);
            assert_eq!(
                map.obstacles.tree().cell_value(x, y),
                inside,
                "cell ({x}, {y}) near the square"
            );
        }
    }
    // The concave polygon's notch (local (3.5, 4), rotated −20° about (25, 20)) stays free.
    let (s, co) = ((-20f64).to_radians().sin(), (-20f64).to_radians().cos());
    let notch = sim_core::glam::DVec2::new(25.0 + 3.5 * co - 4.0 * s, 20.0 + 3.5 * s + 4.0 * co);
    assert!(map.obstacles.is_point_free(notch), "{notch}");
    assert_eq!(map.treasures.len(), 1);
    assert!(editor::validate::validate(&map).is_empty());
}

#[test]
fn scene_errors_name_the_file_and_place() {
    let bad_xml = "<scene width-m=\"10\" height-m=\"10\">\n  <disc x=\"1\" y=\"1\" radius=\"1\">\n</scene>\n";
    let e = parse_scene(bad_xml, Path::new("broken.xml")).unwrap_err();
    match &e {
        EditorError::Xml { line, column, .. } => assert!(*line >= 2 && *column >= 1, "{e}"),
        other => panic!("expected an XML error, got {other:?}"),
    }
    assert!(e.to_string().starts_with("broken.xml:"), "{e}");

    let outside = "<scene width-m=\"10\" height-m=\"10\"><disc x=\"9\" y=\"5\" radius=\"2\"/></scene>";
    let e = parse_scene(outside, Path::new("out.xml")).unwrap_err().to_string();
    assert!(e.contains("out.xml") && e.contains("outside the world"), "{e}");

    let missing = "<scene width-m=\"10\" height-m=\"10\"><disc x=\"5\" y=\"5\"/></scene>";
    let e = parse_scene(missing, Path::new("missing.xml")).unwrap_err().to_string();
    assert!(e.contains("missing.xml") && e.contains("radius"), "{e}");

    let degenerate = "<scene width-m=\"10\" height-m=\"10\"><polygon><point x=\"1\" y=\"1\"/></polygon></scene>";
    let e = parse_scene(degenerate, Path::new("deg.xml")).unwrap_err().to_string();
    assert!(e.contains("deg.xml") && e.contains("degenerate"), "{e}");

    let treasure = "<scene width-m=\"10\" height-m=\"10\"><treasure x=\"50\" y=\"5\"/></scene>";
    let e = parse_scene(treasure, Path::new("t.xml")).unwrap_err().to_string();
    assert!(e.contains("t.xml") && e.contains("treasure"), "{e}");
}

/// A misspelt attribute or element, a value that is no number and a missing attribute are
/// refused at their element's line and column, with what the element may hold (a misspelt
/// optional attribute was ignored: the shape was built without it).
#[test]
fn scene_faults_are_placed_at_their_element() {
    let scene = |body: &str| format!("<scene width-m=\"10\" height-m=\"10\">\n  {body}\n</scene>\n");
    let cases = [
        (
            r#"<rect x="5" y="5" width="2" height="1" rotaton-deg="30"/>"#,
            "s.xml:2:3: <rect> has no attribute `rotaton-deg` (its attributes: x, y, width, height, rotation-deg)",
        ),
        (
            r#"<dsc x="5" y="5" radius="1"/>"#,
            "s.xml:2:3: unknown element <dsc> (expected here: <home>, <treasure>, <disc>, <rect>, <capsule>, <polygon>)",
        ),
        (
            r#"<home x="1O" y="5"/>"#,
            "s.xml:2:3: <home> x must be a number, got '1O'",
        ),
        (
            r#"<disc x="5" y="5"/>"#,
            "s.xml:2:3: <disc> needs the attribute `radius`",
        ),
        (
            r#"<treasure x="5" y="5" quantity="-2"/>"#,
            "s.xml:2:3: <treasure> quantity must be a whole number, got '-2'",
        ),
        (
            r#"<polygon><point x="1" y="1"/><disc x="5" y="5" radius="1"/></polygon>"#,
            "s.xml:2:32: unknown element <disc> (expected here: <point>)",
        ),
    ];
    for (body, expected) in cases {
        let e = parse_scene(&scene(body), Path::new("s.xml")).unwrap_err().to_string();
        assert_eq!(e, expected);
    }
}
