//! Imports checked against values counted independently from the input bytes.
// Areas are sums of exactly representable cell areas: exact comparison is the point.
#![allow(clippy::float_cmp)]

mod common;

use std::path::Path;

use editor::import::{ImportOptions, Unknown, import};
use editor::preview::{PreviewOptions, render};
use image::{GrayImage, Luma};
use sim_core::glam::DVec2;
use sim_core::spatial::ObstacleMap;
use sim_core::world::{HomeBase, MapData};

fn test_image(w: u32, h: u32, seed: u64) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| {
        let v = common::hash(x / 3, y / 2, seed);
        Luma([if v.is_multiple_of(3) { 20 } else { 240 }])
    })
}

fn dark_count(img: &GrayImage) -> u64 {
    img.pixels().filter(|p| p.0[0] < 128).count() as u64
}

/// Every cell agrees with its pixel (row 0 = top).
fn assert_matches(map: &ObstacleMap, img: &GrayImage, blocked: impl Fn(u8) -> bool) {
    let (w, h) = img.dimensions();
    assert_eq!((map.grid().width_cells(), map.grid().height_cells()), (w, h));
    for row in 0..h {
        for col in 0..w {
            assert_eq!(
                map.tree().cell_value(col, h - 1 - row),
                blocked(img.get_pixel(col, row).0[0]),
                "pixel ({col}, {row})"
            );
        }
    }
}

#[test]
fn png_pgm_bmp_import_pixel_for_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let img = test_image(77, 45, 3);
    for ext in ["png", "pgm", "bmp"] {
        let path = dir.path().join(format!("t.{ext}"));
        img.save(&path).unwrap();
        let opts = ImportOptions {
            resolution_m: Some(0.5),
            ..ImportOptions::default()
        };
        let map = import(&path, &opts).unwrap();
        assert_eq!(map.blocked_area_m2(), dark_count(&img) as f64 * 0.25, "{ext}");
        assert_matches(&map, &img, |v| v < 128);
        let inv = import(
            &path,
            &ImportOptions {
                invert: true,
                ..ImportOptions::default()
            },
        )
        .unwrap();
        assert_eq!(
            inv.blocked_area_m2(),
            (77 * 45 - dark_count(&img)) as f64,
            "{ext} inverted"
        );
    }
}

#[test]
fn jpeg_of_aligned_blocks_imports() {
    let dir = tempfile::tempdir().unwrap();
    let img = GrayImage::from_fn(64, 48, |x, y| Luma([if (x / 8 + y / 8) % 3 == 0 { 0 } else { 255 }]));
    let path = dir.path().join("t.jpg");
    img.save(&path).unwrap();
    let map = import(&path, &ImportOptions::default()).unwrap();
    assert_matches(&map, &img, |v| v < 128);
}

#[test]
fn preview_reproduces_the_bitmap() {
    let dir = tempfile::tempdir().unwrap();
    let img = test_image(90, 61, 9);
    let path = dir.path().join("p.png");
    img.save(&path).unwrap();
    let obstacles = import(&path, &ImportOptions::default()).unwrap();
    let map = MapData {
        obstacles,
        home: HomeBase::Disc {
            center: DVec2::new(1.0, 1.0),
            radius_m: 1.0,
        },
        treasures: vec![],
    };
    let pic = render(
        &map,
        &PreviewOptions {
            px: None,
            overlays: false,
        },
    )
    .unwrap();
    assert_eq!(pic.dimensions(), img.dimensions());
    for (x, y, p) in img.enumerate_pixels() {
        let want = if p.0[0] < 128 { 0 } else { 255 };
        assert_eq!(pic.get_pixel(x, y).0, [want; 3], "pixel ({x}, {y})");
    }
    // Half the size: every pixel is the mean of a 2×2 block (one odd column/row is stretched).
    let small = render(
        &map,
        &PreviewOptions {
            px: Some(45),
            overlays: true,
        },
    )
    .unwrap();
    assert_eq!(small.width(), 45);
}

