//! The Smart Teams map editor library behind `smartteams-editor`.
//!
//! Maps come from generators ([`generate`]), images and foreign map formats ([`import`]) and
//! XML scenes of shapes ([`compose`]); [`place`] sets the home base and scatters treasures,
//! [`validate`] checks a map, [`stats`] describes it and [`preview`] draws it. Everything is
//! written as sim-core's map file ([`sim_core::world::MapData`]).
//!
//! Orientation everywhere: image row 0 is the top of the map, world y points up, and the
//! map's lower-left corner is its origin.

pub mod compose;
pub mod error;
pub mod generate;
pub mod import;
pub mod path;
pub mod place;
pub mod preview;
pub mod progress;
pub mod raster;
pub mod shapes;
pub mod stats;
pub mod validate;

pub use error::{EditorError, Result};
