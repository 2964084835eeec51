//! Charts as PNG or SVG (plotters): line charts for the scale suite, and the standard
//! figure of a study (`smartteams plot`): explored fraction, treasures delivered, energy
//! and known-map memory against rounds, one line per run or per group of runs, the mean
//! over seeds with a band of one standard deviation.
//!
//! Labels need a TrueType font: the first of the usual system fonts found is registered once;
//! with none, charts are drawn without text (and [`FigureSummary::labelled`] says so).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

/// A chart that could not be drawn, or an input that cannot be plotted: where and why.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct PlotError(pub String);

type Result<T> = std::result::Result<T, PlotError>;

/// Fonts tried for the labels, in order.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
];

/// One line: its legend and its points.
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
}

/// A line with an optional band around it (x, low, high).
struct Line {
    label: String,
    points: Vec<(f64, f64)>,
    band: Vec<(f64, f64, f64)>,
}

/// Whether a font for labels is registered (once per process).
fn font() -> bool {
    static FONT: OnceLock<bool> = OnceLock::new();
    *FONT.get_or_init(|| {
        let Some(bytes) = FONT_PATHS.iter().find_map(|p| std::fs::read(p).ok()) else {
            return false;
        };
        // The font lives as long as the process, as plotters requires.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
    })
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(0, 0, 0),
];

/// Draw one chart into `area`.
fn draw_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    lines: &[Line],
    markers: bool,
) -> Result<()> {
    let e = |e: &dyn std::fmt::Display| PlotError(e.to_string());
    let text = font();
    let (mut x_max, mut y_max) = (0.0f64, 0.0f64);
    for l in lines {
        for &(x, y) in &l.points {
            x_max = x_max.max(x);
            y_max = y_max.max(y);
        }
        for &(_, _, hi) in &l.band {
            y_max = y_max.max(hi);
        }
    }
    let mut builder = ChartBuilder::on(area);
    builder.margin(16).x_label_area_size(44).y_label_area_size(80);
    if text {
        builder.caption(title, ("sans-serif", 22));
    }
    let mut chart = builder
        // A chart of zeros spans 0 to 1: a span of nothing labels every tick 0.
        .build_cartesian_2d(
            0.0..x_max.max(1.0) * 1.02,
            0.0..if y_max > 0.0 { y_max * 1.08 } else { 1.0 },
        )
        .map_err(|x| e(&x))?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc(x_label).y_desc(y_label).label_style(("sans-serif", 14));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|x| e(&x))?;
    for (i, l) in lines.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        if l.band.len() > 1 {
            let outline: Vec<(f64, f64)> = l
                .band
                .iter()
                .map(|&(x, lo, _)| (x, lo))
                .chain(l.band.iter().rev().map(|&(x, _, hi)| (x, hi)))
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(outline, colour.mix(0.18).filled())))
                .map_err(|x| e(&x))?;
        }
        let series = chart
            .draw_series(LineSeries::new(l.points.iter().copied(), colour.stroke_width(2)))
            .map_err(|x| e(&x))?;
        if text {
            series
                .label(l.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
        }
        if markers {
            chart
                .draw_series(l.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|x| e(&x))?;
        }
    }
    if text && !lines.is_empty() {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|x| e(&x))?;
    }
    Ok(())
}

/// Draw `series` as lines with points into a 900 × 560 PNG at `path`.
pub fn line_chart(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<()> {
    let lines: Vec<Line> = series
        .iter()
        .map(|s| Line {
            label: s.label.to_owned(),
            points: s.points.clone(),
            band: Vec::new(),
        })
        .collect();
    let at = |e: &dyn std::fmt::Display| PlotError(format!("{}: {e}", path.display()));
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| at(&e))?;
    draw_chart(&root, title, x_label, y_label, &lines, true).map_err(|e| at(&e))?;
    root.present().map_err(|e| at(&e))
}

/// A metric the standard figure can draw: column, chart title, axis label, scale.
pub const FIGURE_METRICS: [(&str, &str, &str, f64); 4] = [
    (
        "explored_fraction",
        "Explored fraction",
        "explored fraction of the free area",
        1.0,
    ),
    ("treasures_delivered", "Treasures delivered", "treasures", 1.0),
    ("mean_energy", "Mean energy of live robots", "energy", 1.0),
    ("known_map_bytes", "Known-map memory, all robots", "MB", 1e-6),
];

