//! Workspace-level integration tests of Smart Teams live in `tests/tests/`; this library
//! holds what tests of several crates share.

pub mod skip;
