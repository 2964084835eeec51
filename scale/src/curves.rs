//! `smartteams-bench curves`: runs `smartteams-bench swarm --csv-row` once per point, each
//! in its own process, and writes the curves as CSV and PNG.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};
use scale::Measurement;
use scale::plot::{Series, line_chart};

/// One point: the swarm's arguments and the parsed measurement row.
fn point(args: &[String]) -> Result<Vec<String>> {
    let exe = std::env::current_exe().context("cannot find this program to run the points")?;
    eprintln!("curves: swarm {}", args.join(" "));
    let out = Command::new(&exe)
        .arg("swarm")
        .args(args)
        .arg("--csv-row")
        .output()
        .with_context(|| format!("cannot run {}", exe.display()))?;
    if !out.status.success() {
        bail!(
            "swarm {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let row: Vec<String> = text.trim().split(',').map(str::to_owned).collect();
    if row.len() != Measurement::COLUMNS.len() {
        bail!("swarm {} printed an unexpected row: {}", args.join(" "), text.trim());
    }
    Ok(row)
}

fn swarm_args(robots: u32, mesas: u64, rounds: u64, threads: usize) -> Vec<String> {
    // Room at home for the crowd: about 0.3 m² a robot, never under the paper's 10 m.
    let home = (0.3 * f64::from(robots).sqrt()).max(10.0);
    vec![
        "--robots".into(),
        robots.to_string(),
        "--mesas".into(),
        mesas.to_string(),
        "--home-radius-m".into(),
        format!("{home:.1}"),
        "--rounds".into(),
        rounds.to_string(),
        "--threads".into(),
        threads.to_string(),
    ]
}

fn write_csv(path: &Path, extra: &str, rows: &[(String, Vec<String>)]) -> Result<()> {
    let mut w = csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    let mut header = vec![extra.to_owned()];
    header.extend(Measurement::COLUMNS.iter().map(|c| (*c).to_owned()));
    w.write_record(&header)?;
    for (key, row) in rows {
        let mut r = vec![key.clone()];
        r.extend(row.iter().cloned());
        w.write_record(&r)?;
    }
    w.flush()?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// The field `name` (one of [`Measurement::COLUMNS`]) of a measurement row.
fn field<'a>(row: &'a [String], name: &str) -> &'a str {
    let i = Measurement::COLUMNS
        .iter()
        .position(|c| *c == name)
        .expect("known column");
    &row[i]
}

fn column(rows: &[(String, Vec<String>)], x: &str, y: &str, scale: f64) -> Vec<(f64, f64)> {
    rows.iter()
        .filter_map(|(_, r)| {
            Some((
                field(r, x).parse::<f64>().ok()?,
                field(r, y).parse::<f64>().ok()? * scale,
            ))
        })
        .collect()
}

/// Run the curves and write them into `out`.
pub fn run(out: &Path, max_robots: u32, plots: bool) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut by_robots = Vec::new();
    for robots in [100, 300, 1_000, 3_000, 10_000]
        .into_iter()
        .filter(|&n| n <= max_robots)
    {
        let rounds = if robots > 3_000 { 20 } else { 50 };
        by_robots.push((robots.to_string(), point(&swarm_args(robots, 6_000, rounds, 0))?));
    }
    write_csv(&out.join("robots.csv"), "swarm_robots", &by_robots)?;
    let mut by_leaves = Vec::new();
    for mesas in [500, 6_000, 50_000] {
        by_leaves.push((mesas.to_string(), point(&swarm_args(1_000, mesas, 50, 0))?));
    }
    write_csv(&out.join("leaves.csv"), "mesas", &by_leaves)?;
    let mut threads = Vec::new();
    for t in [1, 2] {
        threads.push((t.to_string(), point(&swarm_args(1_000, 6_000, 100, t))?));
    }
    write_csv(&out.join("threads.csv"), "threads", &threads)?;
    let rate = |r: &[String]| field(r, "rounds_per_s").parse::<f64>().unwrap_or(f64::NAN);
    let digest = |r: &[String]| field(r, "digest").to_owned();
    let speedup = rate(&threads[1].1) / rate(&threads[0].1);
    let same = digest(&threads[0].1) == digest(&threads[1].1);
    println!(
        "1 → 2 threads: {speedup:.2}× ({:.1} → {:.1} rounds/s), {} results",
        rate(&threads[0].1),
        rate(&threads[1].1),
        if same { "identical" } else { "DIFFERENT" }
    );
    if !same {
        bail!(
            "1 and 2 threads gave different results (digests {} and {})",
            digest(&threads[0].1),
            digest(&threads[1].1)
        );
    }
    if plots {
        let mb = 1e-6;
        line_chart(
            &out.join("robots-speed.png"),
            "Swarm on 1.37 M leaves: time per robot-round",
            "robots",
            "µs per robot-round",
            &[Series {
                label: "2 threads",
                points: column(&by_robots, "robots", "us_per_robot_round", 1.0),
            }],
        )?;
        line_chart(
            &out.join("robots-memory.png"),
            "Swarm on 1.37 M leaves: peak memory",
            "robots",
            "MB (peak RSS)",
            &[Series {
                label: "peak RSS",
                points: column(&by_robots, "robots", "peak_rss_bytes", mb),
            }],
        )?;
        line_chart(
            &out.join("leaves.png"),
            "1,000 robots: rounds per second against map leaves",
            "leaves",
            "rounds per second",
            &[Series {
                label: "2 threads",
                points: column(&by_leaves, "leaves", "rounds_per_s", 1.0),
            }],
        )?;
        eprintln!("wrote the plots in {}", out.display());
    }
    Ok(())
}
