//! Opt-in (`SMARTTEAMS_DATA`, see `../shared/data/README.md`): every importer through the
//! `smartteams-editor` binary on every real map there, with the placement options a user would
//! add (treasures, quantities, clustered spread, a smaller or an explicit home base, ROS
//! `--unknown free`), then `validate`, `stats --json` and `preview` on each output, also
//! through the binary. Expected figures come from the raw files, read here without the
//! editor: sizes from the headers, blocked cells from the characters or pixels (the ROS rule
//! from the YAML's thresholds), free components by an independent flood fill.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec2;
use sim_core::world::{HomeBase, MapData};

/// A real map as this test reads it.
struct Raw {
    /// The file handed to `import`.
    file: PathBuf,
    /// Flags `import` needs for it (the Stage bitmap's resolution).
    flags: Vec<String>,
    width: u32,
    height: u32,
    cell_m: f64,
    origin: DVec2,
    /// `blocked[row * width + col]`, row 0 at the top; ROS unknown cells are blocked.
    blocked: Vec<bool>,
    /// ROS only: the same with unknown cells free (`--unknown free`).
    blocked_unknown_free: Option<Vec<bool>>,
}

fn movingai(data: &Path, file: &str) -> Raw {
    let path = data.join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    // `str::lines` also drops the `\r` of CRLF files (Berlin).
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "type octile", "{file}");
    let height: u32 = lines[1].strip_prefix("height ").unwrap().parse().unwrap();
    let width: u32 = lines[2].strip_prefix("width ").unwrap().parse().unwrap();
    assert_eq!(lines[3], "map", "{file}");
    let rows = &lines[4..4 + height as usize];
    let blocked = rows
        .iter()
        .flat_map(|l| {
            assert_eq!(l.len(), width as usize, "{file}");
            l.bytes().map(|c| !matches!(c, b'.' | b'G' | b'S'))
        })
        .collect();
    Raw {
        file: path,
        flags: vec![],
        width,
        height,
        cell_m: 1.0,
        origin: DVec2::ZERO,
        blocked,
        blocked_unknown_free: None,
    }
}

fn ros(data: &Path, yaml: &str) -> Raw {
    let path = data.join(yaml);
    let text = std::fs::read_to_string(&path).unwrap();
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key)?.strip_prefix(':'))
            .map(str::trim)
    };
    let num = |key: &str| -> f64 { field(key).unwrap().parse().unwrap() };
    let origin: Vec<f64> = field("origin")
        .unwrap()
        .trim_matches(['[', ']'])
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert!(origin[2].abs() < f64::EPSILON, "{yaml}: no yaw");
    assert_eq!(field("negate"), Some("0"), "{yaml}");
    assert!(matches!(field("mode"), None | Some("trinary")), "{yaml}");
    let (occupied, free) = (num("occupied_thresh"), num("free_thresh"));
    let image = path.parent().unwrap().join(field("image").unwrap());
    let (width, height, pixels) = common::read_pgm(&std::fs::read(image).unwrap());
    // p = (255 − v) / 255; occupied when p > occupied_thresh, free when p < free_thresh.
    let p = |v: u8| (255.0 - f64::from(v)) / 255.0;
    Raw {
        file: path,
        flags: vec![],
        width,
        height,
        cell_m: num("resolution"),
        origin: DVec2::new(origin[0], origin[1]),
        blocked: pixels.iter().map(|&v| p(v) >= free).collect(),
        blocked_unknown_free: Some(pixels.iter().map(|&v| p(v) > occupied).collect()),
    }
}

fn stage(data: &Path) -> Raw {
    let path = data.join("images/stage/cave.png");
    let img = image::open(&path).unwrap().into_luma8();
    // 16 m × 16 m in its Stage world file; a pixel darker than 128 is blocked (the default).
    let cell_m = 16.0 / f64::from(img.width());
    Raw {
        file: path,
        flags: vec!["--resolution-m".into(), cell_m.to_string()],
        width: img.width(),
        height: img.height(),
        cell_m,
        origin: DVec2::ZERO,
        blocked: img.pixels().map(|p| p.0[0] < 128).collect(),
        blocked_unknown_free: None,
    }
}

