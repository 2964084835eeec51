//! The built-in strategies: `random_walk`, `frontier`, `cooperative`, `team`, `excavator`,
//! `transporter`, and `tactics` (composed of tactics by name). They use only sim-core's
//! public API (`crate::agent`, `crate::world`, `crate::spatial`), so a strategy in another
//! crate can do all that they do.

mod composed;
mod explorer;
mod frontier;
mod random_walk;
mod spread;
mod team;
mod worker;

use std::ops::RangeInclusive;

use crate::Result;
use crate::agent::params::{MAX_DISTANCE_M, MAX_ROUNDS};
use crate::agent::{
    MAX_TOUR_STOPS, Params, REPLAN_WHEN_KNOWN, REPLAN_WITHIN_VIEW, REVEAL_FIRST, SEEN_COST_VIEWS, StrategyRegistry,
    TOUR_STOPS,
};

/// Sharing periods, in rounds.
const SHARE_EVERY: RangeInclusive<u64> = 1..=MAX_ROUNDS;

impl StrategyRegistry {
    /// A registry with the built-in strategies.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        register_builtins(&mut r);
        r
    }
}

impl Default for StrategyRegistry {
    /// The built-in strategies.
    fn default() -> Self {
        Self::with_builtins()
    }
}

/// `frontier`'s `replan_within_view`: a lone explorer that searches again as soon as its
/// target is seen within half its view walks less (BENCHMARKS.md, "Exploration quality");
/// `cooperative` keeps [`REPLAN_WITHIN_VIEW`], as in crowds each search costs planning time
/// and moves claims.
const LONE_REPLAN_WITHIN_VIEW: f64 = 0.5;

/// Register every built-in strategy.
fn register_builtins(r: &mut StrategyRegistry) {
    r.register(
        "random_walk",
        "walks straight, turning at random and when blocked",
        |p| Ok(Box::new(random_walk::RandomWalk::from_params(p)?)),
    );
    r.register(
        "frontier",
        "frontier exploration: walks to the nearest boundary between known free space and the unknown \
         (by route, plus seen_cost_views view radii (2) for a view round it already known; those with \
         reveal_first (0.15) of their view unknown first), searching again once its target is seen nearer \
         than replan_within_view of its view radius (0.5), or seen with replan_when_known (0.65) of the view \
         round it known; a target it gets no nearer to for 40 rounds is given up. Of the tour_stops (7) \
         nearest frontiers a view radius apart it heads for the first of the tour that reaches them soonest, \
         weighted by what each reveals, while it has seen no other robot for 50 rounds (0: the nearest)",
        |p| Ok(Box::new(lone_frontier(p)?)),
    );
    r.register(
        "cooperative",
        "frontier exploration that shares known maps and treasure sightings, and avoids team mates' goals \
         (the max_claims most recently heard, 64 by default; by a detour of at most max_detour_m, \
         unbounded by default; in teams of fewer than 12 mates heard, a robot yields a target to a mate \
         with a lower id that announces a goal near it, and in teams of 3 to 12 a robot whose new target is \
         nearer to a mate's goal than to itself, or that a mate's announced walk passes, leaves it to the \
         mate and waits wait_rounds rounds, 5 by \
         default, 0: never, stepping out of the way of mates held back near it; in teams of fewer than 12 mates heard, a robot takes of the compare_frontiers \
         frontiers nearest to it, 8 by default, the one fewest mates' goals are nearer to, 0: the nearest \
         frontier clear of them); replan_within_view as for frontier (0.25); once it has heard spoke_mates \
         team mates (never by default), it walks out along its bearing from home to just beyond the edge \
         of its known map, exploring frontiers where that is blocked",
        |p| Ok(Box::new(cooperative(p)?)),
    );
    r.register(
        "team",
        "explorers in groups: the lowest id in radio range leads (frontier exploration), the others follow it",
        |p| Ok(Box::new(team::TeamExplorer::from_params(p)?)),
    );
    r.register(
        "excavator",
        "goes to the nearest known treasure in its sector or within near_m (40) that no nearer excavator claimed, \
         claims it and digs it out; with none, waits at its post on its bearing, post_behind_m (0) behind the edge \
         of its known map; its sector narrows with the team mates heard (sector_overlap 5)",
        |p| Ok(Box::new(worker::Excavator::from_params(p)?)),
    );
    r.register_composed(
        "tactics",
        "tactics named in 'tactics' (priority order; each sees every round, the first to suggest acts), \
         with an optional goal=\"X,Y\" and TACTIC.PARAM parameters; see `smartteams tactics`",
        |p, tactics| Ok(Box::new(composed::Composed::from_params(p, tactics)?)),
    );
    r.register(
        "transporter",
        "fetches dug units (waiting at treasures being dug), one transporter per treasure, chosen as excavators \
         choose (near_m 60, sector_overlap 12, post_behind_m 15), and delivers them home as soon as no loose units \
         it knows of are left",
        |p| Ok(Box::new(worker::Transporter::from_params(p)?)),
    );
}

/// `frontier` from its parameters: a lone explorer ranking frontiers by target, with tours.
fn lone_frontier(p: &Params) -> Result<frontier::Frontier> {
    p.only(&[
        "replan_within_view",
        "seen_cost_views",
        "reveal_first",
        "replan_when_known",
        "tour_stops",
    ])?;
    let replan = p.f64_in("replan_within_view", LONE_REPLAN_WITHIN_VIEW, 0.0..=1.0)?;
    let by_target = frontier::ByTarget {
        seen_cost_views: p.f64_in("seen_cost_views", SEEN_COST_VIEWS, 0.0..=100.0)?,
        reveal_first: p.f64_in("reveal_first", REVEAL_FIRST, 0.0..=1.0)?,
        replan_when_known: p.f64_in("replan_when_known", REPLAN_WHEN_KNOWN, 0.0..=1.0)?,
        tour_stops: usize::try_from(p.u64_in("tour_stops", TOUR_STOPS as u64, 0..=MAX_TOUR_STOPS as u64)?)
            .unwrap_or(TOUR_STOPS),
    };
    Ok(frontier::Frontier::new(None, replan, Some(by_target)))
}

/// `cooperative` from its parameters: an explorer that shares with its team.
fn cooperative(p: &Params) -> Result<frontier::Frontier> {
    p.only(&[
        "share_every",
        "avoid_radius_m",
        "max_claims",
        "max_detour_m",
        "replan_within_view",
        "spoke_mates",
        "wait_rounds",
        "compare_frontiers",
    ])?;
    let share = explorer::Sharing::from_params(p)?;
    let replan = p.f64_in("replan_within_view", REPLAN_WITHIN_VIEW, 0.0..=1.0)?;
    Ok(frontier::Frontier::new(Some(share), replan, None))
}
