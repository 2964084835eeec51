//! `smartteams-editor`: build, import, validate and preview Smart Teams maps.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use editor::import::{ImportOptions, Unknown};
use editor::place::{PlaceOptions, Spread};
use editor::preview::PreviewOptions;
use sim_core::glam::DVec2;
use sim_core::spatial::NoPath;
use sim_core::world::{HomeBase, MapData};

/// `println!` that ends the process quietly once standard output's reader has gone
/// (`smartteams-editor stats map.stmap | head -1`), where `println!` would panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*)
            && e.kind() == std::io::ErrorKind::BrokenPipe
        {
            std::process::exit(0);
        }
    }};
}

#[derive(Parser)]
#[command(
    name = "smartteams-editor",
    version,
    about = "Build, import, check and draw Smart Teams maps"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate a map.
    #[command(allow_negative_numbers = true)]
    Generate(GenerateArgs),
    /// Import a bitmap (PNG/PGM/JPEG/BMP), a ROS map server YAML or a Moving AI .map.
    #[command(allow_negative_numbers = true)]
    Import(ImportArgs),
    /// Build a map from an XML scene of shapes.
    Compose {
        /// The scene file.
        scene: PathBuf,
        /// Output map file.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Set the home base and scatter treasures reachable from it.
    #[command(allow_negative_numbers = true)]
    Place {
        /// The map file.
        map: PathBuf,
        #[command(flatten)]
        place: PlaceArgs,
        /// Output map file (may be the input).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Check a map: exit status 1 with every problem listed (a damaged file included).
    Validate {
        /// The map file.
        map: PathBuf,
    },
    /// Print figures about a map.
    Stats {
        /// The map file.
        map: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// The shortest any-angle path between two points: its length in metres and waypoints
    /// in world coordinates. Exit status 1 when there is none.
    #[command(allow_negative_numbers = true)]
    Path {
        /// The map file.
        map: PathBuf,
        /// Start `X,Y` in metres.
        #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
        from: DVec2,
        /// Goal `X,Y` in metres.
        #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
        to: DVec2,
        /// Robot radius in metres; the path keeps it clear of obstacles. With 0 the path
        /// follows the Moving AI any-angle rules (it may touch obstacles).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        robot_radius_m: f64,
        /// Print JSON: `{"length_m": L, "waypoints": [[x, y], ...]}`.
        #[arg(long)]
        json: bool,
    },
    /// Draw a map as PNG.
    #[command(allow_negative_numbers = true)]
    Preview {
        /// The map file.
        map: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        output: PathBuf,
        /// Pixels along the map's longer side (default: one per cell, at most 4096).
        #[arg(long)]
        px: Option<u32>,
        /// Draw obstacles only (no home base, no treasures).
        #[arg(long)]
        obstacles_only: bool,
    },
}

#[derive(Args, Clone)]
struct PlaceArgs {
    /// Home base centre `X,Y` in metres (must be free).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    home: Option<DVec2>,
    /// Home base radius in metres (default 2; `place` takes it only with `--home`).
    #[arg(long)]
    home_radius_m: Option<f64>,
    /// Number of treasures to scatter.
    #[arg(long, default_value_t = 0)]
    treasures: u32,
    /// Keep the treasures already on the map.
    #[arg(long)]
    keep_treasures: bool,
    /// How treasures are spread.
    #[arg(long, value_enum, default_value_t = SpreadArg::Uniform)]
    spread: SpreadArg,
    /// Number of clusters (with `--spread clustered`; default 4).
    #[arg(long)]
    clusters: Option<u32>,
    /// Spread of a cluster in metres (with `--spread clustered`; default 5).
    #[arg(long)]
    cluster_sigma_m: Option<f64>,
    /// Treasure quantity, `N` or `MIN..MAX` (inclusive).
    #[arg(long, default_value = "1", value_parser = parse_range)]
    quantity: (u32, u32),
    /// Random seed for placement.
    #[arg(long = "place-seed", default_value_t = 1)]
    place_seed: u64,
}

/// `--clusters` by default.
const CLUSTERS: u32 = 4;

/// `--cluster-sigma-m` by default.
const CLUSTER_SIGMA_M: f64 = 5.0;

#[derive(Clone, Copy, ValueEnum)]
enum SpreadArg {
    Uniform,
    Clustered,
}

impl PlaceArgs {
    /// The home base radius asked for, m.
    fn home_radius_m(&self) -> f64 {
        self.home_radius_m.unwrap_or(PlaceOptions::default().home_radius_m)
    }

    /// Refuse options that would be ignored: cluster options without `--spread clustered`,
    /// and, where the map's home base is kept unless `--home` is given (`place`), a radius
    /// without `--home`.
    fn refuse_unused(&self, keeps_map_home: bool) -> Result<()> {
        if keeps_map_home && self.home.is_none() && self.home_radius_m.is_some() {
            anyhow::bail!(
                "--home-radius-m sizes the home base --home places; without --home the map's home base is kept"
            );
        }
        if matches!(self.spread, SpreadArg::Uniform) {
            let unused = [
                (self.clusters.is_some(), "--clusters"),
                (self.cluster_sigma_m.is_some(), "--cluster-sigma-m"),
            ];
            if let Some((_, option)) = unused.iter().find(|u| u.0) {
                anyhow::bail!("{option} applies only with --spread clustered");
            }
        }
        Ok(())
    }

    fn options(&self, auto_home: bool) -> PlaceOptions {
        PlaceOptions {
            home: self.home,
            auto_home,
            home_radius_m: self.home_radius_m(),
            treasures: self.treasures,
            keep_treasures: self.keep_treasures,
            spread: match self.spread {
                SpreadArg::Uniform => Spread::Uniform,
                SpreadArg::Clustered => Spread::Clustered {
                    clusters: self.clusters.unwrap_or(CLUSTERS),
                    sigma_m: self.cluster_sigma_m.unwrap_or(CLUSTER_SIGMA_M),
                },
            },
            quantity: self.quantity,
            seed: self.place_seed,
        }
    }
}

#[derive(Args)]
struct ImportArgs {
    /// The file to import.
    file: PathBuf,
    /// Metres per pixel (bitmaps; default 1; overrides a ROS or Moving AI resolution).
    #[arg(long)]
    resolution_m: Option<f64>,
    /// Bitmaps: a pixel darker than this grey value (0–255) is blocked (default 128).
    #[arg(long)]
    threshold: Option<u8>,
    /// Bitmaps: pixels at or above the threshold are blocked instead of those below it.
    #[arg(long)]
    invert: bool,
    /// ROS: what unknown cells become (default blocked).
    #[arg(long, value_enum)]
    unknown: Option<UnknownArg>,
    /// World position `X,Y` of the map's lower-left corner (bitmaps, Moving AI; default
    /// 0,0; a ROS map's YAML states its own).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    origin: Option<DVec2>,
    #[command(flatten)]
    place: PlaceArgs,
    /// Output map file.
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
enum UnknownArg {
    Blocked,
    Free,
}

#[derive(Args)]
struct GenerateArgs {
    /// The generator.
    #[arg(value_enum)]
    kind: GeneratorArg,
    /// Map width in metres.
    #[arg(long, default_value_t = 128.0)]
    width_m: f64,
    /// Map height in metres.
    #[arg(long, default_value_t = 128.0)]
    height_m: f64,
    /// Cell side in metres.
    #[arg(long, default_value_t = 1.0)]
    cell_m: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Target blocked fraction (noise, fractal, caves, mesas; generator default if absent).
    #[arg(long)]
    density: Option<f64>,
    /// Feature size in metres (fractal: noise wavelength; maze: corridor width; rooms: smallest room; mesas: largest mesa radius).
    #[arg(long)]
    scale_m: Option<f64>,
    /// Mesas: number of obstacles (default: enough for the density).
    #[arg(long)]
    count: Option<u64>,
    /// Hide the progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    place: PlaceArgs,
    /// Output map file.
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
enum GeneratorArg {
    Noise,
    Fractal,
    Caves,
    Maze,
    Rooms,
    Mesas,
}

fn parse_point(s: &str) -> Result<DVec2, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    match parts[..] {
        [x, y] => match (x.parse::<f64>(), y.parse::<f64>()) {
            (Ok(x), Ok(y)) if x.is_finite() && y.is_finite() => Ok(DVec2::new(x, y)),
            _ => Err(format!("expected X,Y with two numbers, got {s:?}")),
        },
        _ => Err(format!("expected X,Y, got {s:?}")),
    }
}

fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected N or MIN..MAX with positive integers, got {s:?}");
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (a, b.trim_start_matches('=')),
        None => (s, s),
    };
    let (a, b) = (
        a.trim().parse::<u32>().map_err(|_| bad())?,
        b.trim().parse::<u32>().map_err(|_| bad())?,
    );
    if a == 0 || a > b {
        return Err(bad());
    }
    Ok((a, b))
}

fn load(path: &Path) -> Result<MapData> {
    Ok(MapData::load(path)?)
}

fn save(map: &MapData, path: &Path) -> Result<()> {
    map.check()
        .map_err(|p| anyhow::anyhow!("refusing to write {}: {p}", path.display()))?;
    map.save(path)?;
    eprintln!(
        "wrote {} ({} leaves, {:.2} % blocked, {} treasures)",
        path.display(),
        map.obstacles.leaf_count(),
        100.0 * map.obstacles.blocked_area_m2() / (map.obstacles.grid().width_m() * map.obstacles.grid().height_m()),
        map.treasures.len()
    );
    Ok(())
}

fn with_placement(obstacles: sim_core::spatial::ObstacleMap, place: &PlaceArgs) -> Result<MapData> {
    place.refuse_unused(false)?;
    let home = editor::place::auto_home(&obstacles, place.home_radius_m())?;
    let mut map = MapData {
        obstacles,
        home,
        treasures: Vec::new(),
    };
    let placed = editor::place::place(&mut map, &place.options(false))?;
    warn_if_crowded(placed, place.treasures);
    if place.home.is_none()
        && let HomeBase::Disc { radius_m, .. } = map.home
        && radius_m < place.home_radius_m() * (1.0 - 1e-9)
    {
        eprintln!(
            "warning: the home base has radius {radius_m} m: no free disc of the {} m asked for fits, so it is the largest that does near the centre",
            place.home_radius_m()
        );
    }
    Ok(map)
}

/// Say so when more treasures were asked for than there are free cells reachable from the
/// home base: several then share each cell's centre.
fn warn_if_crowded(placed: editor::place::Placement, treasures: u32) {
    if let Some(cells) = placed.reachable_cells.filter(|&c| u64::from(treasures) > c) {
        eprintln!(
            "warning: {treasures} treasures on {cells} free cells reachable from the home base: several share each cell's centre"
        );
    }
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Generate(args) => generate_map(&args),
        Command::Import(args) => import_map(&args),
        Command::Compose { scene, output } => compose_map(&scene, &output),
        Command::Place {
            map: path,
            place,
            output,
        } => place_on_map(&path, &place, &output),
        Command::Validate { map: path } => Ok(validate_map(&path)),
        Command::Stats { map: path, json } => print_stats(&path, json),
        Command::Path {
            map: path,
            from,
            to,
            robot_radius_m,
            json,
        } => print_path(&path, from, to, robot_radius_m, json),
        Command::Preview {
            map: path,
            output,
            px,
            obstacles_only,
        } => draw_preview(&path, &output, px, obstacles_only),
    }
}

