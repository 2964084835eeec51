//! `frontier` and `cooperative`.

use glam::{DVec2, Vec2};

use super::explorer::{Explorer, Sharing, share_knowledge};
use super::spread::{MatesSketch, Spoke};
use crate::agent::{Ctx, FrontierSeeking, Needs, Strategy, Tour};
use crate::spatial::nearest_point_on_segment;
use crate::world::{Action, Payload};

/// Team mates' goals, with the round heard, sorted by robot id: 16 bytes a claim, as a
/// crowded robot's claims are read and written in full every round. The round is kept in
/// 32 bits (saturating after 4×10⁹ rounds), the goal in single precision from the robot's
/// home centre ([`stored_goal`]): within 6 mm on a 100 km map whatever its origin (half a
/// unit in the last place, 4 mm, on each axis), against avoidance radii of metres.
/// `claimed_goals_come_back_within_6_mm_anywhere` checks the bound.
type Claims = Vec<Claim>;

/// One claim of [`Claims`]: (robot id, goal, round heard).
type Claim = (u32, Vec2, u32);

/// A team mate's goal as a claim keeps it: from `home` (the robot's home centre), in single
/// precision (see [`Claims`]).
fn stored_goal(goal: DVec2, home: DVec2) -> Vec2 {
    (goal - home).as_vec2()
}

/// A team mate's last announced walk: from where it stood to its goal.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct MateWalk {
    id: u32,
    from: DVec2,
    goal: DVec2,
    heard_round: u64,
}

impl MateWalk {
    /// Whether the mate, walking straight on, passes within `reach_m` of `target`: the
    /// point of its walk nearest the target is within `reach_m` of it, and the walk there
    /// is a straight move `ctx`'s robot knows to be free.
    fn passes(&self, ctx: &Ctx, target: DVec2, reach_m: f64) -> bool {
        let near = nearest_point_on_segment(target, self.from, self.goal);
        near.distance(target) <= reach_m && ctx.can_move(self.from, near) == Some(true)
    }
}

/// Note a mate's announcement in a small team's `walks`: its walk from `from` to `goal`
/// replaces its last, or without a goal, the mate has none.
fn note_walk(walks: &mut Vec<MateWalk>, id: u32, from: DVec2, goal: Option<DVec2>, heard_round: u64) {
    walks.retain(|w| w.id != id);
    if let Some(goal) = goal {
        walks.push(MateWalk {
            id,
            from,
            goal,
            heard_round,
        });
    }
}

/// The goal a claim holds ([`stored_goal`]'s inverse, to single precision).
fn goal_of(stored: Vec2, home: DVec2) -> DVec2 {
    home + stored.as_dvec2()
}

/// What a round's announcements do to the claims: a goal to keep (`Some`) or forget.
type Update = (u32, Option<Vec2>);

/// Of `updates` (sorted by robot id), each robot's last: the one that counts.
fn last_words(updates: &[Update]) -> impl Iterator<Item = Update> + '_ {
    updates
        .iter()
        .enumerate()
        .filter(|&(k, u)| updates.get(k + 1).is_none_or(|next| next.0 != u.0))
        .map(|(_, &u)| u)
}

/// `claims` with `updates` applied (both sorted by robot id; of a robot's updates the
/// last counts), into `out`, by one merge of the two lists: what applying the updates one
/// by one to a map gives (`merged_claims_equal_updates_applied_one_by_one`).
// Out of line, as is the cut below: inlined, they slow `decide` down.
#[inline(never)]
fn merge_claims(claims: &[Claim], updates: &[Update], round: u32, out: &mut Claims) {
    out.clear();
    let mut i = 0;
    for (id, goal) in last_words(updates) {
        while i < claims.len() && claims[i].0 < id {
            out.push(claims[i]);
            i += 1;
        }
        if i < claims.len() && claims[i].0 == id {
            i += 1;
        }
        if let Some(g) = goal {
            out.push((id, g, round));
        }
    }
    out.extend_from_slice(&claims[i..]);
}

/// Keep the `max` claims heard last (of those heard in the same round, the lowest ids),
/// in id order. Claims were heard in the last 60 rounds (older ones are forgotten every
/// 10), so the cut is found by counting claims per round heard, without sorting.
fn keep_newest(claims: &mut Claims, max: usize, round: u64) {
    if let Some(mut keep) = newest_cut(claims, max, round) {
        claims.retain(|c| keep.keeps(c));
    }
}

