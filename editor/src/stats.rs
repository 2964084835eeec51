//! `stats`: what a map file holds.

use std::fmt;

use serde::Serialize;
use sim_core::world::MapData;

/// Figures describing a map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapStats {
    /// Width in metres.
    pub width_m: f64,
    /// Height in metres.
    pub height_m: f64,
    /// Cell side in metres.
    pub cell_m: f64,
    /// Width in cells.
    pub width_cells: u32,
    /// Height in cells.
    pub height_cells: u32,
    /// Lower-left corner `[x, y]`.
    pub origin: [f64; 2],
    /// Quadtree leaves (padding included).
    pub leaves: usize,
    /// Blocked leaves (padding included).
    pub blocked_leaves: usize,
    /// Free area, m².
    pub free_area_m2: f64,
    /// Blocked area inside the map, m².
    pub blocked_area_m2: f64,
    /// Blocked fraction of the map's area.
    pub blocked_fraction: f64,
    /// Number of treasures.
    pub treasures: usize,
    /// Sum of treasure quantities.
    pub treasure_quantity: u64,
    /// Home base centre `[x, y]`.
    pub home_center: [f64; 2],
    /// The home base's radius, m (`None` for a rectangle).
    pub home_radius_m: Option<f64>,
    /// The width and height of the home base's bounding box, m.
    pub home_size_m: [f64; 2],
    /// Size of the map file in bytes.
    pub file_bytes: u64,
}

/// Compute the figures of `map`, whose file has `file_bytes` bytes.
pub fn stats(map: &MapData, file_bytes: u64) -> MapStats {
    let o = &map.obstacles;
    let g = o.grid();
    let blocked = o.blocked_area_m2();
    let total = g.width_m() * g.height_m();
    MapStats {
        width_m: g.width_m(),
        height_m: g.height_m(),
        cell_m: g.cell_m(),
        width_cells: g.width_cells(),
        height_cells: g.height_cells(),
        origin: g.origin().to_array(),
        leaves: o.leaf_count(),
        blocked_leaves: o.blocked_leaf_count(),
        free_area_m2: o.free_area_m2(),
        blocked_area_m2: blocked,
        blocked_fraction: blocked / total,
        treasures: map.treasures.len(),
        treasure_quantity: map.treasures.iter().map(|t| u64::from(t.quantity)).sum(),
        home_center: map.home.center().to_array(),
        home_radius_m: match map.home {
            sim_core::world::HomeBase::Disc { radius_m, .. } => Some(radius_m),
            sim_core::world::HomeBase::Rect(_) => None,
        },
        home_size_m: {
            let b = map.home.bounds();
            (b.max - b.min).to_array()
        },
        file_bytes,
    }
}

/// A length or area for people: at most 6 decimals, without trailing zeros (sums of cell
/// sizes such as 19.200000000000003 print as 19.2).
fn num(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_owned() } else { s.to_owned() }
}

impl fmt::Display for MapStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "size            {} m × {} m ({} × {} cells of {} m)",
            num(self.width_m),
            num(self.height_m),
            self.width_cells,
            self.height_cells,
            num(self.cell_m)
        )?;
        writeln!(f, "origin          ({}, {})", num(self.origin[0]), num(self.origin[1]))?;
        writeln!(f, "leaves          {} ({} blocked)", self.leaves, self.blocked_leaves)?;
        writeln!(
            f,
            "area            {} m² free, {} m² blocked ({:.2} %)",
            num(self.free_area_m2),
            num(self.blocked_area_m2),
            100.0 * self.blocked_fraction
        )?;
        let (x, y) = (num(self.home_center[0]), num(self.home_center[1]));
        match self.home_radius_m {
            Some(r) => writeln!(f, "home            a disc of radius {} m at ({x}, {y})", num(r))?,
            None => writeln!(
                f,
                "home            a rectangle of {} m × {} m centred at ({x}, {y})",
                num(self.home_size_m[0]),
                num(self.home_size_m[1])
            )?,
        }
        writeln!(
            f,
            "treasures       {} (total quantity {})",
            self.treasures, self.treasure_quantity
        )?;
        write!(f, "file            {} bytes", self.file_bytes)
    }
}

#[cfg(test)]
mod number_tests {
    use super::num;

    /// Sums of cell sizes print as people write them.
    #[test]
    fn lengths_print_without_float_noise() {
        assert_eq!(num(19.200_000_000_000_003), "19.2");
        assert_eq!(num(-0.299_999_999_999_998_93), "-0.3");
        assert_eq!(num(128.0), "128");
        assert_eq!(num(0.05), "0.05");
        assert_eq!(num(-0.000_000_1), "0");
    }
}
