//! `compose`: a map from an XML scene of shapes.

use std::path::Path;

use sim_core::MapData;

use crate::{EditorError, Result};

/// Build the map described by the scene file at `path`.
pub fn compose_file(path: &Path) -> Result<MapData> {
    Err(EditorError::bad_input(path, "compose is not implemented yet"))
}