#[test]
fn corrupt_images_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let img = test_image(40, 40, 1);
    let path = dir.path().join("whole.png");
    img.save(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("truncated.png");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = import(&cut, &ImportOptions::default()).unwrap_err();
    assert!(
        err.to_string().contains("truncated.png: the image is cut short"),
        "{err}"
    );

    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"this is not an image").unwrap();
    let err = import(&junk, &ImportOptions::default()).unwrap_err();
    assert!(err.to_string().contains("junk.png"), "{err}");

    let missing = dir.path().join("missing.bmp");
    let err = import(&missing, &ImportOptions::default()).unwrap_err();
    assert!(err.to_string().contains("missing.bmp"), "{err}");
}

#[test]
fn movingai_blocked_area_and_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let rows = ["..@@T", "GSW..", "O...."];
    let text = format!("type octile\r\nheight 3\r\nwidth 5\r\nmap\r\n{}\r\n", rows.join("\r\n"));
    let path = dir.path().join("m.map");
    std::fs::write(&path, text).unwrap();
    let map = import(&path, &ImportOptions::default()).unwrap();
    let expected = rows.concat().bytes().filter(|c| !b".GS".contains(c)).count();
    assert_eq!(map.blocked_area_m2(), expected as f64);
    // Row 0 ("..@@T") is the top: y = 2.
    assert!(map.tree().cell_value(2, 2));
    assert!(!map.tree().cell_value(0, 2));
    assert!(map.tree().cell_value(0, 0)); // 'O' bottom-left
    assert!(map.tree().cell_value(2, 1)); // 'W'
}

#[test]
fn bad_movingai_headers_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [
        ("noheader.map", "..@\n"),
        ("badsize.map", "type octile\nheight x\nwidth 3\nmap\n...\n"),
        ("short.map", "type octile\nheight 2\nwidth 3\nmap\n...\n"),
        ("wide.map", "type octile\nheight 1\nwidth 3\nmap\n....\n"),
        ("huge.map", "type octile\nheight 100000\nwidth 100000\nmap\n"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let err = import(&path, &ImportOptions::default()).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(name) && msg.contains("MovingAI"), "{msg}");
    }
}

fn write_ros(dir: &Path, yaml: &str, pixels: &[u8], w: u32, h: u32) -> std::path::PathBuf {
    let mut pgm = format!("P5\n# test\n{w} {h}\n255\n").into_bytes();
    pgm.extend_from_slice(pixels);
    std::fs::write(dir.join("img.pgm"), pgm).unwrap();
    let path = dir.join("map.yaml");
    std::fs::write(&path, yaml).unwrap();
    path
}

/// The ROS formula, written out independently: (occupied, free, unknown).
fn ros_counts(pixels: &[u8], negate: bool, occ: f64, free: f64) -> (u64, u64, u64) {
    let mut c = (0, 0, 0);
    for &v in pixels {
        let p = if negate {
            f64::from(v) / 255.0
        } else {
            (255.0 - f64::from(v)) / 255.0
        };
        if p > occ {
            c.0 += 1;
        } else if p < free {
            c.1 += 1;
        } else {
            c.2 += 1;
        }
    }
    c
}