/// Empties `out` and gives it room for `n` claims. It grows by doubling, up to `max` claims
/// (or `n`, if more), and a new block replaces the old rather than copying it: fitted
/// exactly, a crowded robot's list would be regrown and copied nearly every round.
/// `claims_keep_the_most_recently_heard` checks the block stays within `max` claims.
fn empty_with_room(out: &mut Claims, n: usize, max: usize) {
    out.clear();
    if out.capacity() < n {
        *out = Vec::with_capacity(n.max(2 * out.capacity()).min(max.max(n)));
    }
}

/// [`keep_newest`] of `claims`, written into `out` (its capacity at most `max` claims, or
/// what is kept if more): the merged claims are cut while they are copied back, in one
/// pass. `claims_keep_the_most_recently_heard` checks both keep the same claims.
#[inline(never)]
fn keep_newest_into(claims: &[Claim], max: usize, round: u64, out: &mut Claims) {
    match newest_cut(claims, max, round) {
        None => {
            empty_with_room(out, claims.len(), max);
            out.extend_from_slice(claims);
        }
        Some(mut keep) => {
            empty_with_room(out, max, max);
            for c in claims {
                if keep.keeps(c) {
                    out.push(*c);
                }
            }
        }
    }
}

/// Which claims [`keep_newest`] keeps: those heard less than `cut` rounds ago, and the
/// first `room` (in id order) of those heard `cut` rounds ago (63: that long or longer).
struct NewestCut {
    round: u64,
    cut: usize,
    room: usize,
    /// `round - cut`: claims heard later are kept.
    newer_than: i64,
}

impl NewestCut {
    fn age(&self, heard: u32) -> usize {
        (self.round.saturating_sub(u64::from(heard))).min(63) as usize
    }

    /// Whether claim `c` is kept (called once per claim, in id order).
    #[inline]
    fn keeps(&mut self, c: &Claim) -> bool {
        // `age < cut`: heard after `round - cut` (the cut is at most 63, below the clamp).
        if i64::from(c.2) > self.newer_than {
            return true;
        }
        if self.room > 0 && self.age(c.2) == self.cut {
            self.room -= 1;
            return true;
        }
        false
    }
}

/// The cut of [`keep_newest`], or `None` if all `claims` fit in `max`.
fn newest_cut(claims: &[Claim], max: usize, round: u64) -> Option<NewestCut> {
    if claims.len() <= max {
        return None;
    }
    let mut keep = NewestCut {
        round,
        cut: 63,
        room: 0,
        newer_than: 0,
    };
    let mut per_age = [0usize; 64];
    for c in claims {
        per_age[keep.age(c.2)] += 1;
    }
    // The oldest age kept, and how many claims of that age fit.
    let mut kept = 0;
    for (a, &n) in per_age.iter().enumerate() {
        if kept + n >= max {
            (keep.cut, keep.room) = (a, max - kept);
            break;
        }
        kept += n;
    }
    keep.newer_than = i64::try_from(round).unwrap_or(i64::MAX) - keep.cut as i64;
    Some(keep)
}

/// The claims `updates` (sorted by robot id) make, heard in `round`: each robot's last
/// word, if it names a goal.
fn fresh_claims(updates: &[Update], round: u64) -> impl Iterator<Item = Claim> + '_ {
    let heard = heard_in(round);
    last_words(updates).filter_map(move |(id, goal)| goal.map(|g| (id, g, heard)))
}

/// Apply a round's announcements `updates` (sorted by robot id) to `claims`, then, if
/// `cut_now`, keep the `max` heard last ([`keep_newest`]); `merged` is a buffer. Without
/// `cut_now` the claims may come back cut all the same when the round's fresh claims alone
/// fill `max`, which is what any later forgetting of old or far claims and cut would leave
/// as long as it keeps every claim heard in `round`. `claims_heard_equal_merged_then_cut`
/// checks both paths against a merge and a cut.
fn hear_claims(claims: &mut Claims, updates: &[Update], round: u64, max: usize, cut_now: bool, merged: &mut Claims) {
    if max == 0 || fresh_claims(updates, round).nth(max - 1).is_some() {
        // The round's fresh claims fill `max` on their own: the cut keeps the first `max` of
        // them, all heard now, and none of the old, which are not read.
        empty_with_room(claims, max, max);
        claims.extend(fresh_claims(updates, round).take(max));
        return;
    }
    merge_claims(claims, updates, heard_in(round), merged);
    if cut_now {
        keep_newest_into(merged, max, round, claims);
    } else {
        empty_with_room(claims, merged.len(), max);
        claims.extend_from_slice(merged);
    }
}

