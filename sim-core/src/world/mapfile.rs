//! The map file: obstacles, home base and treasures in a compact, versioned binary format.
//!
//! Layout (little-endian), version 1:
//!
//! | field | bytes |
//! |---|---|
//! | magic `b"STMAP\r\n\x1a"` (catches text-mode mangling, like PNG's) | 8 |
//! | version `u16` = 1, flags `u16` = 0 | 4 |
//! | origin x, origin y, cell size (m) `f64` | 24 |
//! | width, height in cells `u32` | 8 |
//! | home: kind `u8` (0 disc: cx, cy, r; 1 rectangle: min x, min y, max x, max y) `f64`s | 25 or 33 |
//! | treasure count `u32`, then x `f64`, y `f64`, quantity `u32` each | 4 + 20 n |
//! | node count `u64`, then the quadtree in preorder, 2 bits a node (0 free, 1 blocked, 2 internal; children SW, SE, NW, NE), 4 nodes a byte, low bits first | 8 + ⌈n/4⌉ |
//! | CRC-32 of everything before | 4 |
//!
//! A node costs 2 bits, so a tree of L leaves costs about 2.7 L bits. The reader trusts no
//! count: each is checked against the bytes actually left before anything is allocated, and
//! every failure names the byte offset and the problem.

use std::path::Path;

use glam::DVec2;

use crate::spatial::Aabb;
use crate::spatial::Grid;
use crate::spatial::{ObstacleMap, RegionQuadtree};
use crate::{Error, Result};

/// File magic.
pub const MAGIC: [u8; 8] = *b"STMAP\r\n\x1a";
/// Current format version.
pub const VERSION: u16 = 1;

/// The home base: where robots start, recharge and deliver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HomeBase {
    /// A disc.
    Disc {
        /// Centre.
        center: DVec2,
        /// Radius in metres.
        radius_m: f64,
    },
    /// A rectangle.
    Rect(Aabb),
}

impl HomeBase {
    /// Whether `p` lies in the home base (closed).
    pub fn contains(&self, p: DVec2) -> bool {
        match *self {
            HomeBase::Disc { center, radius_m } => p.distance_squared(center) <= radius_m * radius_m,
            HomeBase::Rect(r) => r.contains_box(&Aabb { min: p, max: p }),
        }
    }

    /// Its centre.
    pub fn center(&self) -> DVec2 {
        match *self {
            HomeBase::Disc { center, .. } => center,
            HomeBase::Rect(r) => r.center(),
        }
    }

    /// A box around it.
    pub fn bounds(&self) -> Aabb {
        match *self {
            HomeBase::Disc { center, radius_m } => Aabb {
                min: center - DVec2::splat(radius_m),
                max: center + DVec2::splat(radius_m),
            },
            HomeBase::Rect(r) => r,
        }
    }

    fn check(&self, extent: &Aabb) -> Result<(), String> {
        let ok = match *self {
            HomeBase::Disc { center, radius_m } => center.is_finite() && radius_m.is_finite() && radius_m > 0.0,
            HomeBase::Rect(r) => r.min.is_finite() && r.max.is_finite() && r.min.x < r.max.x && r.min.y < r.max.y,
        };
        if !ok {
            return Err(format!("home base {self:?} is degenerate"));
        }
        if !extent.contains_box(&Aabb {
            min: self.center(),
            max: self.center(),
        }) {
            return Err(format!("home base centre {} lies outside the map", self.center()));
        }
        Ok(())
    }
}

/// A treasure as placed on the map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreasureSpec {
    /// World position.
    pub position: DVec2,
    /// Quantity (units to excavate and deliver).
    pub quantity: u32,
}

/// Everything a map file holds.
#[derive(Clone, Debug)]
pub struct MapData {
    /// The obstacles (and the grid).
    pub obstacles: ObstacleMap,
    /// The home base.
    pub home: HomeBase,
    /// The treasures.
    pub treasures: Vec<TreasureSpec>,
}

