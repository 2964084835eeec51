//! The Smart Teams map editor library behind `smartteams-editor`.