/// A round as a claim keeps it (see [`Claims`]).
fn heard_in(round: u64) -> u32 {
    u32::try_from(round).unwrap_or(u32::MAX)
}

/// A mate's announcement as a walk ([`note_walk`]'s arguments but the round): its id, where
/// it stood, its goal.
type HeardWalk = (u32, DVec2, Option<DVec2>);

thread_local! {
    /// A worker's buffers for a round's announcements, the merged claims and the walks heard.
    static SCRATCH: std::cell::RefCell<(Vec<Update>, Claims, Vec<HeardWalk>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new(), Vec::new())) };
}

/// `frontier` and `cooperative`.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Frontier {
    core: Explorer,
    sharing: Option<Sharing>,
    /// Team mates' announced goals, with the round heard, sorted by robot id: forgotten
    /// after 50 rounds and, in a crowd, when farther than 20 m or 4 `avoid_radius_m`. In a
    /// crowd hundreds arrive a round, in sender order, so they are merged into this sorted
    /// list in one pass.
    claims: Claims,
    announced: Option<DVec2>,
    shared_area: f64,
    /// With `spoke_mates`, the walk out along the robot's bearing.
    #[serde(default)]
    spoke: Option<Spoke>,
    /// Team mates heard: counted until they reach [`SMALL_TEAM_MATES`], or for good with a
    /// spoke (which needs their number).
    #[serde(default)]
    mates: MatesSketch,
    /// It has heard [`SMALL_TEAM_MATES`] team mates or more: a crowd, where goals are not
    /// settled between mates (see [`Frontier::yield_to_lower_ids`]).
    #[serde(default)]
    crowd: bool,
    /// The round until which it waits, having left its target to a team mate (see
    /// [`Frontier::leave_to_mates`]).
    #[serde(default)]
    waiting_until: u64,
    /// Where the robot stood last round (for [`Frontier::held_back`]).
    #[serde(default)]
    last_position: Option<DVec2>,
    /// A lone explorer's tour (`frontier` with `tour_stops` above 0), planned while it has
    /// seen no other robot for [`COMPANY_ROUNDS`].
    #[serde(default)]
    tour: Option<Tour>,
    /// The round until which a lone explorer heads for the nearest frontier instead, having
    /// seen another robot.
    #[serde(default)]
    company_until: u64,
    /// In a small team, each mate's last announced walk (at most one a mate, fewer than
    /// [`SMALL_TEAM_MATES`]; none in a crowd).
    #[serde(default)]
    walks: Vec<MateWalk>,
}

/// Rounds a lone `frontier` robot that saw another robot heads for the nearest frontier
/// rather than plan tours: robots that set out together would plan much the same tours and
/// walk together (BENCHMARKS.md, "The paper's Fig. 4").
const COMPANY_ROUNDS: u64 = 50;

/// `cooperative` robots that have heard fewer team mates than this settle clashing goals
/// ([`Frontier::yield_to_lower_ids`]); in crowds each clash would cost a search.
const SMALL_TEAM_MATES: f64 = 12.0;

/// Team mates a `cooperative` robot must have heard (and fewer than [`SMALL_TEAM_MATES`])
/// before it leaves targets to them ([`Frontier::leave_to_mates`]): with one mate, waiting
/// costs more time than the walk it saves (BENCHMARKS.md, "Exploration quality").
const WAITING_TEAM_MATES: f64 = 2.0;

/// Rounds a team mate's announced goal is kept without news of it.
const CLAIM_KEPT_ROUNDS: u64 = 50;

/// How a lone explorer (`frontier`) ranks frontiers and when it searches again (see
/// `FrontierSeeking::with_ranking_by_target`, `with_reveal_first` and
/// `with_replan_when_known`).
#[derive(Clone, Copy, Debug)]
pub(super) struct ByTarget {
    /// View radii charged for a view round the target wholly known.
    pub(super) seen_cost_views: f64,
    /// Frontiers with at least this part of their view unknown are taken first.
    pub(super) reveal_first: f64,
    /// Search again once the target is known with this part of the view round it.
    pub(super) replan_when_known: f64,
    /// Plan tours over this many nearest frontiers (0: head for the nearest).
    pub(super) tour_stops: usize,
}