#[test]
fn ros_thresholds_negate_origin_and_unknown() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (23u32, 17u32);
    let pixels: Vec<u8> = (0..w * h).map(|i| (common::hash(i, 7, 5) % 256) as u8).collect();
    for negate in [false, true] {
        let yaml = format!(
            "image: img.pgm\nresolution: 0.1\norigin: [-2.5, 3.0, 0.0]\nnegate: {}\noccupied_thresh: 0.65\nfree_thresh: 0.2\nmode: trinary\n",
            u8::from(negate)
        );
        let path = write_ros(dir.path(), &yaml, &pixels, w, h);
        let (occ, free, unk) = ros_counts(&pixels, negate, 0.65, 0.2);
        assert_eq!(occ + free + unk, u64::from(w * h));
        let map = import(&path, &ImportOptions::default()).unwrap();
        assert_eq!(map.grid().origin(), DVec2::new(-2.5, 3.0));
        assert!((map.grid().cell_m() - 0.1).abs() < 1e-12);
        assert!((map.free_area_m2() - free as f64 * 0.01).abs() < 1e-9);
        let open = import(
            &path,
            &ImportOptions {
                unknown: Unknown::Free,
                ..ImportOptions::default()
            },
        )
        .unwrap();
        assert!((open.free_area_m2() - (free + unk) as f64 * 0.01).abs() < 1e-9);
        // Orientation: pixel (col, row) is cell (col, h-1-row).
        for row in 0..h {
            for col in 0..w {
                let (o, _, _) = ros_counts(&[pixels[(row * w + col) as usize]], negate, 0.65, 0.2);
                if o == 1 {
                    assert!(open.tree().cell_value(col, h - 1 - row));
                }
            }
        }
    }
}

#[test]
fn bad_ros_files_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_ros(dir.path(), "image: img.pgm\nresolution: [oops\n", &[0; 4], 2, 2);
    let msg = import(&path, &ImportOptions::default()).unwrap_err().to_string();
    assert!(msg.contains("map.yaml") && msg.contains("YAML"), "{msg}");
    std::fs::write(
        &path,
        "image: nothere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
    )
    .unwrap();
    let msg = import(&path, &ImportOptions::default()).unwrap_err().to_string();
    assert!(msg.contains("nothere.pgm"), "{msg}");
    std::fs::write(
        &path,
        "image: img.pgm\nresolution: 0.05\norigin: [0, 0, 1.2]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
    )
    .unwrap();
    let msg = import(&path, &ImportOptions::default()).unwrap_err().to_string();
    assert!(msg.contains("map.yaml") && msg.contains("yaw"), "{msg}");
}

// ---- opt-in tests on real data (SMARTTEAMS_DATA) ----

#[test]
fn real_movingai_maps() {
    let Some(data) = common::data_dir("real_movingai_maps") else {
        return;
    };
    for (file, w, h) in [
        ("movingai/arena.map", 49, 49),
        ("movingai/street/Berlin_0_256.map", 256, 256),
    ] {
        let path = data.join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let body: Vec<&str> = text.lines().skip(4).map(|l| l.trim_end_matches('\r')).collect();
        let blocked: usize = body
            .iter()
            .map(|l| l.chars().filter(|c| !matches!(c, '.' | 'G' | 'S')).count())
            .sum();
        let map = import(&path, &ImportOptions::default()).unwrap();
        assert_eq!((map.grid().width_cells(), map.grid().height_cells()), (w, h), "{file}");
        assert_eq!(map.blocked_area_m2(), blocked as f64, "{file}");
        assert!(blocked > 0);
    }
}

#[test]
fn real_ros_maps() {
    let Some(data) = common::data_dir("real_ros_maps") else {
        return;
    };
    for (yaml, pgm, free_thresh, origin, (w, h)) in [
        (
            "ros/turtlebot3/map.yaml",
            "ros/turtlebot3/map.pgm",
            0.196,
            DVec2::new(-10.0, -10.0),
            (384, 384),
        ),
        (
            "ros/nav2/depot.yaml",
            "ros/nav2/depot.pgm",
            0.25,
            DVec2::ZERO,
            (604, 307),
        ),
    ] {
        let (pw, ph, pixels) = common::read_pgm(&std::fs::read(data.join(pgm)).unwrap());
        assert_eq!((pw, ph), (w, h));
        let (occ, free, unk) = ros_counts(&pixels, false, 0.65, free_thresh);
        assert!(occ > 0 && free > 0, "{yaml}: {occ} {free} {unk}");
        let cell = 0.05 * 0.05;
        let map = import(&data.join(yaml), &ImportOptions::default()).unwrap();
        assert_eq!(map.grid().origin(), origin);
        assert_eq!((map.grid().width_cells(), map.grid().height_cells()), (w, h));
        assert!((map.free_area_m2() / cell - free as f64).abs() < 1e-6, "{yaml}");
        assert!(
            (map.blocked_area_m2() / cell - (occ + unk) as f64).abs() < 1e-6,
            "{yaml}"
        );
        let open = import(
            &data.join(yaml),
            &ImportOptions {
                unknown: Unknown::Free,
                ..ImportOptions::default()
            },
        )
        .unwrap();
        assert!((open.blocked_area_m2() / cell - occ as f64).abs() < 1e-6, "{yaml}");
    }
}

