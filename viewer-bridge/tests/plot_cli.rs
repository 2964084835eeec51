//! `smartteams plot` as a user types it: figures of the requested size and format from
//! known CSVs, a line per group of runs, and clear errors for bad input.

use std::path::Path;
use std::process::{Command, Output};

fn smartteams(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smartteams"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Width and height from a PNG's header (signature, then the IHDR chunk).
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

/// Run 20 rounds of the demo config in `dir`, writing its metrics to `demo.csv`.
fn demo_metrics(dir: &Path) {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/demo.xml");
    let args = ["run", demo.to_str().unwrap(), "--rounds", "20", "--no-viewer", "-q"];
    let run = smartteams(dir, &[&args[..], &["--metrics", "demo.csv"]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
}

const SWEEP: &str = "run,seed,g.count,round,explored_fraction,treasures_delivered,mean_energy,known_map_bytes
0,1,4,1,0.1,0,10,1000
0,1,4,2,0.3,1,8,2000
1,1,8,1,0.2,0,10,1000
1,1,8,2,0.6,2,9,3000
2,2,4,1,0.3,0,10,1000
2,2,4,2,0.5,3,6,4000
3,2,8,1,0.2,0,10,1000
3,2,8,2,0.6,2,7,3000
";

#[test]
fn plot_draws_a_line_per_group_at_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("sweep.csv"), SWEEP).unwrap();
    let out = smartteams(d, &["plot", "sweep.csv", "-o", "fig.png", "--size", "900x700"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("4 charts, 2 lines each (4 runs): g.count=4 (2 runs); g.count=8 (2 runs)"),
        "{said}"
    );
    assert_eq!(png_size(&std::fs::read(d.join("fig.png")).unwrap()), (900, 700));

    // A run's own metrics CSV beside the sweep: one more line; SVG by the extension.
    demo_metrics(d);
    let out = smartteams(d, &["plot", "sweep.csv", "demo.csv", "-o", "fig.svg"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("4 charts, 3 lines each (5 runs)"), "{said}");
    assert!(said.contains("; demo"), "{said}");
    let svg = std::fs::read_to_string(d.join("fig.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("width=\"1400\"") && svg.contains("height=\"900\""));
}

/// Against distance walked: a run's metrics CSV has the column; a CSV without it is refused
/// by name.
#[test]
fn plot_against_distance_reads_the_distance_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    demo_metrics(d);
    let out = smartteams(d, &["plot", "demo.csv", "-o", "fig.svg", "--x", "distance"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let svg = std::fs::read_to_string(d.join("fig.svg")).unwrap();
    // Labels need a system font; without one the figure is drawn bare and says so.
    let labelled = !String::from_utf8_lossy(&out.stdout).contains("no font found");
    assert!(!labelled || svg.contains("distance walked"), "no distance axis");
    std::fs::write(d.join("sweep.csv"), SWEEP).unwrap();
    let out = smartteams(d, &["plot", "sweep.csv", "-o", "fig.png", "--x", "distance"]);
    assert!(!out.status.success());
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("sweep.csv") && said.contains("'distance_m'"), "{said}");
}

#[test]
fn plot_refuses_bad_input_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("sweep.csv"), SWEEP).unwrap();
    std::fs::write(d.join("old.csv"), "round,explored_fraction\n1,0.5\n").unwrap();
    std::fs::write(
        d.join("bad.csv"),
        SWEEP.replace("1,1,8,2,0.6,2,9,3000", "1,1,8,2,lots,2,9,3000"),
    )
    .unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["sweep.csv", "./sweep.csv", "-o", "f.png"],
            "./sweep.csv is given twice: its runs would count twice",
        ),
        (
            &["sweep.csv", "-o", "no/such/f.png"],
            "cannot write the figure no/such/f.png: the folder no/such does not exist",
        ),
        (
            &["old.csv", "-o", "f.png"],
            "old.csv:1: no 'treasures_delivered' column",
        ),
        (
            &["bad.csv", "-o", "f.png"],
            "bad.csv:5: explored_fraction must be a number, got 'lots'",
        ),
        (
            &["sweep.csv", "-o", "f.jpg"],
            "f.jpg: the figure is written as .png or .svg",
        ),
        (&["missing.csv", "-o", "f.png"], "missing.csv"),
        (
            &["sweep.csv", "-o", "f.png", "--size", "90x5"],
            "90 × 5 pixels makes no sense",
        ),
    ];
    for (args, want) in cases {
        let out = smartteams(d, &[&["plot"], args].concat());
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(want), "{args:?}: wanted '{want}', got: {err}");
    }
}