impl Frontier {
    /// An explorer that shares with `sharing` (`None`: alone) and searches again once its
    /// target is known and nearer than `replan_within_view` of its view radius. With
    /// `by_target` it ranks frontiers by the walk to their targets, as [`ByTarget`] says;
    /// without, by the walk to the pieces holding them.
    pub(super) fn new(sharing: Option<Sharing>, replan_within_view: f64, by_target: Option<ByTarget>) -> Self {
        let mut core = Explorer::default();
        core.frontier = FrontierSeeking::default()
            .with_replan_within_view(replan_within_view)
            .with_ranking_by_target(by_target.map(|b| b.seen_cost_views))
            .with_reveal_first(by_target.map_or(0.0, |b| b.reveal_first))
            .with_replan_when_known(by_target.map(|b| b.replan_when_known));
        let tour = by_target.filter(|b| b.tour_stops > 0).map(|b| Tour {
            stops: b.tour_stops,
            ..Tour::default()
        });
        Self {
            core,
            sharing,
            claims: Claims::default(),
            announced: None,
            shared_area: 0.0,
            spoke: sharing.and_then(|s| s.spoke_mates).map(Spoke::from_mates),
            mates: MatesSketch::default(),
            crowd: false,
            waiting_until: 0,
            last_position: None,
            tour,
            company_until: 0,
            walks: Vec::new(),
        }
    }

    /// A lone explorer plans tours while it has seen no other robot for [`COMPANY_ROUNDS`],
    /// and heads for the nearest frontier otherwise.
    fn tour_while_alone(&mut self, ctx: &Ctx) {
        let Some(tour) = self.tour else {
            return;
        };
        if !ctx.robots_in_view().is_empty() {
            self.company_until = ctx.round + COMPANY_ROUNDS;
        }
        let alone = ctx.round >= self.company_until;
        self.core.frontier.set_tour(alone.then_some(tour));
    }

    /// When a team mate with a lower id announced this round a goal within `radius_m` of
    /// this robot's target, drop the route: the next search avoids the mate's goal. Robots
    /// that set out together pick the same nearest frontier before they hear each other;
    /// without this the higher ids follow the lowest until their targets are reached.
    fn yield_to_lower_ids(&mut self, ctx: &Ctx, radius_m: f64) -> bool {
        let (me, now, home) = (ctx.me.id.get(), heard_in(ctx.round), ctx.home().center());
        let nav = self.core.frontier.navigator();
        let clash = nav.destination().is_some_and(|target| {
            self.claims
                .iter()
                .any(|&(id, goal, heard)| id < me && heard == now && goal_of(goal, home).distance(target) <= radius_m)
        });
        if clash {
            nav.clear();
        }
        clash
    }

    /// The rounds this robot waits when it leaves a target to its team mates, if it does:
    /// it shares, waits a positive number of rounds, and is in a small team of at least
    /// [`WAITING_TEAM_MATES`] mates heard.
    fn leaves_targets(&self) -> Option<u64> {
        self.sharing
            .map(|s| s.wait_rounds)
            .filter(|&w| w > 0 && !self.crowd && self.mates.count() >= WAITING_TEAM_MATES)
    }

    /// Leave a new target to a team mate: when the target (set this round, `before` being
    /// the goal before, or found again after yielding it) lies nearer to a mate's announced
    /// goal than the robot's route to it, or a mate's announced walk passes within a view
    /// radius of it from nearer than that route ([`MateWalk::passes`]), drop the route and
    /// wait `wait_rounds` (then search again). The mate, once at its goal or on its way, is
    /// nearer; walking there would cross the ground the mate is exploring. It leaves the
    /// target until it no longer keeps the mate's goal or walk ([`CLAIM_KEPT_ROUNDS`]
    /// without news of it). Returns whether the robot waits. O(claims + walks), a swept-disc
    /// test for each walk that passes near.
    fn leave_to_mates(&mut self, ctx: &mut Ctx, before: Option<DVec2>, yielded: bool, wait_rounds: u64) -> bool {
        let Some(target) = ctx.goal().filter(|&t| yielded || Some(t) != before) else {
            return false;
        };
        let (me, home) = (ctx.me.id.get(), ctx.home().center());
        let nav = self.core.frontier.navigator();
        let walk_m = nav.remaining_m(ctx.position());
        let nearer_goal = self
            .claims
            .iter()
            .any(|&(id, goal, _)| id != me && goal_of(goal, home).distance(target) < walk_m);
        let (view_m, round) = (ctx.kind.view_radius_m, ctx.round);
        let nearer_mate = nearer_goal
            || self.walks.iter().any(|w| {
                w.id != me
                    && round <= w.heard_round + CLAIM_KEPT_ROUNDS
                    && w.from.distance(target) < walk_m
                    && w.passes(ctx, target, view_m)
            });
        if nearer_mate {
            nav.clear();
            ctx.set_goal(None);
            self.waiting_until = ctx.round + wait_rounds;
        }
        nearer_mate
    }