#[test]
fn real_stage_bitmap() {
    let Some(data) = common::data_dir("real_stage_bitmap") else {
        return;
    };
    let path = data.join("images/stage/cave.png");
    let img = image::open(&path).unwrap().into_luma8();
    let dark = dark_count(&img);
    let map = import(
        &path,
        &ImportOptions {
            resolution_m: Some(16.0 / 500.0),
            ..ImportOptions::default()
        },
    )
    .unwrap();
    let cell = (16.0f64 / 500.0).powi(2);
    assert!((map.blocked_area_m2() / cell - dark as f64).abs() < 1e-6);
    assert!(dark > 1000);
    assert_matches(&map, &img, |v| v < 128);
}

/// CRC-32 of the map file of each real map's import with default options (the Stage cave
/// at its 16 m width). These change only when an importer's output changes, in a commit
/// that says why.
const PINNED_IMPORTS: [(&str, u32); 5] = [
    ("movingai/arena.map", 0xfe92_c769),
    ("movingai/street/Berlin_0_256.map", 0x6c3d_803e),
    ("ros/turtlebot3/map.yaml", 0xc66b_6bb1),
    ("ros/nav2/depot.yaml", 0x734a_2280),
    ("images/stage/cave.png", 0x72fc_a7cc),
];

#[test]
fn real_maps_import_to_their_pinned_maps() {
    let Some(data) = common::data_dir("real_maps_import_to_their_pinned_maps") else {
        return;
    };
    let mut wrong = Vec::new();
    for (file, crc) in PINNED_IMPORTS {
        let options = ImportOptions {
            resolution_m: file.starts_with("images/").then_some(16.0 / 500.0),
            ..ImportOptions::default()
        };
        let obstacles = import(&data.join(file), &options).unwrap();
        let bytes = sim_core::world::MapData {
            obstacles,
            home: sim_core::world::HomeBase::Disc {
                center: DVec2::ZERO,
                radius_m: 1.0,
            },
            treasures: vec![],
        }
        .to_bytes();
        // The file ends with a CRC-32 of the rest (the CRC of the whole is a constant).
        let got = crc32fast::hash(&bytes[..bytes.len() - 4]);
        if got != crc {
            wrong.push(format!("(\"{file}\", 0x{got:08x}),"));
        }
    }
    assert!(
        wrong.is_empty(),
        "imports differ from the pinned ones:\n{}",
        wrong.join("\n")
    );
}

/// A ROS YAML whose `image:` names a missing file is refused with an error naming the YAML
/// that asked for it, not only the image.
#[test]
fn fuzz_found_a_ros_yaml_naming_a_missing_image_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let yaml = dir.path().join("site.yaml");
    std::fs::write(
        &yaml,
        "image: gone.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    )
    .unwrap();
    let e = import(&yaml, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("site.yaml") && e.contains("gone.pgm"), "{e}");
    // And one whose image has no pixels: the error names the image and its size.
    std::fs::write(dir.path().join("gone.pgm"), b"P5\n0 16\n255\n").unwrap();
    let e = import(&yaml, &ImportOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("site.yaml") && e.contains("gone.pgm") && e.contains("0 × 16"),
        "{e}"
    );
}