/// What the standard figure's charts run along.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum XAxis {
    /// Rounds.
    #[default]
    Round,
    /// Metres walked by all robots (`distance_m`): at each round, the mean over the group's
    /// runs. Explored fraction against it says how far a strategy walks for what it finds.
    Distance,
}

impl XAxis {
    /// The axis label.
    fn label(self) -> &'static str {
        match self {
            XAxis::Round => "round",
            XAxis::Distance => "distance walked, all robots (m)",
        }
    }
}

/// What [`metrics_figure`] drew.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FigureSummary {
    /// Charts (one per metric).
    pub charts: usize,
    /// Lines on each chart (one per group of runs), with their labels.
    pub groups: Vec<String>,
    /// Runs read.
    pub runs: usize,
    /// Whether the labels were drawn (a font was found).
    pub labelled: bool,
}

/// Per round: the values of a metric in every run of a group.
type Samples = BTreeMap<u64, Vec<f64>>;

/// Read metrics or sweep CSVs: runs grouped by the columns before `round` other than `run`
/// and `seed` (the values a sweep varies), each file its own group when there are none.
/// Returns (group label, runs in it, per metric: per round samples).
fn read_groups(inputs: &[PathBuf], metrics: &[&str]) -> Result<Vec<(String, usize, Vec<Samples>)>> {
    // In order of first appearance (a sweep's grid order), not sorted as text.
    let mut groups: Vec<(String, std::collections::BTreeSet<String>, Vec<Samples>)> = Vec::new();
    let mut index: std::collections::HashMap<(usize, String), usize> = std::collections::HashMap::new();
    for (f, path) in inputs.iter().enumerate() {
        let at = |line: u64, m: String| PlotError(format!("{}:{line}: {m}", path.display()));
        let file = std::fs::File::open(path).map_err(|e| PlotError(format!("{}: {e}", path.display())))?;
        let mut reader = csv::Reader::from_reader(std::io::BufReader::new(file));
        let header = reader
            .headers()
            .map_err(|e| at(1, format!("not a metrics CSV: {e}")))?
            .clone();
        let column = |name: &str| header.iter().position(|h| h == name);
        let round = column("round").ok_or_else(|| at(1, "not a metrics CSV: no 'round' column".into()))?;
        let wanted: Vec<usize> = metrics
            .iter()
            .map(|m| column(m).ok_or_else(|| at(1, format!("no '{m}' column (written by older versions?)"))))
            .collect::<Result<_>>()?;
        let run_col = column("run").filter(|&c| c < round);
        let keys: Vec<usize> = (0..round)
            .filter(|&c| Some(c) != run_col && &header[c] != "seed")
            .collect();
        let stem = path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        for record in reader.records() {
            let record = record.map_err(|e| {
                at(
                    e.position().map_or(0, csv::Position::line),
                    format!("malformed CSV: {e}"),
                )
            })?;
            let line = record.position().map_or(0, csv::Position::line);
            let number = |c: usize| -> Result<f64> {
                record[c]
                    .parse::<f64>()
                    .map_err(|_| at(line, format!("{} must be a number, got '{}'", &header[c], &record[c])))
            };
            let r = number(round)? as u64;
            let label = if keys.is_empty() {
                stem.clone()
            } else {
                let values: Vec<String> = keys.iter().map(|&c| format!("{}={}", &header[c], &record[c])).collect();
                values.join(", ")
            };
            let run = run_col.map_or_else(String::new, |c| record[c].to_owned());
            let g = *index
                .entry((if keys.is_empty() { f } else { 0 }, label.clone()))
                .or_insert_with(|| {
                    groups.push((
                        label,
                        std::collections::BTreeSet::default(),
                        vec![Samples::new(); metrics.len()],
                    ));
                    groups.len() - 1
                });
            let (_, runs, samples) = &mut groups[g];
            runs.insert(format!("{f}/{run}"));
            for (s, &c) in samples.iter_mut().zip(&wanted) {
                s.entry(r).or_default().push(number(c)?);
            }
        }
    }
    if groups.is_empty() {
        return Err(PlotError("nothing to plot: the CSVs hold no rows".into()));
    }
    Ok(groups
        .into_iter()
        .map(|(label, runs, samples)| (label, runs.len(), samples))
        .collect())
}

