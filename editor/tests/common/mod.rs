//! Helpers shared by the editor's integration tests.
#![allow(dead_code)] // each test file uses a part of these helpers

use std::path::PathBuf;

#[path = "../../../tests/src/skip.rs"]
mod skip;

/// The real-data folder from `SMARTTEAMS_DATA`, or `None` (the caller returns) after
/// recording the skip; a `SMARTTEAMS_DATA` that names no folder fails the test.
pub fn data_dir(test: &str) -> Option<PathBuf> {
    let Some(d) = std::env::var_os("SMARTTEAMS_DATA") else {
        skip::skip(
            "data",
            test,
            "SMARTTEAMS_DATA is not set (the real maps of ../shared/data)",
        );
        return None;
    };
    let d = PathBuf::from(d);
    let d = if d.is_relative() {
        // Relative to the workspace root (where CI runs from).
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join(d)
    } else {
        d
    };
    assert!(d.is_dir(), "{test}: SMARTTEAMS_DATA={} is not a folder", d.display());
    Some(d)
}

/// Parse a binary PGM (P5, 8-bit) independently of the editor: (width, height, pixels).
pub fn read_pgm(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut fields = Vec::new();
    let mut i = 0;
    while fields.len() < 4 {
        while bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if bytes[i] == b'#' {
            while bytes[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        let start = i;
        while !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        fields.push(String::from_utf8(bytes[start..i].to_vec()).unwrap());
    }
    i += 1; // the single whitespace after maxval
    assert_eq!(fields[0], "P5");
    assert_eq!(fields[3], "255");
    let (w, h): (u32, u32) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let pixels = bytes[i..i + (w * h) as usize].to_vec();
    (w, h, pixels)
}

/// A deterministic pseudo-random byte for `(x, y, seed)`.
pub fn hash(x: u32, y: u32, seed: u64) -> u64 {
    let mut v = u64::from(x) << 32 | u64::from(y);
    v ^= seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    v ^ (v >> 31)
}