/// `generate`: generate the obstacles, place the home base and treasures, and save the map.
fn generate_map(args: &GenerateArgs) -> Result<ExitCode> {
    let obstacles = generate(args)?;
    let map = with_placement(obstacles, &args.place)?;
    save(&map, &args.output)?;
    Ok(ExitCode::SUCCESS)
}

/// `import`: import the obstacles from a file, place the home base and treasures, and save
/// the map.
fn import_map(args: &ImportArgs) -> Result<ExitCode> {
    refuse_unused_import_options(args)?;
    let defaults = ImportOptions::default();
    let opts = ImportOptions {
        resolution_m: args.resolution_m,
        threshold: args.threshold.unwrap_or(defaults.threshold),
        invert: args.invert,
        unknown: match args.unknown {
            None | Some(UnknownArg::Blocked) => Unknown::Blocked,
            Some(UnknownArg::Free) => Unknown::Free,
        },
        origin: args.origin.unwrap_or(defaults.origin),
    };
    let obstacles = editor::import::import(&args.file, &opts)?;
    let map = with_placement(obstacles, &args.place)?;
    save(&map, &args.output)?;
    Ok(ExitCode::SUCCESS)
}

/// Refuse the import options the file's format does not use (the format is the file
/// extension's, as `import` reads it): they would be ignored.
fn refuse_unused_import_options(args: &ImportArgs) -> Result<()> {
    use editor::import::Format;
    let format = Format::of(&args.file);
    let (bitmap, ros) = (format == Format::Bitmap, format == Format::Ros);
    let unused = [
        (args.threshold.is_some() && !bitmap, "--threshold", "bitmaps"),
        (args.invert && !bitmap, "--invert", "bitmaps"),
        (args.unknown.is_some() && !ros, "--unknown", "ROS maps"),
        (
            args.origin.is_some() && ros,
            "--origin",
            "bitmaps and Moving AI maps (a ROS map's YAML states its origin)",
        ),
    ];
    if let Some((_, option, applies)) = unused.iter().find(|u| u.0) {
        anyhow::bail!("{}: {option} applies only to {applies}", args.file.display());
    }
    Ok(())
}

