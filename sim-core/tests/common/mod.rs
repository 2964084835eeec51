//! Worlds shared by several test files.

use sim_core::agent::TestWorld;
use sim_core::glam::DVec2;

/// A corridor one cell (1 m) wide and 30 long; the robot at (10.5, 1.5) knows x = 7..17, so
/// its frontiers are the west end, 3 m away, and the east end, 6.5 m away.
pub fn corridor_with_two_ends() -> TestWorld {
    corridor(30, 10, 7..17)
}

/// A corridor one cell (1 m) wide and `length` long, walled above and below; the robot
/// stands in cell `robot_x` and knows the cells of `known` (their discs of 0.75 m).
pub fn corridor(length: usize, robot_x: usize, known: std::ops::Range<i32>) -> TestWorld {
    let art = [
        "#".repeat(length),
        format!("{}R{}", ".".repeat(robot_x), ".".repeat(length - robot_x - 1)),
        "#".repeat(length),
    ]
    .join("\n");
    let mut w = TestWorld::from_ascii(&art, 1.0).unwrap();
    for x in known {
        w = w.knowing_disc(DVec2::new(f64::from(x) + 0.5, 1.5), 0.75);
    }
    w
}
