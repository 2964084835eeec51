//! The `smartteams-editor` binary end to end: exit codes, JSON stats, error messages.

use std::path::{Path, PathBuf};
use std::process::Command;

use sim_core::world::{HomeBase, MapData};

fn editor() -> Command {
    Command::new(env!("CARGO_BIN_EXE_smartteams-editor"))
}

#[test]
fn generate_place_validate_stats_preview() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("m.stmap");
    let out = editor()
        .args([
            "generate",
            "caves",
            "--width-m",
            "96",
            "--height-m",
            "64",
            "--seed",
            "3",
            "--treasures",
            "12",
            "-o",
        ])
        .arg(&map)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = editor().arg("validate").arg(&map).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stdout));
    let out = editor().args(["stats", "--json"]).arg(&map).output().unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["width_m"], 96.0);
    assert_eq!(v["treasures"], 12);
    assert_eq!(v["file_bytes"], std::fs::metadata(&map).unwrap().len());
    for key in [
        "height_m",
        "cell_m",
        "origin",
        "leaves",
        "blocked_leaves",
        "free_area_m2",
        "blocked_area_m2",
    ] {
        assert!(!v[key].is_null(), "{key}");
    }
    let png = dir.path().join("m.png");
    let out = editor()
        .arg("preview")
        .arg(&map)
        .arg("-o")
        .arg(&png)
        .args(["--px", "192"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(image::image_dimensions(&png).unwrap(), (192, 128));
}

/// A map with problems: `compose` will not write it, and `validate` exits 1 listing each.
#[test]
fn validate_exits_1_listing_every_problem() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(
        &scene,
        r#"<scene width-m="20" height-m="20"><home x="3" y="3" radius="1"/>
           <rect x="10" y="10" width="1" height="20"/>
           <treasure x="15" y="5"/><treasure x="10" y="12"/><treasure x="5" y="15"/></scene>"#,
    )
    .unwrap();
    let map = dir.path().join("s.stmap");
    // `compose` refuses to write it, naming its problems.
    let out = editor()
        .arg("compose")
        .arg(&scene)
        .arg("-o")
        .arg(&map)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && !map.exists(), "{err}");
    assert!(
        err.contains("the scene's map would not be valid: treasure 0 cannot be reached")
            && err.contains("treasure 1 lies in a blocked cell"),
        "{err}"
    );
    // Made with the library, which does not check, it fails `validate`.
    let text = std::fs::read_to_string(&scene).unwrap();
    let made = editor::compose::compose(editor::compose::parse_scene(&text, &scene).unwrap()).unwrap();
    std::fs::write(&map, made.to_bytes()).unwrap();
    let out = editor().arg("validate").arg(&map).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("treasure 0 cannot be reached"), "{text}");
    assert!(text.contains("treasure 1 lies in a blocked cell"), "{text}");
    assert!(!text.contains("treasure 2"), "{text}");
}

/// A damaged map file fails validation like a map with problems: exit status 1, the
/// reason named.
#[test]
fn validate_refuses_a_damaged_file_with_status_1() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("cut.stmap");
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../maps/demo.stmap");
    let whole = std::fs::read(demo).unwrap();
    std::fs::write(&map, &whole[..whole.len() / 2]).unwrap();
    let out = editor().arg("validate").arg(&map).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("cut.stmap"), "{text}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a valid map"));
}

#[test]
fn bad_input_is_an_error_naming_the_file_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.map");
    std::fs::write(&bad, "type octile\nheight 3\nwidth 3\nmap\n...\n").unwrap();
    let out_map = dir.path().join("out.stmap");
    let out = editor()
        .arg("import")
        .arg(&bad)
        .arg("-o")
        .arg(&out_map)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.map") && !err.contains("panicked"), "{err}");
    assert!(!out_map.exists(), "nothing is written on failure");

    // A bitmap whose pixels end early: 100 announced, 3 given.
    let cut = dir.path().join("cut.pgm");
    std::fs::write(&cut, b"P5\n10 10\n255\nabc").unwrap();
    let out = editor()
        .arg("import")
        .arg(&cut)
        .arg("-o")
        .arg(&out_map)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cut.pgm: the image is cut short"), "{err}");

    let junk = dir.path().join("junk.stmap");
    std::fs::write(&junk, b"STMAP\r\n\x1a\x01\x00").unwrap();
    let out = editor().arg("stats").arg(&junk).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("junk.stmap") && !err.contains("panicked"), "{err}");
}