/// `compose`: build the map of an XML scene and save it.
fn compose_map(scene: &Path, output: &Path) -> Result<ExitCode> {
    let map = editor::compose::compose_file(scene)?;
    save(&map, output)?;
    Ok(ExitCode::SUCCESS)
}

/// `place`: set the home base and treasures of the map at `path` and save it to `output`.
fn place_on_map(path: &Path, place: &PlaceArgs, output: &Path) -> Result<ExitCode> {
    place.refuse_unused(true)?;
    let mut map = load(path)?;
    let placed = editor::place::place(&mut map, &place.options(false))?;
    warn_if_crowded(placed, place.treasures);
    save(&map, output)?;
    Ok(ExitCode::SUCCESS)
}

/// `validate`: print "ok" or every problem of the map; exit status 1 when there are problems,
/// a damaged or unreadable file included.
fn validate_map(path: &Path) -> ExitCode {
    let map = match load(path) {
        Ok(map) => map,
        Err(e) => {
            say!("{e:#}");
            eprintln!("{}: not a valid map", path.display());
            return ExitCode::from(1);
        }
    };
    let problems = editor::validate::validate(&map);
    if problems.is_empty() {
        say!("{}: ok", path.display());
    } else {
        for p in &problems {
            say!("{}: {p}", path.display());
        }
        eprintln!("{}: {} problem(s)", path.display(), problems.len());
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}

/// `stats`: print the map's figures, as text or JSON.
fn print_stats(path: &Path, json: bool) -> Result<ExitCode> {
    let bytes = std::fs::metadata(path)
        .with_context(|| format!("cannot read {}", path.display()))?
        .len();
    let map = load(path)?;
    let s = editor::stats::stats(&map, bytes);
    if json {
        say!("{}", serde_json::to_string_pretty(&s)?);
    } else {
        say!("{s}");
    }
    Ok(ExitCode::SUCCESS)
}

/// `path`: print the shortest path from `from` to `to`; exit status 1 when there is none.
fn print_path(path: &Path, from: DVec2, to: DVec2, robot_radius_m: f64, json: bool) -> Result<ExitCode> {
    let map = load(path)?;
    let found = editor::path::shortest_path(&map.obstacles, from, to, robot_radius_m)
        .with_context(|| format!("{}: cannot plan paths", path.display()))?;
    match found {
        Ok(report) if json => say!("{}", serde_json::to_string(&report)?),
        Ok(report) => print!("{report}"),
        Err(no_path) => {
            let why = match no_path {
                NoPath::StartBlocked(p) => {
                    format!("start ({}, {}) is {}", p.x, p.y, why_blocked(&map, p, robot_radius_m))
                }
                NoPath::GoalBlocked(p) => {
                    format!("goal ({}, {}) is {}", p.x, p.y, why_blocked(&map, p, robot_radius_m))
                }
                other => other.to_string(),
            };
            eprintln!("{}: no path: {why}", path.display());
            return Ok(ExitCode::from(1));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Why the end `p` of a path is blocked, of the three reasons the planner does not tell
/// apart.
fn why_blocked(map: &MapData, p: DVec2, robot_radius_m: f64) -> String {
    let e = map.obstacles.grid().extent();
    if !(e.min.x..=e.max.x).contains(&p.x) || !(e.min.y..=e.max.y).contains(&p.y) {
        format!(
            "outside the map ({} to {} m east, {} to {} m north)",
            e.min.x, e.max.x, e.min.y, e.max.y
        )
    } else if !map.obstacles.is_point_free(p) {
        "inside an obstacle".to_owned()
    } else {
        format!("closer to an obstacle than the robot's radius ({robot_radius_m} m)")
    }
}

/// `preview`: draw the map (or its obstacles only) as a PNG at `output`.
fn draw_preview(path: &Path, output: &Path, px: Option<u32>, obstacles_only: bool) -> Result<ExitCode> {
    if !output.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        anyhow::bail!("{}: a preview is written as PNG: name it .png", output.display());
    }
    let map = load(path)?;
    let img = editor::preview::render(
        &map,
        &PreviewOptions {
            px,
            overlays: !obstacles_only,
        },
    )?;
    editor::preview::write_png(&img, output)?;
    eprintln!("wrote {} ({} × {} px)", output.display(), img.width(), img.height());
    Ok(ExitCode::SUCCESS)
}

fn generate(args: &GenerateArgs) -> Result<sim_core::spatial::ObstacleMap> {
    use editor::generate::{GenerateOptions, Kind};
    let kind = match args.kind {
        GeneratorArg::Noise => Kind::Noise,
        GeneratorArg::Fractal => Kind::Fractal,
        GeneratorArg::Caves => Kind::Caves,
        GeneratorArg::Maze => Kind::Maze,
        GeneratorArg::Rooms => Kind::Rooms,
        GeneratorArg::Mesas => Kind::Mesas,
    };
    let opts = GenerateOptions {
        width_m: args.width_m,
        height_m: args.height_m,
        cell_m: args.cell_m,
        seed: args.seed,
        density: args.density,
        scale_m: args.scale_m,
        count: args.count,
        progress: !args.quiet && std::io::IsTerminal::is_terminal(&std::io::stderr()),
    };
    let start = std::time::Instant::now();
    let map = editor::generate::generate(kind, &opts)?;
    eprintln!(
        "generated in {:.1} s: {} leaves ({} blocked)",
        start.elapsed().as_secs_f64(),
        map.leaf_count(),
        map.blocked_leaf_count()
    );
    Ok(map)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