/// Draw the standard figure of one or more metrics CSVs (from `smartteams run --metrics`)
/// or sweep CSVs into `output` (`.png` or `.svg`, `width` × `height` pixels): a chart per
/// metric of [`FIGURE_METRICS`] against `x`, a line per group of runs (the mean over its
/// seeds, with a band of ± one standard deviation when it has several).
pub fn metrics_figure(
    inputs: &[PathBuf],
    output: &Path,
    (width, height): (u32, u32),
    x: XAxis,
) -> Result<FigureSummary> {
    if inputs.is_empty() {
        return Err(PlotError("no CSV to plot".into()));
    }
    // One file twice would count its runs twice, as more seeds, and narrow the band.
    let files: Vec<PathBuf> = inputs.iter().map(|p| crate::run::file_identity(p)).collect();
    if let Some(k) = (0..files.len()).find(|&k| files[..k].contains(&files[k])) {
        let twice = inputs[k].display();
        return Err(PlotError(format!("{twice} is given twice: its runs would count twice")));
    }
    if let Some(message) = crate::missing_folder("figure", output) {
        return Err(PlotError(message));
    }
    if width < 200 || height < 200 || width > 20_000 || height > 20_000 {
        return Err(PlotError(format!(
            "a figure of {width} × {height} pixels makes no sense (200 to 20000 a side)"
        )));
    }
    let mut columns: Vec<&str> = FIGURE_METRICS.iter().map(|m| m.0).collect();
    if x == XAxis::Distance {
        columns.push("distance_m");
    }
    let groups = read_groups(inputs, &columns)?;
    let charts = chart_lines(&groups, x);
    match output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => draw_figure(
            &BitMapBackend::new(output, (width, height)).into_drawing_area(),
            output,
            &charts,
            x,
        )?,
        Some("svg") => draw_figure(
            &SVGBackend::new(output, (width, height)).into_drawing_area(),
            output,
            &charts,
            x,
        )?,
        _ => {
            return Err(PlotError(format!(
                "{}: the figure is written as .png or .svg (by its extension)",
                output.display()
            )));
        }
    }
    Ok(FigureSummary {
        charts: FIGURE_METRICS.len(),
        groups: charts[0].iter().map(|l| l.label.clone()).collect(),
        runs: groups.iter().map(|g| g.1).sum(),
        labelled: font(),
    })
}

/// Per metric of [`FIGURE_METRICS`], a line per group: the mean at each round, and the band
/// of ± one standard deviation (population) when the group has several runs; placed at the
/// round, or at the mean distance walked by then (the samples after the figure's metrics).
fn chart_lines(groups: &[(String, usize, Vec<Samples>)], x: XAxis) -> Vec<Vec<Line>> {
    let mean = |values: &[f64]| values.iter().sum::<f64>() / values.len() as f64;
    FIGURE_METRICS
        .iter()
        .enumerate()
        .map(|(m, &(_, _, _, scale))| {
            groups
                .iter()
                .map(|(label, runs, samples)| {
                    let mut points = Vec::new();
                    let mut band = Vec::new();
                    for (&round, values) in &samples[m] {
                        let n = values.len() as f64;
                        let y = mean(values);
                        let sd = (values.iter().map(|v| (v - y).powi(2)).sum::<f64>() / n).sqrt();
                        let x = match x {
                            XAxis::Round => round as f64,
                            XAxis::Distance => mean(&samples[FIGURE_METRICS.len()][&round]),
                        };
                        points.push((x, y * scale));
                        band.push((x, ((y - sd) * scale).max(0.0), (y + sd) * scale));
                    }
                    Line {
                        label: if *runs > 1 {
                            format!("{label} ({runs} runs)")
                        } else {
                            label.clone()
                        },
                        points,
                        band: if *runs > 1 { band } else { Vec::new() },
                    }
                })
                .collect()
        })
        .collect()
}

