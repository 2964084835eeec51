//! Layer 1, spatial structures: geometry, the grid, the region quadtree behind obstacle and
//! known maps, the treasure PR-quadtree, the robot hash grid, the navigation graph, and the
//! ids that key them. Imports nothing from the layers above.

mod anyangle;
mod geometry;
mod grid;
mod ids;
mod known_map;
mod known_window;
mod nav;
mod obstacle_map;
mod quadtree;
mod robot_index;
mod treasure_index;
mod view_stencil;

pub use anyangle::{AnyAnglePath, AnyAnglePlanner, MAX_RASTER_CELLS, MAX_VERTICES, NoPath, reference};
pub use geometry::{
    Aabb, BlockCells, Capsule, CellMasks, CellRows, Clipped, Disc, DiscBeyond, Overlap, Shape, clip_line, clip_segment,
    nearest_point_on_segment, point_segment_distance_squared, segment_box_distance_squared,
    segment_enters_box_interior,
};
pub use grid::{Grid, MAX_DEPTH};
pub use ids::{RobotId, TreasureId};
pub use known_map::KnownMap;
pub use nav::{FoundGoal, LazyNavGraph, NavGraph, NavNodeId, Piece, PieceMemo, Route, Terrain};
pub use obstacle_map::ObstacleMap;
pub use quadtree::{BitGrid, CellSet, Components, PartialCells, Region, RegionQuadtree, Square};
pub(crate) use quadtree::{BlockMemo, Finger};
pub(crate) use robot_index::Entry as IndexEntry;
pub use robot_index::RobotIndex;
pub use treasure_index::{BUCKET, Treasure, TreasureIndex};
