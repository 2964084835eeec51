//! Workspace-level integration tests of Smart Teams live in `tests/tests/`.