    /// A sharing robot's round with its team: share its known map as `share` says, take in
    /// the goals its mates announced (see [`Claims`]), count the mates heard, and in a small
    /// team yield a clashing target to a lower id ([`Frontier::yield_to_lower_ids`]; returns
    /// whether it did).
    fn hear_team(&mut self, ctx: &mut Ctx, share: Sharing) -> bool {
        share_knowledge(ctx, share.every_rounds, &mut self.shared_area);
        let radius = share.avoid_radius_m;
        let home = ctx.home().center();
        // In a crowd only claims near enough to matter are kept, so crowds stay cheap. A
        // small team keeps every mate's goal, however far: heard from a mate about to
        // leave radio range, it keeps the two apart after they part.
        let near = if self.crowd {
            (4.0 * radius).max(20.0)
        } else {
            f64::INFINITY
        };
        let p = ctx.position();
        let round = ctx.round;
        // This round's announcements, and the merge, in buffers of the worker thread, not
        // of the robot: spare copies per robot would cost megabytes in a crowd, and fresh
        // ones each round would keep the allocator busy.
        SCRATCH.with_borrow_mut(|(updates, merged, heard_walks)| {
            updates.clear();
            heard_walks.clear();
            let counting = !self.crowd || self.spoke.is_some();
            let mut mates = counting.then_some(&mut self.mates);
            let mut walks = (!self.crowd).then_some(&mut *heard_walks);
            updates.extend(ctx.messages().iter().filter_map(|m| match m.payload {
                Payload::Position { goal, position } => {
                    if let Some(walks) = walks.as_deref_mut() {
                        walks.push((m.from.get(), position, goal));
                    }
                    if let Some(mates) = mates.as_deref_mut() {
                        mates.heard(m.from);
                    }
                    Some((
                        m.from.get(),
                        goal.filter(|g| g.distance(p) <= near).map(|g| stored_goal(g, home)),
                    ))
                }
                _ => None,
            }));
            if !updates.is_empty() {
                // Inboxes come in sender order; sort (stably: a sender's last word wins)
                // if not.
                if !updates.is_sorted_by_key(|u| u.0) {
                    updates.sort_by_key(|u| u.0);
                }
                // Every round but each tenth the merged claims are cut at once; each
                // tenth, old and far ones are forgotten before the cut (below). The
                // announcements' goals are all within `near` of `p`, as that asks.
                let cut_now = !round.is_multiple_of(10);
                hear_claims(&mut self.claims, updates, round, share.max_claims, cut_now, merged);
            }
            // A crowd never reads walks: a robot that has just heard enough mates to be one
            // notes none of this round's (each costs O(walks), and a crowd hears hundreds)
            // and drops those it kept.
            self.crowd = self.crowd || self.mates.count() >= SMALL_TEAM_MATES;
            if self.crowd {
                self.walks = Vec::new();
            } else {
                for &(id, from, goal) in heard_walks.iter() {
                    note_walk(&mut self.walks, id, from, goal, round);
                }
            }
        });
        if round.is_multiple_of(10) {
            self.walks.retain(|w| round <= w.heard_round + CLAIM_KEPT_ROUNDS);
            self.claims.retain(|(_, g, heard)| {
                round <= u64::from(*heard) + CLAIM_KEPT_ROUNDS && goal_of(*g, home).distance(p) <= near
            });
        }
        keep_newest(&mut self.claims, share.max_claims, round);
        !self.crowd && self.yield_to_lower_ids(ctx, radius)
    }

    /// Whether the robot, walking to a goal, moved less than half a step last round: held
    /// back by a wall or by robots (a waiting mate makes way when told, see [`make_way`]).
    /// Called once a round: it notes the position.
    fn held_back(&mut self, ctx: &Ctx) -> bool {
        let p = ctx.position();
        let moved_m = self.last_position.replace(p).map_or(f64::INFINITY, |q| q.distance(p));
        ctx.goal().is_some()
            && matches!(ctx.me.last_action.0, Action::MoveTo { .. })
            && moved_m < 0.5 * ctx.kind.speed_m_per_round
    }

    /// Announce the goal to team mates when it changed (claims stay cheap in crowds), or
    /// `again`.
    fn announce_goal(&mut self, ctx: &mut Ctx, again: bool) {
        if self.sharing.is_some() && (again || ctx.goal() != self.announced) {
            self.announced = ctx.goal();
            let goal = ctx.goal();
            ctx.broadcast(Payload::Position {
                position: ctx.position(),
                goal,
            });
        }
    }
}