/// The four charts of [`metrics_figure`], two by two.
fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    output: &Path,
    charts: &[Vec<Line>],
    x: XAxis,
) -> Result<()> {
    let at = |e: &dyn std::fmt::Display| PlotError(format!("{}: {e}", output.display()));
    root.fill(&WHITE).map_err(|e| at(&e))?;
    for (area, (lines, &(_, title, y_label, _))) in
        root.split_evenly((2, 2)).iter().zip(charts.iter().zip(&FIGURE_METRICS))
    {
        draw_chart(area, title, x.label(), y_label, lines, false).map_err(|e| at(&e))?;
    }
    root.present().map_err(|e| at(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "run,seed,g.count,round,explored_fraction,treasures_delivered,mean_energy,known_map_bytes";

    #[test]
    fn a_sweeps_runs_are_grouped_by_what_it_varies_and_averaged_over_seeds() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("s.csv");
        // Two team sizes × two seeds, two rounds; values chosen so the means are exact.
        let rows = [
            "0,1,4,1,0.1,0,10,1000000",
            "0,1,4,2,0.3,1,8,2000000",
            "1,1,8,1,0.2,0,10,1000000",
            "1,1,8,2,0.6,2,9,3000000",
            "2,2,4,1,0.3,0,10,1000000",
            "2,2,4,2,0.5,3,6,4000000",
            "3,2,8,1,0.2,0,10,1000000",
            "3,2,8,2,0.6,2,7,3000000",
        ];
        std::fs::write(&sweep, format!("{HEADER}\n{}\n", rows.join("\n"))).unwrap();
        let single = dir.path().join("solo.csv");
        std::fs::write(
            &single,
            "round,explored_fraction,treasures_delivered,mean_energy,known_map_bytes\n1,0.5,0,3,500000\n",
        )
        .unwrap();
        let columns: Vec<&str> = FIGURE_METRICS.iter().map(|m| m.0).collect();
        let groups = read_groups(&[sweep, single], &columns).unwrap();
        let labels: Vec<(&str, usize)> = groups.iter().map(|g| (g.0.as_str(), g.1)).collect();
        assert_eq!(labels, [("g.count=4", 2), ("g.count=8", 2), ("solo", 1)]);
        let charts = chart_lines(&groups, XAxis::Round);
        // Explored, team of 4: rounds 1 and 2 average (0.1, 0.3) and (0.3, 0.5): 0.2 ± 0.1,
        // 0.4 ± 0.1.
        let explored = &charts[0][0];
        assert_eq!(explored.label, "g.count=4 (2 runs)");
        for (got, want) in explored.points.iter().zip([(1.0, 0.2), (2.0, 0.4)]) {
            assert!(
                (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
                "{got:?}"
            );
        }
        for (got, want) in explored.band.iter().zip([(1.0, 0.1, 0.3), (2.0, 0.3, 0.5)]) {
            assert!(
                (got.1 - want.1).abs() < 1e-12 && (got.2 - want.2).abs() < 1e-12,
                "{got:?}"
            );
        }
        // Team of 8: both seeds agree, so no spread; delivered 2 at round 2.
        assert_eq!(charts[1][1].points, [(1.0, 0.0), (2.0, 2.0)]);
        assert!(charts[1][1].band.iter().all(|&(_, lo, hi)| (hi - lo).abs() < 1e-12));
        // Memory in MB: team of 4 at round 2, mean of 2 and 4 MB.
        assert!((charts[3][0].points[1].1 - 3.0).abs() < 1e-12);
        // A lone run has no band.
        assert!(charts[2][2].band.is_empty());
        assert_eq!(charts[2][2].points, [(1.0, 3.0)]);
    }

    /// Against distance: each round's point sits at the group's mean distance walked by then.
    /// Two seeds walked 10 and 30 m by round 1, 20 and 60 m by round 2: x = 20 and 40 m; their
    /// explored fractions 0.1 and 0.3, then 0.2 and 0.6: y = 0.2 and 0.4.
    #[test]
    fn against_distance_each_point_sits_at_the_mean_distance_walked() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("s.csv");
        std::fs::write(
            &sweep,
            "run,seed,round,explored_fraction,treasures_delivered,mean_energy,known_map_bytes,distance_m\n\
             0,1,1,0.1,0,10,1,10\n0,1,2,0.2,0,10,1,20\n1,2,1,0.3,0,10,1,30\n1,2,2,0.6,0,10,1,60\n",
        )
        .unwrap();
        let mut columns: Vec<&str> = FIGURE_METRICS.iter().map(|m| m.0).collect();
        columns.push("distance_m");
        let groups = read_groups(&[sweep], &columns).unwrap();
        let charts = chart_lines(&groups, XAxis::Distance);
        let explored = &charts[0][0];
        for (got, want) in explored.points.iter().zip([(20.0, 0.2), (40.0, 0.4)]) {
            assert!(
                (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
                "{got:?}"
            );
        }
        assert_eq!(explored.points.len(), 2);
        assert!((explored.band[1].0 - 40.0).abs() < 1e-12);
    }
}
