//! Worlds shared by several test files.

use sim_core::agent::TestWorld;
use sim_core::glam::DVec2;

/// A corridor one cell (1 m) wide and 30 long; the robot at (10.5, 1.5) knows x = 7..17, so
/// its frontiers are the west end, 3 m away, and the east end, 6.5 m away.
pub fn corridor_with_two_ends() -> TestWorld {
    let art = [
        "#".repeat(30),
        format!("{}R{}", ".".repeat(10), ".".repeat(19)),
        "#".repeat(30),
    ]
    .join("\n");
    let mut w = TestWorld::from_ascii(&art, 1.0).unwrap();
    for x in 7..17 {
        w = w.knowing_disc(DVec2::new(f64::from(x) + 0.5, 1.5), 0.75);
    }
    w
}