impl Strategy for Frontier {
    crate::serde_state!();

    fn needs(&self) -> Needs {
        Needs {
            // Other robots are looked at only by a lone explorer with a tour, to know
            // whether it is alone: the physical unit prevents collisions and the collision
            // tactic handles being stuck.
            robots: self.tour.is_some(),
            treasures: self.sharing.is_some(),
            messages: self.sharing.is_some(),
            ..Needs::ALL
        }
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let max_detour_m = self.sharing.and_then(|s| s.max_detour_m).unwrap_or(f64::INFINITY);
        // Claims keep their goals from here (see [`Claims`]).
        let home = ctx.home().center();
        let (radius, yielded) = if let Some(share) = self.sharing {
            let yielded = self.hear_team(ctx, share);
            (share.avoid_radius_m, yielded)
        } else {
            (0.0, false)
        };
        self.tour_while_alone(ctx);
        if let Some(a) = self.core.reflexes(ctx) {
            if let Some(spoke) = &mut self.spoke {
                spoke.interrupt();
            }
            return a;
        }
        let leaves_targets = self.leaves_targets();
        // Held back, it tells the waiting mates in its way (see [`make_way`]).
        let held_back = leaves_targets.is_some() && self.held_back(ctx);
        if leaves_targets.is_some() && ctx.round < self.waiting_until {
            ctx.set_goal(None);
            self.announce_goal(ctx, false);
            return make_way(ctx).unwrap_or(Action::Idle);
        }
        let before = ctx.goal();
        let claims = &self.claims;
        let spoke = self.spoke.as_mut();
        let mates_heard = self.mates.count();
        // In crowds each comparison would cost a longer search.
        let compare = self.sharing.filter(|_| !self.crowd).map_or(0, |s| s.compare_frontiers);
        let action = if let Some(a) = spoke.and_then(|s| s.step(ctx, self.core.frontier.navigator(), mates_heard)) {
            a
        } else {
            let a = self.core.explore(
                ctx,
                || claims.iter().map(|c| goal_of(c.1, home)).collect(),
                radius,
                max_detour_m,
                compare,
            );
            if leaves_targets.is_some_and(|wait_rounds| self.leave_to_mates(ctx, before, yielded, wait_rounds)) {
                Action::Idle
            } else {
                a
            }
        };
        self.announce_goal(ctx, held_back);
        action
    }
}

