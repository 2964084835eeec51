//! The bridge from a Smart Teams simulation to its users: the `smartteams` runner.