/// Writes a ROS map (`map.yaml` + `img.pgm`, 5 cm pixels, origin 0, 0) of `w × h` pixels,
/// `blocked(col, y)` with y counted from the bottom. Returns the YAML's path.
fn write_ros_5cm(dir: &Path, w: u32, h: u32, blocked: impl Fn(u32, u32) -> bool) -> PathBuf {
    let mut pgm = format!("P5\n{w} {h}\n255\n").into_bytes();
    for row in 0..h {
        for col in 0..w {
            pgm.push(if blocked(col, h - 1 - row) { 0 } else { 254 });
        }
    }
    std::fs::write(dir.join("img.pgm"), pgm).unwrap();
    let yaml = dir.join("map.yaml");
    std::fs::write(
        &yaml,
        "image: img.pgm\nresolution: 0.050000\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    )
    .unwrap();
    yaml
}

/// `import FILE ARGS -o OUT`, which must fail with exit status 2 and write nothing; its
/// standard error.
fn import_refused(file: &Path, args: &[&str], out_map: &Path) -> String {
    let out = editor()
        .arg("import")
        .arg(file)
        .args(args)
        .arg("-o")
        .arg(out_map)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(!out_map.exists(), "{args:?}: nothing is written on failure");
    err
}

fn run_ok(cmd: &mut Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// `import` of a ROS map at 5 cm per pixel does not panic in the automatic home placement
/// (`clamp: expected min <= max`). A square quadtree leaf's world box is not exactly square
/// in floating point (its x and y sides come from different corners), so the leaf's half
/// width along x, used as the inset along y too, can give `min.y + half > max.y - half` by
/// an ulp for some 5 cm leaves. Here every free leaf is a single 5 cm cell (a blocked pixel
/// in every 2 × 2 block; the free cells are all connected) and the cell nearest the centre,
/// (10, 6), is one with the inverted range; the cell below it is blocked, so a disc shifted
/// down by that ulp (what the clamp gave where glam's assertions are off) overlaps it.
#[test]
fn ros_import_at_5cm_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (21u32, 13u32);
    let blocked = |x: u32, y: u32| x.is_multiple_of(2) && !y.is_multiple_of(2);
    let yaml = write_ros_5cm(dir.path(), w, h, blocked);
    let map_path = dir.path().join("out.stmap");
    let out = editor()
        .arg("import")
        .arg(&yaml)
        .arg("-o")
        .arg(&map_path)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !err.contains("panicked"),
        "{:?}: {err}",
        out.status
    );

    let out = run_ok(editor().arg("validate").arg(&map_path));
    assert!(String::from_utf8_lossy(&out.stdout).ends_with(": ok\n"));
    let out = run_ok(editor().args(["stats", "--json"]).arg(&map_path));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (v["width_cells"].as_u64(), v["height_cells"].as_u64()),
        (Some(21), Some(13))
    );
    assert_eq!(v["cell_m"].as_f64(), Some(0.05));
    let blocked_cells = (0..w * h).filter(|&i| blocked(i % w, i / w)).count();
    assert_eq!(blocked_cells, 11 * 6);
    let area = v["blocked_area_m2"].as_f64().unwrap();
    assert!((area - 66.0 * 0.05 * 0.05).abs() < 1e-12, "{area}");
    let png = dir.path().join("out.png");
    run_ok(editor().arg("preview").arg(&map_path).arg("-o").arg(&png));
    assert_eq!(image::image_dimensions(&png).unwrap(), (21, 13));
    // A preview is a PNG: another name is refused rather than written as a PNG under it.
    let jpg = dir.path().join("out.jpg");
    let out = editor()
        .arg("preview")
        .arg(&map_path)
        .arg("-o")
        .arg(&jpg)
        .output()
        .unwrap();
    assert!(!out.status.success() && !jpg.exists());
    assert!(String::from_utf8_lossy(&out.stderr).contains("a preview is written as PNG"));

    // The home base the CLI chose is a disc that is free of obstacles and inside the map.
    let map = MapData::load(&map_path).unwrap();
    let HomeBase::Disc { center, radius_m } = map.home else {
        panic!("auto home is a disc, got {:?}", map.home);
    };
    assert!(radius_m > 0.0 && radius_m <= 2.0, "{radius_m}");
    assert!(
        map.obstacles.is_disc_free(center, radius_m),
        "home {center} r {radius_m}"
    );
    // (serde_json's default float parsing may be an ulp off: compare with a tolerance.)
    let json_home = [
        v["home_center"][0].as_f64().unwrap(),
        v["home_center"][1].as_f64().unwrap(),
    ];
    assert!((json_home[0] - center.x).abs() < 1e-12 && (json_home[1] - center.y).abs() < 1e-12);
    // Its centre lies in a free cell (checked on the pixels written above).
    let (x, y) = ((center.x / 0.05).floor() as u32, (center.y / 0.05).floor() as u32);
    assert!(x < w && y < h && !blocked(x, y), "home centre in cell ({x}, {y})");
    assert_eq!((x, y), (10, 6), "the leaf with the inverted range is the one chosen");
}

