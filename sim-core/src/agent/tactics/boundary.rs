//! Boundary following: slide along an obstacle.

use glam::DVec2;

use crate::agent::ctx::Ctx;

/// Slides along an obstacle: when the desired heading is blocked, turns (to the left) in
/// steps of 30° until the way is free in known terrain.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct BoundaryFollowing;

impl BoundaryFollowing {
    /// A free heading as close as possible to `desired`, turning left; `None` if boxed in.
    pub fn heading(ctx: &Ctx, desired: DVec2) -> Option<DVec2> {
        let p = ctx.position();
        let step = ctx.kind.speed_m_per_round;
        let desired = desired.try_normalize()?;
        (0..12)
            .map(|i| DVec2::from_angle(f64::from(i) * std::f64::consts::TAU / 12.0).rotate(desired))
            .find(|h| ctx.can_move(p, p + *h * step) == Some(true))
    }
}
