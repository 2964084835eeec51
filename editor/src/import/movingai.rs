//! Moving AI `.map` files: a four-line header (`type …`, `height H`, `width W`, `map`) and
//! `H` rows of `W` characters; row 0 is the top. `.`, `G` and `S` are passable, everything
//! else is blocked. Cells are 1 m.

use std::path::Path;

use sim_core::spatial::ObstacleMap;

use super::{ImportOptions, read};
use crate::raster::{check_raster_size, grid, map_from_top_rows};
use crate::{EditorError, Result};

/// Whether a Moving AI terrain character is passable.
pub fn passable(c: u8) -> bool {
    matches!(c, b'.' | b'G' | b'S')
}

/// A parsed Moving AI map: rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MovingAiMap {
    /// Width in cells.
    pub width: u32,
    /// Height in cells.
    pub height: u32,
    /// `height` rows of `width` terrain bytes, row 0 at the top.
    pub rows: Vec<Vec<u8>>,
}

/// Parse the text of a `.map` file; errors carry 1-based line numbers.
pub fn parse(text: &[u8]) -> Result<MovingAiMap, String> {
    let mut lines = text.split(|&b| b == b'\n').map(|l| l.strip_suffix(b"\r").unwrap_or(l));
    let mut next = |what: &str, n: usize| -> Result<String, String> {
        let line = lines
            .next()
            .ok_or(format!("line {n}: file ends before the header's {what}"))?;
        String::from_utf8(line.to_vec()).map_err(|_| format!("line {n}: header is not text"))
    };
    let first = next("`type` line", 1)?;
    if !first.trim().starts_with("type ") {
        return Err(format!("line 1: expected `type octile`, found {first:?}"));
    }
    let mut width = None;
    let mut height = None;
    for n in 2..=3 {
        let line = next("size", n)?;
        let mut parts = line.split_whitespace();
        let (key, value) = (parts.next(), parts.next());
        let value = value
            .and_then(|v| v.parse::<u32>().ok())
            .filter(|&v| v > 0 && parts.next().is_none());
        match (key, value) {
            (Some("height"), Some(v)) if height.is_none() => height = Some(v),
            (Some("width"), Some(v)) if width.is_none() => width = Some(v),
            _ => {
                return Err(format!(
                    "line {n}: expected `height N` or `width N` with a positive N, found {line:?}"
                ));
            }
        }
    }
    let (Some(width), Some(height)) = (width, height) else {
        return Err("header must give both `height` and `width`".into());
    };
    let map = next("`map` line", 4)?;
    if map.trim() != "map" {
        return Err(format!("line 4: expected `map`, found {map:?}"));
    }
    if u64::from(width) * u64::from(height) > text.len() as u64 {
        return Err(format!(
            "header says {width} × {height} cells but the file has only {} bytes",
            text.len()
        ));
    }
    let mut body: Vec<&[u8]> = lines.collect();
    while body.last().is_some_and(|l| l.iter().all(u8::is_ascii_whitespace)) {
        body.pop();
    }
    let mut rows = Vec::with_capacity(height as usize);
    for (i, line) in body.into_iter().enumerate() {
        let n = i + 5;
        if rows.len() == height as usize {
            return Err(format!("line {n}: more than the {height} rows the header announces"));
        }
        if line.len() != width as usize {
            return Err(format!(
                "line {n}: row {} has {} characters, the header says width {width}",
                rows.len(),
                line.len()
            ));
        }
        rows.push(line.to_vec());
    }
    if rows.len() != height as usize {
        return Err(format!("file has {} rows, the header says height {height}", rows.len()));
    }
    Ok(MovingAiMap { width, height, rows })
}

/// Import a Moving AI map (1 m cells unless `--resolution-m` says otherwise).
pub fn import(path: &Path, opts: &ImportOptions) -> Result<ObstacleMap> {
    let text = read(path)?;
    let m = parse(&text).map_err(|p| EditorError::bad_input(path, format!("malformed MovingAI map: {p}")))?;
    check_raster_size(m.width, m.height, "this map").map_err(|e| EditorError::bad_input(path, e.to_string()))?;
    let g = grid(opts.origin, opts.resolution_m.unwrap_or(1.0), m.width, m.height)
        .map_err(|e| EditorError::bad_input(path, e.to_string()))?;
    map_from_top_rows(g, |col, row| !passable(m.rows[row as usize][col as usize]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        let ok = b"type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n.@.\r\nTGS\r\n";
        let m = parse(ok).unwrap();
        assert_eq!((m.width, m.height), (3, 2));
        assert_eq!(m.rows[1], b"TGS");
        assert!(
            parse(b"type octile\nheight 2\nwidth 3\nmap\n.@.\n")
                .unwrap_err()
                .contains("1 rows")
        );
        assert!(
            parse(b"type octile\nheight 2\nwidth 3\nmap\n.@\n...\n")
                .unwrap_err()
                .contains("line 5")
        );
        assert!(parse(b"typo\nheight 2\nwidth 3\nmap\n").unwrap_err().contains("line 1"));
        assert!(
            parse(b"type octile\nheight -2\nwidth 3\nmap\n")
                .unwrap_err()
                .contains("line 2")
        );
        assert!(
            parse(b"type octile\nheight 99999\nwidth 99999\nmap\n")
                .unwrap_err()
                .contains("bytes")
        );
        assert!(
            parse(b"type octile\nheight 1\nwidth 1\nmap\n.\n@\n")
                .unwrap_err()
                .contains("more than")
        );
    }
}