/// A waiting robot's step out of the way of the nearest team mate that announced its goal
/// last round from within two steps of touching it (as a robot held back does): a step to
/// the side of the mate's line to its goal, ahead along it if that side is blocked, or to
/// the other side; `None` if the robot is behind the mate, or no step is free. Robots that
/// start packed, or wait in a doorway, otherwise hold in the mate they left their target to.
fn make_way(ctx: &Ctx) -> Option<Action> {
    let p = ctx.position();
    let (radius_m, step_m) = (ctx.kind.radius_m, ctx.kind.speed_m_per_round);
    let reach_m = 2.0 * (radius_m + step_m);
    let (mate, goal) = ctx
        .messages()
        .iter()
        .filter_map(|m| match m.payload {
            Payload::Position {
                position,
                goal: Some(goal),
            } if position.distance(p) <= reach_m => Some((position, goal)),
            _ => None,
        })
        .min_by(|a, b| a.0.distance(p).total_cmp(&b.0.distance(p)))?;
    let heading = (goal - mate).try_normalize()?;
    let off = p - mate;
    if off.dot(heading) < -radius_m {
        return None;
    }
    let side = if heading.perp_dot(off) >= 0.0 {
        heading.perp()
    } else {
        -heading.perp()
    };
    [side, heading, -side]
        .into_iter()
        .map(|d| p + d * step_m)
        .find(|&to| ctx.can_move(p, to) == Some(true))
        .map(|to| Action::MoveTo { to })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use glam::{DVec2, Vec2};
    use proptest::prelude::*;

    use super::{
        Claims, Update, goal_of, hear_claims, keep_newest, keep_newest_into, make_way, merge_claims, stored_goal,
    };
    use crate::agent::TestWorld;
    use crate::spatial::RobotId;
    use crate::world::{Action, Inbox, Message, Payload, Recipient};

    /// Where a waiting robot steps when mate 2 announces, from `mate` (relative to the
    /// robot), a goal at `goal` (relative too), in the world of `art` (the robot knows it
    /// all; the explorer type: 0.125 m radius, 1 m steps, so mates within 2.25 m count).
    fn step_aside(art: &str, mate: DVec2, goal: DVec2) -> Option<DVec2> {
        let mut w = TestWorld::from_ascii(art, 1.0).unwrap().knowing_all();
        let p = w.robot.position;
        let said = Message {
            from: RobotId::new(2),
            sent_round: 0,
            to: Recipient::Broadcast,
            payload: Payload::Position {
                position: p + mate,
                goal: Some(p + goal),
            },
        };
        w.mind.perception.inbox = Inbox::from(vec![said]);
        make_way(&w.ctx()).map(|a| match a {
            Action::MoveTo { to } => to - p,
            other => panic!("a move, not {other:?}"),
        })
    }

    /// A mate 1 m west and 0.2 m south of the robot, heading east: the robot, north of the
    /// mate's line, steps 1 m north. In a corridor one cell wide it cannot: it steps 1 m
    /// east, ahead of the mate. A mate heading west (the robot behind it), one 2.5 m off,
    /// or one with nowhere to go: no step.
    #[test]
    fn a_waiting_robot_steps_off_a_near_mates_way() {
        let open = [".....", ".....", "..R..", ".....", "....."].join("\n");
        let corridor = ["#####", "..R..", "#####"].join("\n");
        let (mate, east, west) = (DVec2::new(-1.0, -0.2), DVec2::new(10.0, -0.2), DVec2::new(-10.0, -0.2));
        let near = |a: Option<DVec2>, b: DVec2| a.is_some_and(|a| a.distance(b) < 1e-9);
        assert!(near(step_aside(&open, mate, east), DVec2::Y));
        assert!(near(step_aside(&corridor, mate, east), DVec2::X));
        assert_eq!(step_aside(&open, mate, west), None);
        assert_eq!(step_aside(&open, DVec2::new(-2.5, 0.0), east), None);
        assert_eq!(step_aside(&open, mate, mate), None);
    }

    /// The mates' announcements of one round, from ids `ids`: each stood 1 m east of the
    /// robot and heads 5 m north of it.
    fn announcements(p: DVec2, ids: std::ops::Range<u32>) -> Inbox {
        Inbox::from(
            ids.map(|id| Message {
                from: RobotId::new(id),
                sent_round: 0,
                to: Recipient::Broadcast,
                payload: Payload::Position {
                    position: p + DVec2::X,
                    goal: Some(p + 5.0 * DVec2::Y),
                },
            })
            .collect::<Vec<_>>(),
        )
    }

    /// A `cooperative` robot keeps the walks of a small team's mates (here 3), each mate's
    /// last; one that hears a crowd (40 mates, above the 12 of a small team) keeps none, and
    /// no room for them: a crowd never reads them, and at home it hears hundreds a round.
    #[test]
    fn only_a_small_teams_robot_keeps_its_mates_walks() {
        use crate::agent::{Params, Strategy};
        let sharing = super::Sharing::from_params(&Params::default()).unwrap();
        let art = [".....", ".....", "..R..", ".....", "....."].join("\n");
        let mut w = TestWorld::from_ascii(&art, 1.0).unwrap().knowing_all();
        let p = w.robot.position;
        let mut small = super::Frontier::new(Some(sharing), 0.25, None);
        w.mind.perception.inbox = announcements(p, 2..5);
        small.decide(&mut w.ctx());
        w.mind.perception.inbox = announcements(p, 3..5);
        small.decide(&mut w.ctx());
        assert!(!small.crowd);
        let ids: Vec<u32> = small.walks.iter().map(|m| m.id).collect();
        assert_eq!(ids, [2, 3, 4]);
        let mut crowd = super::Frontier::new(Some(sharing), 0.25, None);
        w.mind.perception.inbox = announcements(p, 2..4);
        crowd.decide(&mut w.ctx());
        assert_eq!(crowd.walks.len(), 2);
        w.mind.perception.inbox = announcements(p, 10..50);
        crowd.decide(&mut w.ctx());
        assert!(crowd.crowd);
        assert_eq!((crowd.walks.len(), crowd.walks.capacity()), (0, 0));
    }

    /// A goal kept in single precision from the home comes back within 6 mm on a
    /// 100 km map whatever its origin, here 5,000 km out (a projected map's coordinates),
    /// where single precision from the origin is off by up to a quarter of a metre.
    #[test]
    fn claimed_goals_come_back_within_6_mm_anywhere() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let origin = glam::DVec2::new(5.0e6, -5.0e6);
        let (mut worst, mut worst_absolute) = (0.0f64, 0.0f64);
        for _ in 0..100_000 {
            let at = |rng: &mut rand_chacha::ChaCha8Rng| {
                origin + glam::DVec2::new(rng.random_range(0.0..1.0e5), rng.random_range(0.0..1.0e5))
            };
            let (home, goal) = (at(&mut rng), at(&mut rng));
            worst = worst.max(goal_of(stored_goal(goal, home), home).distance(goal));
            worst_absolute = worst_absolute.max(goal.as_vec2().as_dvec2().distance(goal));
        }
        assert!(worst <= 0.006, "{worst} m");
        assert!(worst_absolute > 0.1, "{worst_absolute} m");
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 500, rng_seed: proptest::test_runner::RngSeed::Fixed(3), ..ProptestConfig::default() })]

        /// The merge gives what inserting and removing the updates one by one in a map does.
        #[test]
        fn merged_claims_equal_updates_applied_one_by_one(
            old in proptest::collection::btree_map(0u32..40, (0.0f32..10.0, 0u32..5), 0..20),
            mut updates in proptest::collection::vec((0u32..40, proptest::option::of(0.0f32..10.0)), 0..30),
        ) {
            updates.sort_by_key(|u| u.0);
            let updates: Vec<Update> = updates.into_iter().map(|(id, g)| (id, g.map(|x| Vec2::new(x, -x)))).collect();
            let claims: Claims = old.iter().map(|(&id, &(x, r))| (id, Vec2::splat(x), r)).collect();
            let mut expected: BTreeMap<u32, (Vec2, u32)> = claims.iter().map(|c| (c.0, (c.1, c.2))).collect();
            for &(id, goal) in &updates {
                match goal {
                    Some(g) => expected.insert(id, (g, 9)),
                    None => expected.remove(&id),
                };
            }
            let mut out = Vec::new();
            merge_claims(&claims, &updates, 9, &mut out);
            let expected: Claims = expected.into_iter().map(|(id, (g, r))| (id, g, r)).collect();
            prop_assert_eq!(out, expected);
        }

        /// A round's announcements applied and cut, with or without the shortcut for fresh
        /// claims that fill `max`, give what merging and cutting give.
        #[test]
        fn claims_heard_equal_merged_then_cut(
            old in proptest::collection::btree_map(0u32..40, (0.0f32..10.0, 0u32..9), 0..30),
            mut updates in proptest::collection::vec((0u32..40, proptest::option::weighted(0.8, 0.0f32..10.0)), 0..40),
            max in 0usize..25,
            cut_now in proptest::bool::ANY,
        ) {
            updates.sort_by_key(|u| u.0);
            let updates: Vec<Update> = updates.into_iter().map(|(id, g)| (id, g.map(|x| Vec2::new(x, -x)))).collect();
            let claims: Claims = old.iter().map(|(&id, &(x, r))| (id, Vec2::splat(x), r)).collect();
            let round = 9;
            let mut expected = Vec::new();
            merge_claims(&claims, &updates, 9, &mut expected);
            keep_newest(&mut expected, max, round);
            let mut heard = claims.clone();
            hear_claims(&mut heard, &updates, round, max, cut_now, &mut Vec::new());
            // Uncut, the caller cuts later.
            keep_newest(&mut heard, max, round);
            prop_assert_eq!(heard, expected);
        }

        /// A crowd's claims are cut to the `max` heard last (the lowest ids among those
        /// heard in the same round), in id order, as sorting by recency would.
        #[test]
        fn claims_keep_the_most_recently_heard(
            heard in proptest::collection::btree_map(0u32..500, 0u32..60, 0..300),
            max in 0usize..200,
        ) {
            let round = 60;
            let mut claims: Claims = heard.iter().map(|(&id, &r)| (id, Vec2::splat(f32::from(u16::try_from(id).expect("ids below 500"))), r)).collect();
            let mut by_recency = claims.clone();
            by_recency.sort_by_key(|c| (std::cmp::Reverse(c.2), c.0));
            by_recency.truncate(max);
            by_recency.sort_by_key(|c| c.0);
            let mut copied = Vec::new();
            keep_newest_into(&claims, max, round, &mut copied);
            keep_newest(&mut claims, max, round);
            prop_assert_eq!(&claims, &by_recency);
            // Cut while copied, the same claims.
            prop_assert_eq!(&copied, &by_recency);
            // Grown without copies, its block still holds at most `max` claims.
            prop_assert!(copied.capacity() <= max.max(copied.len()));
        }
    }
}