/// Importers refuse grids whose coordinates cannot be computed with (cells too small for the
/// size of their coordinates, areas that under- or overflow) with an error naming the file,
/// instead of panicking in the home placement or writing a map with NaN areas.
#[test]
fn import_refuses_grids_it_cannot_compute_with() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tiny.map");
    std::fs::write(&file, "type octile\nheight 3\nwidth 4\nmap\n....\n.@..\n....\n").unwrap();
    let out_map = dir.path().join("out.stmap");
    for args in [
        &["--resolution-m", "1e-300"][..],
        &["--resolution-m", "1e306"],
        &["--origin", "1e20,1e20"],
        &["--origin", "1e308,0"],
    ] {
        let err = import_refused(&file, args, &out_map);
        assert!(
            err.contains("tiny.map") && err.contains("cannot be computed with"),
            "{args:?}: {err}"
        );
    }
    // The same file at sensible settings imports.
    run_ok(
        editor()
            .arg("import")
            .arg(&file)
            .args(["--resolution-m", "0.05", "--origin=-1e4,1e4", "-o"])
            .arg(&out_map),
    );
}

/// `path` prints the length and waypoints (text and JSON), exits with status 1 and a
/// message when the goal is unreachable or inside an obstacle, and refuses a nonsense
/// radius. The map: 6 × 4 cells of 1 m, a wall at column 2 from the bottom up to y = 2, and
/// a closed pocket at the top right.
#[test]
fn path_prints_the_shortest_route_and_exits_1_without_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("wall.map");
    std::fs::write(
        &file,
        "type octile\nheight 4\nwidth 6\nmap\n....@.\n....@@\n..@...\n..@...\n",
    )
    .unwrap();
    let map = dir.path().join("wall.stmap");
    run_ok(editor().arg("import").arg(&file).arg("-o").arg(&map));
    let path = |args: &[&str]| editor().arg("path").arg(&map).args(args).output().unwrap();

    // Round the top of the wall: (0, 0) -> (2, 2) -> (3, 2) -> (4, 0), by hand √8 + 1 + √5.
    let out = path(&["--from", "0,0", "--to", "4,0", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let expected = 8f64.sqrt() + 1.0 + 5f64.sqrt();
    assert!((v["length_m"].as_f64().unwrap() - expected).abs() < 1e-12, "{v}");
    assert_eq!(
        v["waypoints"],
        serde_json::json!([[0.0, 0.0], [2.0, 2.0], [3.0, 2.0], [4.0, 0.0]])
    );

    let text = String::from_utf8(path(&["--from", "0,0", "--to", "4,0"]).stdout).unwrap();
    assert_eq!(text, format!("length_m {expected}\n0 0\n2 2\n3 2\n4 0\n"));

    // A robot of radius 0.25 m keeps clear: longer, and bends 0.25 m off the corners.
    let out = path(&[
        "--from",
        "0.5,0.5",
        "--to",
        "3.5,0.5",
        "--robot-radius-m",
        "0.25",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["waypoints"][1], serde_json::json!([1.75, 2.25]), "{v}");

    for (args, says) in [
        (&["--from", "0,0", "--to", "5.5,3.5"][..], "cannot be reached"),
        (
            &["--from", "0,0", "--to", "2.5,0.5"],
            "goal (2.5, 0.5) is inside an obstacle",
        ),
        (
            &["--from", "-1,0", "--to", "1,1"],
            "start (-1, 0) is outside the map (0 to ",
        ),
        (
            &["--from", "1.9,0.5", "--to", "0.5,0.5", "--robot-radius-m", "0.25"],
            "start (1.9, 0.5) is closer to an obstacle than the robot's radius (0.25 m)",
        ),
    ] {
        let out = path(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("wall.stmap: no path") && err.contains(says),
            "{args:?}: {err}"
        );
        assert!(out.stdout.is_empty());
    }
    let out = path(&["--from", "0,0", "--to", "1,1", "--robot-radius-m", "-1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("robot radius must be a non-negative number of metres, got -1"),
        "{err}"
    );
}

/// The free cells 4-connected to the home base's cell, counted by a breadth-first walk over
/// the grid's cells.
fn reachable_free_cells(map: &MapData) -> u64 {
    let grid = *map.obstacles.grid();
    let free = |x: u32, y: u32| map.obstacles.is_point_free(grid.cell_center(x, y));
    let start = grid.cell_of(map.home.center()).unwrap();
    let mut seen = std::collections::HashSet::from([start]);
    let mut queue = std::collections::VecDeque::from([start]);
    while let Some((x, y)) = queue.pop_front() {
        let next = [
            x.checked_sub(1).map(|x| (x, y)),
            (x + 1 < grid.width_cells()).then_some((x + 1, y)),
            y.checked_sub(1).map(|y| (x, y)),
            (y + 1 < grid.height_cells()).then_some((x, y + 1)),
        ];
        for c in next.into_iter().flatten() {
            if free(c.0, c.1) && seen.insert(c) {
                queue.push_back(c);
            }
        }
    }
    seen.len() as u64
}

/// Asking for more treasures than there are free cells reachable from the home base is
/// allowed (they share cells' centres) and warned about, naming both counts; as many as
/// there are cells is not.
#[test]
fn more_treasures_than_reachable_cells_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("small.stmap");
    let out = editor()
        .args([
            "generate",
            "rooms",
            "--width-m",
            "8",
            "--height-m",
            "8",
            "--quiet",
            "--treasures",
            "1",
            "-o",
        ])
        .arg(&map)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // (A home smaller than the 2 m asked for is warned of on so small a map: not this.)
    assert!(!String::from_utf8_lossy(&out.stderr).contains("treasures on"));
    let cells = reachable_free_cells(&MapData::load(&map).unwrap());
    assert!(cells > 1, "{cells}");
    let place = |treasures: u64| {
        let out = editor()
            .arg("place")
            .arg(&map)
            .args(["--treasures", &treasures.to_string(), "-o"])
            .arg(dir.path().join("placed.stmap"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(!place(cells).contains("warning"));
    let err = place(cells + 1);
    assert!(
        err.contains(&format!(
            "warning: {} treasures on {cells} free cells reachable from the home base",
            cells + 1
        )),
        "{err}"
    );
    let placed = MapData::load(&dir.path().join("placed.stmap")).unwrap();
    assert_eq!(placed.treasures.len() as u64, cells + 1);
}

/// Negative coordinates are values, as ROS maps' origins and homes often are: a bitmap
/// imported at `--origin -10,-10` has its lower-left corner there, and `--home -0.5,-0.5`
/// sets the home base's centre; a negative count is a bad value of its option.
#[test]
fn negative_coordinates_are_values_of_their_option() {
    let dir = tempfile::tempdir().unwrap();
    // 2 m × 2 m of free cells from (-1, -1).
    let yaml = write_ros_5cm(dir.path(), 40, 40, |_, _| false);
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(
        &yaml,
        text.replace("origin: [0.0, 0.0, 0.0]", "origin: [-1.0, -1.0, 0.0]"),
    )
    .unwrap();
    let pgm = dir.path().join("img.pgm");
    let (ros, bitmap) = (dir.path().join("ros.stmap"), dir.path().join("bitmap.stmap"));
    run_ok(editor().arg("import").arg(&yaml).arg("-o").arg(&ros).args([
        "--home",
        "-0.5,-0.5",
        "--home-radius-m",
        "0.2",
    ]));
    run_ok(
        editor()
            .arg("import")
            .arg(&pgm)
            .arg("-o")
            .arg(&bitmap)
            .args(["--origin", "-10,-10"]),
    );
    let home = MapData::load(&ros).unwrap().home;
    assert_eq!(home.center(), glam::DVec2::new(-0.5, -0.5), "{home:?}");
    let origin = MapData::load(&bitmap).unwrap().obstacles.grid().origin();
    assert_eq!(origin, glam::DVec2::new(-10.0, -10.0));
    let out = editor()
        .args(["generate", "noise", "--treasures", "-3", "-o"])
        .arg(dir.path().join("n.stmap"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("invalid value '-3' for '--treasures"),
        "{err}"
    );
}

/// Output to a reader that has gone (`smartteams-editor stats MAP | head -1`) ends the
/// command quietly, where `println!` panicked.
#[test]
fn a_reader_that_has_gone_ends_stats_quietly() {
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("../maps/maze.stmap");
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = editor().arg("stats").arg(&map).stdout(writer).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.is_empty(), "{:?}: {err}", out.status);
}

/// An automatic home base smaller than `--home-radius-m` asked for is said to be.
#[test]
fn a_home_smaller_than_asked_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let generate = |radius: &str| {
        let out = editor()
            .args([
                "generate",
                "rooms",
                "--width-m",
                "64",
                "--height-m",
                "48",
                "--home-radius-m",
                radius,
                "-o",
            ])
            .arg(dir.path().join("r.stmap"))
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = generate("50");
    let home = MapData::load(&dir.path().join("r.stmap")).unwrap().home;
    let HomeBase::Disc { radius_m, .. } = home else {
        panic!("{home:?}");
    };
    assert!(
        err.contains(&format!(
            "warning: the home base has radius {radius_m} m: no free disc of the 50 m asked for fits"
        )),
        "{err}"
    );
    assert!(!generate("1").contains("warning"));
}

/// Options `place` would ignore are refused before anything is written: a home base radius
/// without `--home` (the map's home base is kept), and cluster options without `--spread
/// clustered`. With `--home`, the radius is taken.
#[test]
fn place_refuses_options_it_would_ignore() {
    let dir = tempfile::tempdir().unwrap();
    let (map, out_map) = (dir.path().join("m.stmap"), dir.path().join("placed.stmap"));
    run_ok(
        editor()
            .args([
                "generate",
                "noise",
                "--width-m",
                "16",
                "--height-m",
                "16",
                "--density",
                "0",
                "--quiet",
                "-o",
            ])
            .arg(&map),
    );
    let place = |args: &[&str]| {
        editor()
            .arg("place")
            .arg(&map)
            .args(args)
            .arg("-o")
            .arg(&out_map)
            .output()
            .unwrap()
    };
    for (args, says) in [
        (
            &["--home-radius-m", "5"][..],
            "--home-radius-m sizes the home base --home places",
        ),
        (
            &["--clusters", "3"][..],
            "--clusters applies only with --spread clustered",
        ),
        (
            &["--treasures", "2", "--cluster-sigma-m", "1"][..],
            "--cluster-sigma-m applies only with --spread clustered",
        ),
    ] {
        let out = place(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{args:?}: {err}");
        assert!(!out_map.exists(), "{args:?} wrote a map");
    }
    run_ok(
        editor()
            .arg("place")
            .arg(&map)
            .args(["--home", "8,8", "--home-radius-m", "5", "-o"])
            .arg(&out_map),
    );
    let placed = MapData::load(&out_map).unwrap();
    assert!(
        matches!(placed.home, HomeBase::Disc { radius_m, .. } if (radius_m - 5.0).abs() < 1e-9),
        "{:?}",
        placed.home
    );
}

/// Import options the file's format does not use are refused, naming the file, rather than
/// ignored: `--origin` of a ROS map (its YAML states it), `--unknown` of a bitmap or a
/// Moving AI map, `--threshold` and `--invert` of a Moving AI map.
#[test]
fn import_refuses_options_its_format_does_not_use() {
    let dir = tempfile::tempdir().unwrap();
    let mai = dir.path().join("tiny.map");
    std::fs::write(&mai, "type octile\nheight 3\nwidth 4\nmap\n....\n.@..\n....\n").unwrap();
    // The ROS map's image is a bitmap of its own.
    let yaml = write_ros_5cm(dir.path(), 40, 40, |_, _| false);
    let png = dir.path().join("img.pgm");
    let out_map = dir.path().join("out.stmap");
    for (file, args, says) in [
        (
            &yaml,
            &["--origin", "1,1"][..],
            "--origin applies only to bitmaps and Moving AI maps",
        ),
        (&png, &["--unknown", "free"][..], "--unknown applies only to ROS maps"),
        (&mai, &["--unknown", "free"][..], "--unknown applies only to ROS maps"),
        (&mai, &["--threshold", "100"][..], "--threshold applies only to bitmaps"),
        (&mai, &["--invert"][..], "--invert applies only to bitmaps"),
    ] {
        let err = import_refused(file, args, &out_map);
        let name = file.file_name().unwrap().to_string_lossy();
        assert!(err.contains(&*name) && err.contains(says), "{args:?}: {err}");
    }
    run_ok(
        editor()
            .arg("import")
            .arg(&png)
            .args(["--threshold", "255", "--invert", "--origin", "-2,-2", "-o"])
            .arg(&out_map),
    );
    run_ok(
        editor()
            .arg("import")
            .arg(&mai)
            .args(["--origin", "-2,-2", "-o"])
            .arg(&out_map),
    );
}