impl Raw {
    fn cells(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Index into `blocked` of the cell holding world point `p` (half-open cells).
    fn index_of(&self, p: DVec2) -> usize {
        let c = ((p - self.origin) / self.cell_m).floor();
        assert!(c.x >= 0.0 && c.y >= 0.0 && c.x < f64::from(self.width) && c.y < f64::from(self.height));
        let row = self.height - 1 - c.y as u32;
        row as usize * self.width as usize + c.x as usize
    }

    /// World centre of cell `(col, row)` (row 0 at the top).
    fn center_of(&self, col: u32, row: u32) -> DVec2 {
        self.origin + (DVec2::new(f64::from(col), f64::from(self.height - 1 - row)) + 0.5) * self.cell_m
    }

    /// Whether a disc stays inside the map and overlaps no blocked cell (a cell touched
    /// within a billionth of a cell counts as not overlapped).
    fn disc_free(&self, blocked: &[bool], c: DVec2, r: f64) -> bool {
        let eps = 1e-9;
        let lo = (c - self.origin - r) / self.cell_m;
        let hi = (c - self.origin + r) / self.cell_m;
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        if lo.x < -eps || lo.y < -eps || hi.x > w + eps || hi.y > h + eps {
            return false;
        }
        let span = |a: f64, b: f64, n: u32| (a.floor().max(0.0) as u32)..=(b.floor() as u32).min(n - 1);
        for y in span(lo.y, hi.y, self.height) {
            for x in span(lo.x, hi.x, self.width) {
                let min = self.origin + DVec2::new(f64::from(x), f64::from(y)) * self.cell_m;
                let q = c.clamp(min, min + self.cell_m);
                let row = (self.height - 1 - y) as usize;
                if q.distance(c) < r - eps * self.cell_m && blocked[row * self.width as usize + x as usize] {
                    return false;
                }
            }
        }
        true
    }

    /// The centre of the free 5 × 5 block of cells nearest the map's centre: a disc of two
    /// cells' radius there is free.
    fn free_spot(&self, blocked: &[bool]) -> DVec2 {
        let (w, h) = (self.width, self.height);
        let middle = self.origin + DVec2::new(f64::from(w), f64::from(h)) * self.cell_m / 2.0;
        let free_block = |col: u32, row: u32| {
            (row - 2..=row + 2).all(|r| (col - 2..=col + 2).all(|c| !blocked[(r * w + c) as usize]))
        };
        (2..h - 2)
            .flat_map(|row| (2..w - 2).map(move |col| (col, row)))
            .filter(|&(col, row)| free_block(col, row))
            .map(|(col, row)| self.center_of(col, row))
            .min_by(|a, b| a.distance(middle).total_cmp(&b.distance(middle)))
            .expect("a free 5 × 5 block")
    }
}

/// 4-connected components of the free cells: a label per cell (`u32::MAX` when blocked) and
/// each label's size.
fn components(raw: &Raw, blocked: &[bool]) -> (Vec<u32>, Vec<usize>) {
    let (w, h) = (raw.width as usize, raw.height as usize);
    let mut label = vec![u32::MAX; w * h];
    let mut sizes = Vec::new();
    for start in 0..w * h {
        if blocked[start] || label[start] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        let (mut stack, mut size) = (vec![start], 0);
        label[start] = id;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % w, i / w);
            let next = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in next.into_iter().flatten() {
                if !blocked[j] && label[j] == u32::MAX {
                    label[j] = id;
                    stack.push(j);
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

fn editor() -> Command {
    Command::new(env!("CARGO_BIN_EXE_smartteams-editor"))
}

fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !err.contains("panicked"),
        "{cmd:?}: {:?}\n{}\n{err}",
        out.status,
        String::from_utf8_lossy(&out.stdout)
    );
    out
}

/// What one import should give.
struct Expect<'a> {
    what: String,
    blocked: &'a [bool],
    treasures: u64,
    quantity: (u64, u64),
    /// `Some((centre, radius))` for `--home`; `None`: automatic, at most `home_radius_m`.
    home: Option<(DVec2, f64)>,
    home_radius_m: f64,
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

/// `stats --json` against the raw file.
fn check_stats(raw: &Raw, map_path: &Path, e: &Expect, map: &MapData) {
    let out = run_ok(editor().args(["stats", "--json"]).arg(map_path));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |key: &str| v[key].as_f64().unwrap_or_else(|| panic!("{}: {key} in {v}", e.what));
    let what = &e.what;
    assert_eq!(v["width_cells"].as_u64(), Some(u64::from(raw.width)), "{what}");
    assert_eq!(v["height_cells"].as_u64(), Some(u64::from(raw.height)), "{what}");
    assert!(close(f("cell_m"), raw.cell_m), "{what}");
    assert!(close(f("width_m"), f64::from(raw.width) * raw.cell_m), "{what}");
    assert!(close(f("height_m"), f64::from(raw.height) * raw.cell_m), "{what}");
    let origin = [v["origin"][0].as_f64().unwrap(), v["origin"][1].as_f64().unwrap()];
    assert!(
        close(origin[0], raw.origin.x) && close(origin[1], raw.origin.y),
        "{what}"
    );
    let blocked = e.blocked.iter().filter(|&&b| b).count();
    let cell_area = raw.cell_m * raw.cell_m;
    assert!(
        close(f("blocked_area_m2"), blocked as f64 * cell_area),
        "{what}: {blocked} cells"
    );
    let free = raw.cells() - blocked;
    assert!(
        close(f("free_area_m2"), free as f64 * cell_area),
        "{what}: {free} cells"
    );
    assert!(
        close(f("blocked_fraction"), blocked as f64 / raw.cells() as f64),
        "{what}"
    );
    assert_eq!(v["treasures"].as_u64(), Some(e.treasures), "{what}");
    let q = v["treasure_quantity"].as_u64().unwrap();
    assert!(
        (e.treasures * e.quantity.0..=e.treasures * e.quantity.1).contains(&q),
        "{what}: {q}"
    );
    let file_bytes = std::fs::metadata(map_path).unwrap().len();
    assert_eq!(v["file_bytes"].as_u64(), Some(file_bytes), "{what}");
    let home = [
        v["home_center"][0].as_f64().unwrap(),
        v["home_center"][1].as_f64().unwrap(),
    ];
    let c = map.home.center();
    assert!(close(home[0], c.x) && close(home[1], c.y), "{what}: {home:?} vs {c}");
}

/// The home base and treasures of the written map against the raw raster.
fn check_placement(raw: &Raw, e: &Expect, map: &MapData) {
    let what = &e.what;
    let HomeBase::Disc { center, radius_m } = map.home else {
        panic!("{what}: home is not a disc: {:?}", map.home);
    };
    match e.home {
        Some((c, r)) => assert_eq!((center, radius_m), (c, r), "{what}"),
        None => assert!(
            radius_m > 0.0 && radius_m <= e.home_radius_m,
            "{what}: radius {radius_m}"
        ),
    }
    assert!(
        map.obstacles.is_disc_free(center, radius_m),
        "{what}: home {center} r {radius_m}"
    );
    assert!(
        raw.disc_free(e.blocked, center, radius_m),
        "{what}: home {center} r {radius_m}"
    );
    let (label, sizes) = components(raw, e.blocked);
    let home = label[raw.index_of(center)];
    assert_ne!(home, u32::MAX, "{what}: home centre {center} in a blocked cell");
    if e.home.is_none() {
        let largest = sizes.iter().max().unwrap();
        assert_eq!(
            sizes[home as usize], *largest,
            "{what}: auto home is in the largest free region"
        );
    }
    assert_eq!(map.treasures.len() as u64, e.treasures, "{what}");
    for t in &map.treasures {
        let q = u64::from(t.quantity);
        assert!(q >= e.quantity.0 && q <= e.quantity.1, "{what}");
        assert_eq!(
            label[raw.index_of(t.position)],
            home,
            "{what}: treasure at {}",
            t.position
        );
    }
}

/// `preview`: at one pixel per cell and obstacles only, the picture is the raw raster.
fn check_preview(raw: &Raw, map_path: &Path, e: &Expect, dir: &Path) {
    let png = dir.join("obstacles.png");
    run_ok(
        editor()
            .arg("preview")
            .arg(map_path)
            .arg("-o")
            .arg(&png)
            .arg("--obstacles-only"),
    );
    let pic = image::open(&png).unwrap().into_rgb8();
    assert_eq!(pic.dimensions(), (raw.width, raw.height), "{}", e.what);
    for (col, row, p) in pic.enumerate_pixels() {
        let want = if e.blocked[(row * raw.width + col) as usize] {
            0
        } else {
            255
        };
        assert_eq!(p.0, [want; 3], "{}: pixel ({col}, {row})", e.what);
    }
    let png = dir.join("small.png");
    run_ok(
        editor()
            .arg("preview")
            .arg(map_path)
            .arg("-o")
            .arg(&png)
            .args(["--px", "300"]),
    );
    let (w, h) = image::image_dimensions(&png).unwrap();
    assert_eq!(w.max(h), 300, "{}", e.what);
}

/// `import` with `args`, then every check on the output.
fn import_and_check(raw: &Raw, args: &[String], e: &Expect) {
    let dir = tempfile::tempdir().unwrap();
    let map_path = dir.path().join("out.stmap");
    let out = run_ok(
        editor()
            .arg("import")
            .arg(&raw.file)
            .args(&raw.flags)
            .args(args)
            .arg("-o")
            .arg(&map_path),
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("wrote"), "{}", e.what);
    let out = run_ok(editor().arg("validate").arg(&map_path));
    assert!(String::from_utf8_lossy(&out.stdout).ends_with(": ok\n"), "{}", e.what);
    let map = MapData::load(&map_path).unwrap();
    check_stats(raw, &map_path, e, &map);
    check_placement(raw, e, &map);
    check_preview(raw, &map_path, e, dir.path());
}

/// Every import a user would naturally try on `raw`.
fn check_all(raw: &Raw) {
    let name = raw.file.display().to_string();
    let s = |v: &[&str]| v.iter().map(ToString::to_string).collect::<Vec<_>>();
    let cell = raw.cell_m;
    let auto = |what: &str, treasures, quantity, home_radius_m| Expect {
        what: format!("{name} {what}"),
        blocked: &raw.blocked,
        treasures,
        quantity,
        home: None,
        home_radius_m,
    };
    import_and_check(raw, &[], &auto("defaults", 0, (1, 1), 2.0));
    import_and_check(
        raw,
        &s(&["--treasures", "40", "--quantity", "1..5", "--place-seed", "7"]),
        &auto("uniform treasures", 40, (1, 5), 2.0),
    );
    let sigma = (10.0 * cell).to_string();
    import_and_check(
        raw,
        &s(&[
            "--treasures",
            "30",
            "--spread",
            "clustered",
            "--clusters",
            "3",
            "--cluster-sigma-m",
            &sigma,
        ]),
        &auto("clustered treasures", 30, (1, 1), 2.0),
    );
    let small = (3.0 * cell).to_string();
    import_and_check(
        raw,
        &s(&["--home-radius-m", &small, "--treasures", "10"]),
        &auto("small home", 10, (1, 1), 3.0 * cell),
    );
    let spot = raw.free_spot(&raw.blocked);
    let radius = (2.0 * cell).to_string();
    let home_arg = format!("--home={},{}", spot.x, spot.y);
    import_and_check(
        raw,
        &s(&[&home_arg, "--home-radius-m", &radius, "--treasures", "10"]),
        &Expect {
            home: Some((spot, 2.0 * cell)),
            ..auto("explicit home", 10, (1, 1), 2.0 * cell)
        },
    );
    if let Some(open) = &raw.blocked_unknown_free {
        import_and_check(
            raw,
            &s(&["--unknown", "free", "--treasures", "10"]),
            &Expect {
                blocked: open,
                ..auto("unknown free", 10, (1, 1), 2.0)
            },
        );
    }
}

#[test]
fn real_cli_movingai_arena() {
    let Some(data) = common::data_dir("real_cli_movingai_arena") else {
        return;
    };
    let raw = movingai(&data, "movingai/arena.map");
    assert_eq!((raw.width, raw.height), (49, 49));
    check_all(&raw);
}

#[test]
fn real_cli_movingai_berlin() {
    let Some(data) = common::data_dir("real_cli_movingai_berlin") else {
        return;
    };
    let raw = movingai(&data, "movingai/street/Berlin_0_256.map");
    assert_eq!((raw.width, raw.height), (256, 256));
    check_all(&raw);
}

#[test]
fn real_cli_ros_turtlebot3() {
    let Some(data) = common::data_dir("real_cli_ros_turtlebot3") else {
        return;
    };
    let raw = ros(&data, "ros/turtlebot3/map.yaml");
    assert_eq!((raw.width, raw.height, raw.cell_m), (384, 384, 0.05));
    assert_eq!(raw.origin, DVec2::new(-10.0, -10.0));
    check_all(&raw);
}

#[test]
fn real_cli_ros_depot() {
    let Some(data) = common::data_dir("real_cli_ros_depot") else {
        return;
    };
    let raw = ros(&data, "ros/nav2/depot.yaml");
    assert_eq!((raw.width, raw.height, raw.cell_m), (604, 307, 0.05));
    assert_eq!(raw.origin, DVec2::ZERO);
    check_all(&raw);
}

#[test]
fn real_cli_stage_cave() {
    let Some(data) = common::data_dir("real_cli_stage_cave") else {
        return;
    };
    let raw = stage(&data);
    assert_eq!((raw.width, raw.height), (500, 500));
    assert_eq!(raw.flags, ["--resolution-m", "0.032"]);
    check_all(&raw);
}

/// A query of a Moving AI scenario: start and goal corners (`x` right, `y` down), the octile
/// optimum, and the any-angle optimum where the file has that column.
struct Query {
    start: (i64, i64),
    goal: (i64, i64),
    octile: f64,
    anyangle: Option<f64>,
}

fn read_queries(path: &Path) -> Vec<Query> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter(|l| !l.starts_with("version") && !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let int = |i: usize| f[i].parse::<i64>().unwrap();
            Query {
                start: (int(4), int(5)),
                goal: (int(6), int(7)),
                octile: f[8].parse().unwrap(),
                anyangle: f.get(9).map(|v| v.parse().unwrap()),
            }
        })
        .collect()
}