impl MapData {
    /// Check that home and treasures lie inside the map and are finite.
    pub fn check(&self) -> Result<()> {
        self.problems().map_err(Error::Malformed)
    }

    fn problems(&self) -> Result<(), String> {
        let extent = self.obstacles.grid().extent();
        self.home.check(&extent)?;
        for (i, t) in self.treasures.iter().enumerate() {
            if !(t.position.is_finite()
                && extent.contains_box(&Aabb {
                    min: t.position,
                    max: t.position,
                }))
            {
                return Err(format!("treasure {i} at {} lies outside the map", t.position));
            }
        }
        Ok(())
    }

    /// Encode as bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let g = self.obstacles.grid();
        let mut out = Vec::new();
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        for v in [g.origin().x, g.origin().y, g.cell_m()] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&g.width_cells().to_le_bytes());
        out.extend_from_slice(&g.height_cells().to_le_bytes());
        match self.home {
            HomeBase::Disc { center, radius_m } => {
                out.push(0);
                for v in [center.x, center.y, radius_m] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
            HomeBase::Rect(r) => {
                out.push(1);
                for v in [r.min.x, r.min.y, r.max.x, r.max.y] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        out.extend_from_slice(&(self.treasures.len() as u32).to_le_bytes());
        for t in &self.treasures {
            out.extend_from_slice(&t.position.x.to_le_bytes());
            out.extend_from_slice(&t.position.y.to_le_bytes());
            out.extend_from_slice(&t.quantity.to_le_bytes());
        }
        let tree = self.obstacles.tree();
        let nodes = 4 * tree.internal_nodes() as u64 + 1;
        out.extend_from_slice(&nodes.to_le_bytes());
        tree.encode_preorder(&mut out);
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Decode bytes read from `path` (the path only names the source in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = Reader { bytes, pos: 0, path };
        let grid = r.header()?;
        let home_at = r.pos;
        let home = r.home()?;
        let treasures = r.treasures()?;
        let tree = r.packed_tree()?;
        r.checksum()?;
        let obstacles = r.obstacles(grid, &tree)?;
        let map = MapData {
            obstacles,
            home,
            treasures,
        };
        map.problems().map_err(|e| r.error_at(home_at, e))?;
        Ok(map)
    }

    /// Check the map, then write it to `path` atomically (a temporary file beside it, then
    /// a rename), so a failed save never leaves half a map behind.
    pub fn save(&self, path: &Path) -> Result<()> {
        self.problems().map_err(|problem| Error::MapFile {
            path: path.to_path_buf(),
            offset: 0,
            problem: format!("refusing to write an invalid map: {problem}"),
        })?;
        crate::write_atomically(path, &self.to_bytes())
    }

    /// Read from `path`.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::from_bytes(&bytes, path)
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

/// The obstacle quadtree as the file stores it: its offset, its packed nodes and how many
/// nodes there are.
struct PackedTree<'a> {
    at: usize,
    packed: &'a [u8],
    nodes: u64,
}

impl<'a> Reader<'a> {
    /// Read the header (magic, version, flags) and the grid it describes.
    fn header(&mut self) -> Result<Grid> {
        let magic = self.take(8, "magic")?;
        if magic != MAGIC {
            return Err(self.error_at(0, "not a Smart Teams map file (wrong magic)"));
        }
        let version = self.u16("version")?;
        if version != VERSION {
            return Err(self.error_at(
                8,
                format!("unsupported format version {version} (this build reads version {VERSION})"),
            ));
        }
        let flags = self.u16("flags")?;
        if flags != 0 {
            return Err(self.error_at(10, format!("unknown flags {flags:#06x}")));
        }
        let (ox, oy, cell) = (self.f64("origin x")?, self.f64("origin y")?, self.f64("cell size")?);
        let (w, h) = (self.u32("width")?, self.u32("height")?);
        Grid::new(DVec2::new(ox, oy), cell, w, h).map_err(|e| self.error_at(12, format!("bad header: {e}")))
    }

    /// Read the home base: its kind, then its disc or rectangle.
    fn home(&mut self) -> Result<HomeBase> {
        let home_at = self.pos;
        let home = match self.u8("home kind")? {
            0 => HomeBase::Disc {
                center: DVec2::new(self.f64("home x")?, self.f64("home y")?),
                radius_m: self.f64("home radius")?,
            },
            1 => HomeBase::Rect(Aabb {
                min: DVec2::new(self.f64("home min x")?, self.f64("home min y")?),
                max: DVec2::new(self.f64("home max x")?, self.f64("home max y")?),
            }),
            k => return Err(self.error_at(home_at, format!("unknown home base kind {k}"))),
        };
        Ok(home)
    }

    /// Read the treasures: their count, checked against the bytes left, then each one.
    fn treasures(&mut self) -> Result<Vec<TreasureSpec>> {
        let count_at = self.pos;
        let count = self.u32("treasure count")? as usize;
        if count > self.remaining() / 20 {
            return Err(self.error_at(
                count_at,
                format!("claims {count} treasures but only {} bytes follow", self.remaining()),
            ));
        }
        let mut treasures = Vec::with_capacity(count);
        for _ in 0..count {
            let position = DVec2::new(self.f64("treasure x")?, self.f64("treasure y")?);
            treasures.push(TreasureSpec {
                position,
                quantity: self.u32("treasure quantity")?,
            });
        }
        Ok(treasures)
    }

    /// Read the quadtree's node count, checked against its form and the bytes left, then
    /// its packed nodes.
    fn packed_tree(&mut self) -> Result<PackedTree<'a>> {
        let nodes_at = self.pos;
        let nodes = self.u64("node count")?;
        let tree_bytes = nodes.div_ceil(4);
        if nodes == 0 || (nodes - 1) % 4 != 0 {
            return Err(self.error_at(nodes_at, format!("node count {nodes} is not 4k+1")));
        }
        if tree_bytes > self.remaining() as u64 {
            return Err(self.error_at(
                nodes_at,
                format!(
                    "truncated: the tree needs {tree_bytes} bytes, {} remain",
                    self.remaining()
                ),
            ));
        }
        let at = self.pos;
        let packed = self.take(tree_bytes as usize, "tree")?;
        Ok(PackedTree { at, packed, nodes })
    }

    /// Read the checksum, which must end the file, and check it against every byte before
    /// it.
    fn checksum(&mut self) -> Result<()> {
        let crc_at = self.pos;
        let stored = self.u32("checksum")?;
        if self.remaining() != 0 {
            return Err(self.error_at(
                self.pos,
                format!("{} unexpected bytes after the checksum", self.remaining()),
            ));
        }
        let actual = crc32fast::hash(&self.bytes[..crc_at]);
        if stored != actual {
            return Err(self.error_at(
                crc_at,
                format!("checksum mismatch (stored {stored:#010x}, computed {actual:#010x}): the file is corrupt"),
            ));
        }
        Ok(())
    }

    /// Decode the packed quadtree on `grid` into the obstacle map.
    fn obstacles(&self, grid: Grid, tree: &PackedTree<'_>) -> Result<ObstacleMap> {
        let decoded = RegionQuadtree::decode_preorder(grid, tree.packed, tree.nodes)
            .map_err(|(node, e)| self.error_at(tree.at + (node / 4) as usize, e))?;
        ObstacleMap::from_tree(decoded).map_err(|e| self.error_at(tree.at, format!("invalid quadtree: {e}")))
    }

    fn error_at(&self, offset: usize, problem: impl Into<String>) -> Error {
        Error::MapFile {
            path: self.path.to_path_buf(),
            offset: offset as u64,
            problem: problem.into(),
        }
    }
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.remaining() < n {
            return Err(self.error_at(
                self.pos,
                format!(
                    "truncated: file ends inside the {what} ({n} bytes needed, {} left)",
                    self.remaining()
                ),
            ));
        }
        let bytes: &'a [u8] = self.bytes;
        let s = &bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().expect("2 bytes")))
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }
    fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }
}