/// The points of every `<polyline>` of an SVG, in document order, with its stroke colour.
fn polylines(svg: &str) -> Vec<(String, Vec<(f64, f64)>)> {
    let attr = |tag: &str, name: &str| -> Option<String> {
        let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        Some(tag[start..].split('"').next()?.to_owned())
    };
    svg.split("<polyline")
        .skip(1)
        .map(|rest| {
            let tag = rest.split("/>").next().unwrap();
            let points = attr(tag, "points")
                .unwrap_or_default()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect();
            (attr(tag, "stroke").unwrap_or_default().to_uppercase(), points)
        })
        .collect()
}

/// The drawn lines carry the data: each group's mean over its seeds, worked out by hand
/// from `SWEEP`, read back from the SVG's polylines (pixel y grows downwards, linearly in
/// the value).
#[test]
fn plot_lines_are_the_means_of_each_group() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("sweep.csv"), SWEEP).unwrap();
    let out = smartteams(d, &["plot", "sweep.csv", "-o", "fig.svg"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let svg = std::fs::read_to_string(d.join("fig.svg")).unwrap();
    // The groups' lines in the first two colours (axes and ticks are black; the legend's
    // samples are 20 px level strokes), a point per round: four charts, g.count=4 then
    // g.count=8 in each.
    let (first, second) = ("#1F77B4", "#D62728");
    let legend =
        |p: &[(f64, f64)]| p.len() == 2 && (p[0].1 - p[1].1).abs() < 0.5 && (p[1].0 - p[0].0 - 20.0).abs() < 0.5;
    let lines: Vec<_> = polylines(&svg)
        .into_iter()
        .filter(|(colour, p)| (colour == first || colour == second) && !legend(p))
        .collect();
    assert_eq!(lines.len(), 8, "{lines:?}");
    assert!(lines.iter().all(|(_, p)| p.len() == 2), "{lines:?}");
    // Means at rounds 1 and 2: explored 0.2→0.4 and 0.2→0.6, delivered 0→2 and 0→2,
    // energy 10→7 and 10→8.
    for (chart, (a, b)) in [
        ((0.2, 0.4), (0.2, 0.6)),
        ((0.0, 2.0), (0.0, 2.0)),
        ((10.0, 7.0), (10.0, 8.0)),
    ]
    .into_iter()
    .enumerate()
    {
        let (g4, g8) = (&lines[2 * chart], &lines[2 * chart + 1]);
        assert_eq!((g4.0.as_str(), g8.0.as_str()), (first, second), "chart {chart}");
        let (p, q) = (&g4.1, &g8.1);
        assert_eq!((p[0].0, p[1].0), (q[0].0, q[1].0), "chart {chart}: same rounds");
        assert!(p[1].0 > p[0].0, "chart {chart}: round 2 right of round 1");
        // Equal values at round 1 sit at the same height.
        assert!((p[0].1 - q[0].1).abs() <= 1.0, "chart {chart}: {p:?} {q:?}");
        // The rises are in the ratio of the values' (pixels rounded: within 3 %).
        let (rise_p, rise_q) = (p[0].1 - p[1].1, q[0].1 - q[1].1);
        let want = (a.1 - a.0) / (b.1 - b.0);
        assert!(
            (rise_p / rise_q - want).abs() < 0.03 * want.abs().max(1.0),
            "chart {chart}: rises {rise_p} and {rise_q}, want ratio {want}"
        );
    }
}

/// A chart whose values are all 0 spans 0 to 1, so its ticks read apart (a span of nothing
/// labelled every tick 0.0).
#[test]
fn a_chart_of_zeros_has_ticks_that_read_apart() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv =
        "round,explored_fraction,treasures_delivered,mean_energy,known_map_bytes\n1,0.1,0,10,1000\n2,0.3,0,8,2000\n";
    std::fs::write(d.join("z.csv"), csv).unwrap();
    let out = smartteams(d, &["plot", "z.csv", "-o", "z.svg"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    if String::from_utf8_lossy(&out.stdout).contains("no font found") {
        return; // No labels to read without a system font.
    }
    let svg = std::fs::read_to_string(d.join("z.svg")).unwrap();
    // The texts of the treasures chart, from its title to the next chart's.
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| {
            t.split_once('>')
                .and_then(|(_, rest)| rest.split_once("</text>"))
                .map(|(s, _)| s.trim())
        })
        .collect();
    let start = texts.iter().position(|t| *t == "Treasures delivered").unwrap();
    let end = start
        + 1
        + texts[start + 1..]
            .iter()
            .position(|t| t.starts_with("Mean energy"))
            .unwrap();
    let ticks: std::collections::BTreeSet<&str> = texts[start..end]
        .iter()
        .copied()
        .filter(|t| t.parse::<f64>().is_ok())
        .collect();
    assert!(ticks.contains("0.5") && ticks.contains("1.0"), "{ticks:?}");
}
