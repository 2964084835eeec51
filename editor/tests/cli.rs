//! The `smartteams-editor` binary end to end: exit codes, JSON stats, error messages.

use std::process::Command;

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
    let out = editor()
        .arg("compose")
        .arg(&scene)
        .arg("-o")
        .arg(&map)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = editor().arg("validate").arg(&map).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("treasure 0 cannot be reached"), "{text}");
    assert!(text.contains("treasure 1 lies in a blocked cell"), "{text}");
    assert!(!text.contains("treasure 2"), "{text}");
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

    let junk = dir.path().join("junk.stmap");
    std::fs::write(&junk, b"STMAP\r\n\x1a\x01\x00").unwrap();
    let out = editor().arg("stats").arg(&junk).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("junk.stmap") && !err.contains("panicked"), "{err}");
}