/// The raw file's cells for the reference, in world cells (row 0 at the bottom; 1 m cells at
/// the origin, as `import` lays out a Moving AI map), blocked outside.
fn world_blocked(raw: &Raw) -> impl Fn(i64, i64) -> bool + '_ {
    let (w, h) = (i64::from(raw.width), i64::from(raw.height));
    move |x, y| x < 0 || y < 0 || x >= w || y >= h || raw.blocked[usize::try_from((h - 1 - y) * w + x).unwrap()]
}

/// A Moving AI corner as a world lattice point.
fn world_corner(raw: &Raw, (x, y): (i64, i64)) -> (i64, i64) {
    (x, i64::from(raw.height) - y)
}

#[allow(clippy::cast_precision_loss)] // Small lattice coordinates.
fn as_point((x, y): (i64, i64)) -> DVec2 {
    DVec2::new(x as f64, y as f64)
}

#[allow(clippy::cast_possible_truncation, clippy::float_cmp)] // Exactly on the lattice.
fn as_lattice(p: [f64; 2]) -> (i64, i64) {
    assert_eq!(
        p,
        [p[0].round(), p[1].round()],
        "a point robot's waypoint off the lattice"
    );
    (p[0] as i64, p[1] as i64)
}

/// `path --json` through the binary: `Some((length, waypoints))`, or `None` on exit status 1
/// (no path), which must come with a message.
fn cli_path(map: &Path, from: (i64, i64), to: (i64, i64)) -> Option<(f64, Vec<[f64; 2]>)> {
    let out = editor()
        .arg("path")
        .arg(map)
        .arg(format!("--from={},{}", from.0, from.1))
        .arg(format!("--to={},{}", to.0, to.1))
        .arg("--json")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    match out.status.code() {
        Some(0) => {
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let length = v["length_m"].as_f64().unwrap();
            let waypoints = v["waypoints"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                .collect();
            Some((length, waypoints))
        }
        Some(1) => {
            assert!(err.contains("no path"), "{err}");
            None
        }
        other => panic!("path exited with {other:?}: {err}"),
    }
}

/// Checks a path against the raw file with the reference (independent of the planner): it
/// joins the query's corners and every leg is legal; returns its length recomputed.
fn check_legs(raw: &Raw, q: &Query, waypoints: &[[f64; 2]]) -> f64 {
    let blocked = world_blocked(raw);
    let pts: Vec<(i64, i64)> = waypoints.iter().map(|&p| as_lattice(p)).collect();
    assert_eq!(pts[0], world_corner(raw, q.start));
    assert_eq!(*pts.last().unwrap(), world_corner(raw, q.goal));
    for leg in pts.windows(2) {
        assert!(
            sim_core::spatial::reference::segment_is_legal(&blocked, leg[0], leg[1]),
            "illegal leg {leg:?} on the way {:?} -> {:?}",
            q.start,
            q.goal
        );
    }
    pts.windows(2).map(|l| as_point(l[0]).distance(as_point(l[1]))).sum()
}

fn import_to(raw: &Raw, dir: &Path) -> PathBuf {
    let map = dir.join("map.stmap");
    run_ok(editor().arg("import").arg(&raw.file).arg("-o").arg(&map));
    map
}

/// `path` through the binary on all 160 legacy arena queries equals the any-angle optimum
/// the Polyanya reference implementation published (six significant digits), and every leg
/// is legal by the reference's cell-by-cell test on the raw file.
#[test]
fn real_cli_path_arena_equals_published_anyangle_optima() {
    let Some(data) = common::data_dir("real_cli_path_arena_equals_published_anyangle_optima") else {
        return;
    };
    let raw = movingai(&data, "movingai/arena.map");
    let dir = tempfile::tempdir().unwrap();
    let map = import_to(&raw, dir.path());
    let queries = read_queries(&data.join("movingai/arena.legacy.anyangle.tsv"));
    assert_eq!(queries.len(), 160);
    for q in &queries {
        let best = q.anyangle.unwrap();
        let (from, to) = (world_corner(&raw, q.start), world_corner(&raw, q.goal));
        let (length, waypoints) = cli_path(&map, from, to).expect("every arena query is reachable");
        assert!(
            (length - best).abs() <= 1e-5 * best.max(1.0),
            "{:?} -> {:?}: {length} vs published {best}",
            q.start,
            q.goal
        );
        assert!((check_legs(&raw, q, &waypoints) - length).abs() < 1e-9);
    }
}

/// On the Berlin street map's 930 octile queries (no any-angle optima published), every
/// path is legal, no shorter than the straight line and no longer than the octile optimum,
/// and a query is unreachable exactly when its octile length says so. All through the
/// library; every 93rd query also through the binary, which must print the same path.
#[test]
fn real_path_berlin_between_straight_line_and_octile() {
    let Some(data) = common::data_dir("real_path_berlin_between_straight_line_and_octile") else {
        return;
    };
    let raw = movingai(&data, "movingai/street/Berlin_0_256.map");
    let dir = tempfile::tempdir().unwrap();
    let map = import_to(&raw, dir.path());
    let loaded = MapData::load(&map).unwrap();
    let planner = sim_core::spatial::AnyAnglePlanner::build(&loaded.obstacles, 0.0).unwrap();
    let queries = read_queries(&data.join("movingai/street/Berlin_0_256.map.scen"));
    assert_eq!(queries.len(), 930);
    let mut reachable = 0;
    for (i, q) in queries.iter().enumerate() {
        let (from, to) = (world_corner(&raw, q.start), world_corner(&raw, q.goal));
        let found = planner.path(as_point(from), as_point(to));
        let unreachable = q.octile == 0.0 && q.start != q.goal;
        match &found {
            Ok(p) => {
                assert!(
                    !unreachable,
                    "{:?} -> {:?} is unreachable by the scenario",
                    q.start, q.goal
                );
                let ways: Vec<[f64; 2]> = p.waypoints.iter().map(|w| [w.x, w.y]).collect();
                assert!((check_legs(&raw, q, &ways) - p.length_m).abs() < 1e-9);
                let straight = as_point(from).distance(as_point(to));
                assert!(
                    p.length_m >= straight - 1e-9 && p.length_m <= q.octile + 1e-4,
                    "{:?} -> {:?}: {} outside [{straight}, {}]",
                    q.start,
                    q.goal,
                    p.length_m,
                    q.octile
                );
                reachable += 1;
            }
            Err(e) => assert!(unreachable, "{:?} -> {:?}: {e}, octile {}", q.start, q.goal, q.octile),
        }
        if i % 93 == 0 {
            let cli = cli_path(&map, from, to);
            let lib = found
                .as_ref()
                .ok()
                .map(|p| (p.length_m, p.waypoints.iter().map(|w| [w.x, w.y]).collect::<Vec<_>>()));
            // The same waypoints and length, to the bit: the CLI prints floats so that they
            // read back exactly (serde_json's `float_roundtrip`, on for the editor's tests,
            // parses them correctly rounded).
            assert_eq!(cli, lib);
        }
    }
    assert!(reachable > 900, "{reachable}");
}
