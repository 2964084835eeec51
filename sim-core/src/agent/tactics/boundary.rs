//! Boundary following: round an obstacle to the goal (Bug2).

use glam::DVec2;

use super::Tactic;
use crate::agent::ctx::Ctx;
use crate::agent::strategy::Needs;
use crate::world::Action;

/// How close to the goal counts as there.
const ARRIVED_M: f64 = 0.05;
/// Headings tried a round: every 15°.
const HEADINGS: u32 = 24;

/// Goes to the goal ([`Ctx::goal`]) straight where it can; at an obstacle it follows the
/// obstacle's boundary, keeping it on its right, until it is back on the line from where it
/// met the obstacle to the goal, closer to the goal than where it met it, with the way on
/// free: Lumelsky and Stepanov's Bug2, which gets round any obstacle, concave ones included
/// (each obstacle is left closer to the goal than it was met, so it ends). Only known
/// terrain is tested (unknown terrain counts as free until seen). Quiet with no goal, at
/// the goal, when boxed in, or once it has gone all the way round an obstacle (the goal
/// cannot be reached).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct BoundaryFollowing {
    goal: Option<DVec2>,
    /// Where the robot met the obstacle it follows: the line to leave on runs from here to
    /// the goal.
    line_from: DVec2,
    following: Option<Following>,
    unreachable: bool,
}

/// The boundary being followed.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct Following {
    /// Where the obstacle was met, and how far the goal was from there.
    hit: DVec2,
    hit_distance_m: f64,
    heading: DVec2,
    travelled_m: f64,
    /// Side of the line the robot was on last round (−1, 0, 1).
    side: i8,
}

impl BoundaryFollowing {
    /// A free heading as close as possible to `desired`, turning left in steps of 30°;
    /// `None` if boxed in. (A one-round answer without memory, for strategies that only
    /// need to slide along a wall.)
    pub fn heading(ctx: &Ctx, desired: DVec2) -> Option<DVec2> {
        let p = ctx.position();
        let step = ctx.kind.speed_m_per_round;
        let desired = desired.try_normalize()?;
        (0..12)
            .map(|i| DVec2::from_angle(f64::from(i) * std::f64::consts::TAU / 12.0).rotate(desired))
            .find(|h| ctx.can_move(p, p + *h * step) == Some(true))
    }

    /// Whether it is following an obstacle's boundary now.
    pub fn is_following(&self) -> bool {
        self.following.is_some()
    }

    /// The side of the line (start → goal) that `p` lies on: −1, 0 (on it, within
    /// `tolerance_m`) or 1.
    fn side(&self, goal: DVec2, p: DVec2, tolerance_m: f64) -> i8 {
        let line = goal - self.line_from;
        let len = line.length();
        if len == 0.0 {
            return 0;
        }
        let offset = line.perp_dot(p - self.line_from) / len;
        if offset.abs() <= tolerance_m {
            0
        } else if offset > 0.0 {
            1
        } else {
            -1
        }
    }
}

/// Whether a step from `p` along unit `h` is free (unknown terrain counts as free).
fn free(ctx: &Ctx, p: DVec2, h: DVec2, step: f64) -> bool {
    ctx.can_move(p, p + h * step) != Some(false)
}

/// The `i`-th of [`HEADINGS`] headings counter-clockwise from `from`.
fn turned(from: DVec2, i: u32) -> DVec2 {
    DVec2::from_angle(f64::from(i) * std::f64::consts::TAU / f64::from(HEADINGS)).rotate(from)
}

impl Tactic for BoundaryFollowing {
    fn suggest(&mut self, ctx: &mut Ctx) -> Option<Action> {
        let goal = ctx.goal()?;
        let p = ctx.position();
        if self.goal != Some(goal) {
            *self = Self {
                goal: Some(goal),
                line_from: p,
                following: None,
                unreachable: false,
            };
        }
        let to_goal = goal - p;
        let distance = to_goal.length();
        if self.unreachable || distance <= ARRIVED_M {
            return None;
        }
        let speed = ctx.kind.speed_m_per_round;
        let dir = to_goal / distance;
        let straight = distance.min(speed);
        let Some(mut f) = self.following else {
            if free(ctx, p, dir, straight) {
                return Some(Action::MoveTo { to: p + dir * straight });
            }
            // Met an obstacle: turn left until free, so that it is on the right. The line
            // to leave on runs from here to the goal (where the robot was heading: it may
            // have been pushed off the line it started on, by robots or trimmed moves).
            let heading = (1..HEADINGS)
                .map(|i| turned(dir, i))
                .find(|&h| free(ctx, p, h, speed))?;
            self.line_from = p;
            self.following = Some(Following {
                hit: p,
                hit_distance_m: distance,
                heading,
                travelled_m: speed,
                side: 0,
            });
            return Some(Action::MoveTo {
                to: p + heading * speed,
            });
        };
        // Leave on the line, closer to the goal than where the obstacle was met: the
        // line is crossed when the side changes (steps may jump over it).
        let side = self.side(goal, p, 0.5 * speed);
        let on_line = side == 0 || side != f.side;
        f.side = side;
        if on_line && distance < f.hit_distance_m - 0.5 * speed && free(ctx, p, dir, straight) {
            self.following = None;
            return Some(Action::MoveTo { to: p + dir * straight });
        }
        // All the way round: back at the hit point.
        if f.travelled_m > 4.0 * speed && p.distance(f.hit) < speed {
            self.unreachable = true;
            self.following = None;
            return None;
        }
        // Keep the obstacle on the right: sweep from a right turn counter-clockwise and
        // take the first free heading after a blocked one; if the right is all free the
        // boundary turned away (a convex corner), so turn right towards it, 45° a round.
        let right = turned(f.heading, HEADINGS * 3 / 4);
        let heading = if free(ctx, p, right, speed) {
            Some(turned(f.heading, HEADINGS * 7 / 8)).filter(|&h| free(ctx, p, h, speed))
        } else {
            None
        }
        .or_else(|| {
            (1..HEADINGS)
                .map(|i| turned(right, i))
                .find(|&h| free(ctx, p, h, speed))
        })?;
        f.heading = heading;
        f.travelled_m += speed;
        self.following = Some(f);
        Some(Action::MoveTo {
            to: p + heading * speed,
        })
    }

    fn needs(&self) -> Needs {
        Needs::NAVIGATION
    }

    crate::serde_state!();
}
