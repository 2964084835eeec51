//! The built-in tactics, each alone, in tiny ASCII worlds ([`TestWorld`]). Expected values
//! are worked out by hand in the comments.

mod common;

use sim_core::agent::{
    BoundaryFollowing, CollisionAvoidance, EnergyManagement, FrontierSeeking, GIVE_UP_ROUNDS, Navigator, Tactic, Team,
    TestWorld, blocked,
};
use sim_core::glam::DVec2;
use sim_core::spatial::{PieceMemo, RobotId};
use sim_core::world::{Action, Inbox, Message, Outcome, Payload, Recipient, StrategyEvent};

const EPS: f64 = 1e-9;

/// A 3 × 2 room; the robot in its top-left cell, at (1.5, 2.5).
const ROOM: &str = "
    #####
    #R..#
    #...#
    #####";

fn move_target(a: Option<Action>) -> DVec2 {
    match a {
        Some(Action::MoveTo { to }) => to,
        other => panic!("expected a move, got {other:?}"),
    }
}

// ---------------------------------------------------------------- CollisionAvoidance

#[test]
fn collision_avoidance_is_quiet_while_moves_succeed() {
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    let mut c = CollisionAvoidance::default();
    // Back and forth between x = 1.5 and x = 2.5: every move is Done, so never stuck.
    for i in 0..8 {
        assert_eq!(c.suggest(&mut w.ctx()), None, "round {i}");
        assert!(!c.is_stuck());
        let dx = if i % 2 == 0 { 1.0 } else { -1.0 };
        let to = w.robot.position + DVec2::new(dx, 0.0);
        w.apply(Action::MoveTo { to });
        assert_eq!(w.robot.last_action.1, Outcome::Done);
    }
}

/// A robot pressed against the map's edge escapes onto the map, never off it: no cell off
/// the map is ever known, so "not known to be blocked" alone would let such headings
/// through again and again.
#[test]
fn escapes_never_head_off_the_map() {
    for seed in 0..24 {
        let mut w = TestWorld::from_ascii("\n    R...\n    ....\n    ....", 1.0)
            .unwrap()
            .knowing_all();
        w.seed = seed;
        w.robot.position = DVec2::new(0.13, 1.5);
        let mut c = CollisionAvoidance::default();
        let off_map = Action::MoveTo {
            to: DVec2::new(-0.87, 1.5),
        };
        for _ in 1..=3 {
            assert_eq!(c.suggest(&mut w.ctx()), None);
            w.apply(off_map);
            assert_eq!(w.robot.last_action.1, Outcome::Refused);
        }
        let to = move_target(c.suggest(&mut w.ctx()));
        assert!(w.extent().contains_strictly(to), "seed {seed}: escape to {to}");
        w.apply(Action::MoveTo { to });
        assert_eq!(w.robot.last_action.1, Outcome::Done, "seed {seed}");
    }
}

#[test]
fn collision_avoidance_escapes_after_patience_refused_moves() {
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    let mut c = CollisionAvoidance::default();
    assert_eq!(c.patience_rounds, 3);
    let start = w.robot.position;
    // West of (1.5, 2.5) is the wall at x = 1: every move there is refused.
    let into_wall = Action::MoveTo {
        to: DVec2::new(0.5, 2.5),
    };
    // Call 1 only remembers the position; calls 2, 3, 4 each see one more refused move
    // without progress: stuck = 1, 2, 3 = patience → the 4th call escapes.
    for call in 1..=3 {
        assert_eq!(c.suggest(&mut w.ctx()), None, "call {call}");
        w.apply(into_wall);
        assert_eq!(w.robot.last_action.1, Outcome::Refused);
        assert_eq!(w.robot.position, start);
    }
    let escape = c.suggest(&mut w.ctx());
    let to = move_target(escape);
    let p = w.robot.position;
    // An escape step is one speed (1 m) long, in a direction known to be free.
    assert!((to.distance(p) - w.types[0].speed_m_per_round).abs() < EPS, "{to}");
    assert_eq!(w.ctx().can_move(p, to), Some(true));
    // The counter is reset once the escape starts.
    assert!(!c.is_stuck());
    // The escape lasts escape_rounds (3): two more suggestions follow, then nothing.
    w.apply(Action::MoveTo { to });
    assert_eq!(w.robot.last_action.1, Outcome::Done);
    assert!(c.suggest(&mut w.ctx()).is_some());
    w.apply(Action::Idle);
    assert!(c.suggest(&mut w.ctx()).is_some());
    w.apply(Action::Idle);
    assert_eq!(c.suggest(&mut w.ctx()), None);
}

// ---------------------------------------------------------------- BoundaryFollowing

#[test]
fn boundary_following_keeps_a_free_heading() {
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    // East from (1.5, 2.5) to (2.5, 2.5) is free: turned by 0°, the same unit vector.
    let h = BoundaryFollowing::heading(&w.ctx(), DVec2::X);
    assert_eq!(h, Some(DVec2::X));
    // A longer desired vector comes back normalised.
    let h = BoundaryFollowing::heading(&w.ctx(), DVec2::new(3.0, 0.0)).unwrap();
    assert!((h - DVec2::X).length() < EPS);
}

#[test]
fn boundary_following_turns_left_along_a_wall() {
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    let p = w.robot.position;
    // Heading west from (1.5, 2.5), 1 m steps, radius 0.125, wall face at x = 1:
    //   0°: end (0.5, 2.5) in the wall;
    //  30°: (−cos 30°, −sin 30°) → end (0.634, 2.0): x − r < 1, blocked;
    //  60°: (−0.5, −0.866) → end (1.0, 1.634): x − r < 1, blocked;
    //  90°: (0, −1) → end (1.5, 1.5): free. So the answer is south, 90° to the left.
    let h = BoundaryFollowing::heading(&w.ctx(), -DVec2::X).unwrap();
    assert!((h - DVec2::new(0.0, -1.0)).length() < EPS, "{h}");
    let angle = (-DVec2::X).angle_to(h).to_degrees();
    assert!((angle - 90.0).abs() < 1e-6, "{angle}");
    assert_eq!(w.ctx().can_move(p, p + h), Some(true));
}

#[test]
fn boundary_following_boxed_in_gives_none() {
    // A single free cell of 1 m with 1 m steps: every one of the 12 headings hits a wall.
    let mut w = TestWorld::from_ascii(
        "
        ###
        #R#
        ###",
        1.0,
    )
    .unwrap()
    .knowing_all();
    assert_eq!(BoundaryFollowing::heading(&w.ctx(), DVec2::X), None);
}

// ---------------------------------------------------------------- EnergyManagement

/// A 10-cell corridor: home at (1.5, 1.5), the robot 9 m east at (10.5, 1.5).
const CORRIDOR: &str = "
    ############
    #H........R#
    ############";

// Explorer: speed 1, energy_per_m 1, idle 0.05, sense 0.1, capacity 5,000.
// cost(L) = L·1 + (L/1 + 1)·(0.05 + 0.1).
// Way home L = 9: cost = 9 + 10·0.15 = 10.5. Margin = 2·cost(1) = 2·(1 + 2·0.15) = 2.6.
// Reserve = 0.1·5,000 = 500. Threshold = 10.5 + 2.6 + 500 = 513.1.
const THRESHOLD: f64 = 513.1;

#[test]
fn energy_management_full_energy_far_from_home_is_quiet() {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0).unwrap().knowing_all();
    let mut e = EnergyManagement::default();
    assert_eq!(e.suggest(&mut w.ctx()), None);
    assert!(!e.is_returning());
}

#[test]
fn energy_management_way_home_is_nine_metres() {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0).unwrap().knowing_all();
    let ctx = w.ctx();
    let route = ctx
        .nav()
        .route_within(ctx.terrain().unwrap(), ctx.position(), DVec2::new(1.5, 1.5), 50_000)
        .unwrap();
    // Straight along y = 1.5 from x = 10.5 to x = 1.5.
    assert!((route.length_m - 9.0).abs() < 1e-9, "{}", route.length_m);
}

#[test]
fn energy_management_just_above_the_threshold_is_quiet() {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0).unwrap().knowing_all();
    w.robot.energy = THRESHOLD + 0.1;
    let mut e = EnergyManagement::default();
    assert_eq!(e.suggest(&mut w.ctx()), None);
    assert!(!e.is_returning());
}

#[test]
fn energy_management_below_the_threshold_heads_home() {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0).unwrap().knowing_all();
    w.robot.energy = THRESHOLD - 0.1;
    let mut e = EnergyManagement::default();
    let home = DVec2::new(1.5, 1.5);
    let p = w.robot.position;
    let to = move_target(e.suggest(&mut w.ctx()));
    assert!(e.is_returning());
    assert!(to.distance(home) < p.distance(home), "{to}");
    assert!((to.y - 1.5).abs() < 1e-9, "{to}");
    // It keeps walking home on the next rounds, even if energy is then higher.
    w.apply(Action::MoveTo { to });
    w.robot.energy = 5_000.0;
    let to2 = move_target(e.suggest(&mut w.ctx()));
    assert!(to2.distance(home) < w.robot.position.distance(home) + 1e-9);
    assert!(e.is_returning());
}

/// Between measures, the way home is bounded by the last measure plus the distance walked
/// since. Here the robot measured 9 m, then walked 4 m (back and forth, so it stands where
/// it was): the bound is 13 m, the true way still 9 m. With energy between the two
/// thresholds, a recent measure lets the bound decide (home, early and safe); once
/// `replan_every` rounds have passed, it measures again and carries on.
#[test]
fn energy_management_bounds_the_way_home_between_measures() {
    for (round, returns) in [(5, true), (10, false)] {
        let mut w = TestWorld::from_ascii(CORRIDOR, 1.0).unwrap().knowing_all();
        let mut e = EnergyManagement::default();
        w.round = 0;
        assert_eq!(e.suggest(&mut w.ctx()), None);
        w.round = round;
        w.robot.stats.distance_m += 4.0;
        // Threshold for 13 m: 13 + 14·0.15 + 2.6 + 500 = 517.7; for 9 m, 513.1.
        w.robot.energy = 515.0;
        let action = e.suggest(&mut w.ctx());
        assert_eq!(e.is_returning(), returns, "round {round}: {action:?}");
        assert_eq!(action.is_some(), returns);
    }
}

#[test]
fn energy_management_recharges_at_home_until_leave_fraction() {
    // No 'H': home is a disc of 0.5 m around the robot.
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    let mut e = EnergyManagement::default();
    // 3,000 ≥ 50 % of 5,000 and not returning: nothing to do.
    w.robot.energy = 3_000.0;
    assert_eq!(e.suggest(&mut w.ctx()), None);
    // 2,000 < 2,500: recharge.
    w.robot.energy = 2_000.0;
    assert_eq!(e.suggest(&mut w.ctx()), Some(Action::Idle));
    assert!(e.is_returning());
    // 4,700 < 0.95·5,000 = 4,750: still recharging.
    w.robot.energy = 4_700.0;
    assert_eq!(e.suggest(&mut w.ctx()), Some(Action::Idle));
    // 4,800 ≥ 4,750: done, free to go.
    w.robot.energy = 4_800.0;
    assert_eq!(e.suggest(&mut w.ctx()), None);
    assert!(!e.is_returning());
}

// ---------------------------------------------------------------- Navigator

/// An L-shaped corridor: from (1.5, 3.5) east, down at x = 4.5, then west to (1.5, 1.5).
const L_CORRIDOR: &str = "
    ######
    #R...#
    ####.#
    #....#
    ######";

#[test]
fn navigator_go_to_walks_the_corridor_to_the_goal() {
    let mut w = TestWorld::from_ascii(L_CORRIDOR, 1.0).unwrap().knowing_all();
    let goal = DVec2::new(1.5, 1.5);
    let mut nav = Navigator::default();
    assert!(nav.go_to(&w.ctx(), goal));
    assert_eq!(nav.destination(), Some(goal));
    assert!(!nav.is_idle());
    let mut last_target = None;
    for _ in 0..40 {
        let Some(a) = nav.step(&mut w.ctx()) else { break };
        let Action::MoveTo { to } = a else {
            panic!("expected a move, got {a:?}")
        };
        // Each target is the next waypoint still ahead.
        assert_eq!(nav.remaining().first(), Some(&to));
        last_target = Some(to);
        w.apply(a);
        assert_ne!(w.robot.last_action.1, Outcome::Refused, "waypoint {to} not reachable");
    }
    assert_eq!(last_target, Some(goal));
    // Shortest path: 3 m east, 2 m south, 3 m west = 8 m at most (portals cut corners),
    // and it ends at the goal.
    assert!(w.robot.position.distance(goal) <= 0.05, "{}", w.robot.position);
    assert!(nav.is_idle());
    assert_eq!(nav.step(&mut w.ctx()), None);
}

#[test]
fn navigator_go_to_unknown_goal_fails() {
    let mut w = TestWorld::from_ascii(L_CORRIDOR, 1.0).unwrap();
    let p = w.robot.position;
    let mut w2 = TestWorld::from_ascii(L_CORRIDOR, 1.0).unwrap().knowing_disc(p, 1.0);
    let mut nav = Navigator::default();
    // Knows nothing at all.
    assert!(!nav.go_to(&w.ctx(), DVec2::new(1.5, 1.5)));
    // Knows 1 m around (1.5, 3.5); the goal (1.5, 1.5) lies behind walls, 2 m away, unknown.
    assert!(!nav.go_to(&w2.ctx(), DVec2::new(1.5, 1.5)));
    assert!(nav.is_idle());
    assert_eq!(nav.step(&mut w2.ctx()), None);
}

#[test]
fn navigator_frontier_route_leaves_the_known_disc() {
    // 20 × 20 open cells; 'R' in the 10th row from the top, 11th column: (10.5, 10.5).
    let mut rows: Vec<String> = (0..20).map(|_| ".".repeat(20)).collect();
    rows[9] = format!("{}R{}", ".".repeat(10), ".".repeat(9));
    let mut w = TestWorld::from_ascii(&rows.join("\n"), 1.0).unwrap();
    let p = w.robot.position;
    // The robot at (10.5, 10.5) knows a disc of 3 m around itself.
    w = w.knowing_disc(p, 3.0);
    let ctx = w.ctx();
    let route = Navigator::frontier_route(&ctx, &[], 0.0, f64::INFINITY).expect("a frontier");
    let last = *route.waypoints.last().unwrap();
    let known = ctx.known().unwrap();
    let off_or_border = !known.is_known(last)
        || [DVec2::X, -DVec2::X, DVec2::Y, -DVec2::Y]
            .iter()
            .any(|d| !known.is_known(last + *d * 0.5));
    assert!(off_or_border, "{last} lies deep inside the known region");
    // The nearest frontier is about 3 m (the disc's radius, to a cell) away.
    let d = last.distance(p);
    assert!((1.5..=4.5).contains(&d), "{d}");
}

/// A 40 × 11 open room, 1 m cells, the robot at (5.5, 5.5), knowing every cell left of
/// x = `known_to` except the pocket cell (8, 5), 3 m to its right.
fn room_with_a_pocket(known_to: u32) -> TestWorld {
    let mut rows: Vec<String> = (0..11).map(|_| ".".repeat(40)).collect();
    rows[5] = format!("{}R{}", ".".repeat(5), ".".repeat(34));
    let mut w = TestWorld::from_ascii(&rows.join("\n"), 1.0).unwrap();
    for x in 0..known_to {
        for y in 0..11u32 {
            if (x, y) != (8, 5) {
                w = w.knowing_disc(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5), 0.75);
            }
        }
    }
    w
}

#[test]
fn frontiers_that_reveal_little_are_left_for_last() {
    let pocket = DVec2::new(8.5, 5.5);
    let target = |w: &mut TestWorld, reveal_first: f64| {
        let ctx = w.ctx();
        let seen_cost_m = 2.0 * ctx.kind.view_radius_m;
        let route =
            Navigator::nearest_frontier_route(&ctx, &mut PieceMemo::default(), seen_cost_m, reveal_first, (&[], 0.0))
                .expect("a frontier");
        *route.waypoints.last().unwrap()
    };
    // Known up to x = 34. The pocket: a walk of about 3 m, and its 6 m view holds one
    // unknown cell of about 113 (known part 0.99): 3 + 12 × 0.99 ≈ 15 m. The edge at x = 34:
    // a walk of about 29 m, half its view unknown: 29 + 12 × 0.5 ≈ 35 m.
    let mut w = room_with_a_pocket(34);
    assert!(
        target(&mut w, 0.0).distance(pocket) < 1.0,
        "ranked alike, the pocket is nearer"
    );
    // Taking first what has at least 15 % of its view unknown, the edge wins.
    let edge = target(&mut w, 0.15);
    assert!(edge.x >= 33.0, "the edge at x = 34 first, got {edge}");
    // With the room known but for the pocket, the pocket is still found.
    let mut w = room_with_a_pocket(40);
    assert!(
        target(&mut w, 0.15).distance(pocket) < 1.0,
        "the pocket, once nothing else is left"
    );
}

/// The target the seeker walks to after one more round at `w`'s position, the round then
/// advanced (the robot stays where it is).
fn next_target(seeker: &mut FrontierSeeking, w: &mut TestWorld) -> DVec2 {
    seeker.suggest(&mut w.ctx()).expect("a step");
    w.apply(Action::Idle);
    seeker.navigator().destination().expect("a target")
}

/// A lone explorer (6 m view) at (5.5, 5.5) in the 40 × 11 room, knowing x < 20, walks to
/// the edge at x = 20, 14.5 m away. Once it knows x < 24 (a mate's map, say), that target is
/// known but 15 m off, far beyond half the view: `replan_within_view` alone keeps it. The
/// disc of 6 m round it is known up to 3.5 m east of it; unknown is the segment beyond, a
/// share (acos(0.583) − 0.583 × √(1 − 0.583²)) / π = 0.15 of the disc: 0.85 is known, so
/// with `replan_when_known` 0.65 it searches again and goes on to the new edge at x = 24;
/// with 0.95 it keeps the old target.
#[test]
fn a_target_seen_with_its_view_mostly_known_is_searched_again() {
    let run = |when_known: Option<f64>| {
        let mut w = room_with_a_pocket(20).knowing_disc(DVec2::new(8.5, 5.5), 0.75);
        let mut seeker = FrontierSeeking::default()
            .with_ranking_by_target(Some(2.0))
            .with_replan_within_view(0.5)
            .with_replan_when_known(when_known);
        let first = next_target(&mut seeker, &mut w);
        assert!((19.5..21.0).contains(&first.x), "the edge at x = 20 first, got {first}");
        for x in 20..24 {
            for y in 0..11 {
                w = w.knowing_disc(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5), 0.75);
            }
        }
        let known = w.ctx().known().unwrap().known_fraction_near(first, 6.0);
        assert!((0.75..0.95).contains(&known), "{known}");
        (first, next_target(&mut seeker, &mut w))
    };
    let (first, next) = run(Some(0.65));
    assert!(next.x >= 23.5, "on to the edge at x = 24, got {next}");
    let (_, kept) = run(Some(0.95));
    assert_eq!(kept, first);
    let (_, kept) = run(None);
    assert_eq!(kept, first);
}

/// [`common::corridor_with_two_ends`] and a seeker ranking by target.
fn corridor_with_two_ends() -> (TestWorld, FrontierSeeking) {
    let seeker = FrontierSeeking::default().with_ranking_by_target(Some(2.0));
    (common::corridor_with_two_ends(), seeker)
}

/// In [`corridor_with_two_ends`], held where it stands (a robot in the way, a gap its disc
/// does not fit), the robot keeps the west target for `GIVE_UP_ROUNDS` rounds after the
/// first it followed a route there (round 2 to 41), gives it up in round 42 and turns east;
/// later searches skip the west end.
#[test]
fn a_target_the_robot_gets_no_nearer_to_is_given_up() {
    let (mut w, mut seeker) = corridor_with_two_ends();
    for round in 1..=1 + GIVE_UP_ROUNDS {
        assert_eq!(w.round, round);
        let target = next_target(&mut seeker, &mut w);
        assert!(target.x < 7.5, "round {round}: the west end, got {target}");
    }
    for round in 2 + GIVE_UP_ROUNDS..2 * GIVE_UP_ROUNDS {
        let target = next_target(&mut seeker, &mut w);
        assert!(target.x > 16.5, "round {round}: the east end, got {target}");
    }
}

/// As above, but the seeker is not asked for rounds 31–50 (another tactic acts: a trip home
/// to recharge, say). A pause of more than 10 rounds starts the count afresh: asked again in
/// round 51, it keeps the west target until round 51 + `GIVE_UP_ROUNDS` − 1 and turns east
/// then, where without the fresh count it would have given up at once.
#[test]
fn a_pause_in_seeking_starts_the_count_afresh() {
    let (mut w, mut seeker) = corridor_with_two_ends();
    for _ in 1..=30 {
        assert!(next_target(&mut seeker, &mut w).x < 7.5);
    }
    for _ in 31..=50 {
        w.apply(Action::Idle);
    }
    for round in 51..51 + GIVE_UP_ROUNDS {
        assert_eq!(w.round, round);
        let target = next_target(&mut seeker, &mut w);
        assert!(target.x < 7.5, "round {round}: the west end, got {target}");
    }
    let target = next_target(&mut seeker, &mut w);
    assert!(target.x > 16.5, "the east end, got {target}");
}

// ---------------------------------------------------------------- Team

fn position_message(from: u32, at: DVec2, round: u64) -> Message {
    Message {
        from: RobotId::new(from),
        sent_round: round,
        to: Recipient::Broadcast,
        payload: Payload::Position {
            position: at,
            goal: None,
        },
    }
}

/// An open 20 m × 20 m world; the robot (given id 3) at (1.5, 1.5).
fn team_world() -> TestWorld {
    let mut rows: Vec<String> = (0..19).map(|_| ".".repeat(20)).collect();
    rows.push(format!(".R{}", ".".repeat(18)));
    let mut w = TestWorld::from_ascii(&rows.join("\n"), 1.0).unwrap().knowing_all();
    w.robot.id = RobotId::new(3);
    w
}

const LEADER_AT: DVec2 = DVec2::new(10.5, 10.5);

/// Slot of robot 3 at 2 m: angle 3·2.399963… = 7.199890 rad ≡ 0.916704 rad (−2π);
/// cos = 0.608439, sin = 0.793601 → (10.5 + 1.216878, 10.5 + 1.587202) = (11.716878, 12.087202).
fn slot() -> DVec2 {
    LEADER_AT + DVec2::from_angle(3.0 * 2.399_963_229_728_653) * 2.0
}

#[test]
fn team_golden_angle_slot_by_hand() {
    let s = slot();
    assert!((s.x - 11.716_878).abs() < 1e-6, "{s}");
    assert!((s.y - 12.087_202).abs() < 1e-6, "{s}");
}

#[test]
fn team_follows_a_lower_id() {
    let mut w = team_world();
    let mut t = Team::default();
    w.mind.perception.inbox = Inbox::from(vec![position_message(1, LEADER_AT, 1)]);
    let to = move_target(t.suggest(&mut w.ctx()));
    assert!((to - slot()).length() < EPS, "{to}");
    assert_eq!(t.leader(), Some(RobotId::new(1)));
    assert_eq!(w.mind.output.events(), &[StrategyEvent::JoinedGroup(RobotId::new(1))]);
}

#[test]
fn team_ignores_a_higher_id() {
    let mut w = team_world();
    let mut t = Team::default();
    w.mind.perception.inbox = Inbox::from(vec![position_message(7, LEADER_AT, 1)]);
    assert_eq!(t.suggest(&mut w.ctx()), None);
    assert_eq!(t.leader(), None);
    assert!(w.mind.output.events().is_empty());
}

#[test]
fn team_leaves_after_timeout() {
    let mut w = team_world();
    let mut t = Team::default();
    assert_eq!(t.timeout_rounds, 5);
    // Heard at round 1.
    w.mind.perception.inbox = Inbox::from(vec![position_message(1, LEADER_AT, 1)]);
    assert!(t.suggest(&mut w.ctx()).is_some());
    w.mind.perception.inbox = Inbox::default();
    // Rounds 2..=6: 6 − 1 = 5, not more than 5: still following, no new event.
    for round in 2..=6 {
        w.round = round;
        w.mind.output.begin_round();
        let to = move_target(t.suggest(&mut w.ctx()));
        assert!((to - slot()).length() < EPS);
        assert!(w.mind.output.events().is_empty(), "round {round}");
    }
    // Round 7: 7 − 1 = 6 > 5: leaves.
    w.round = 7;
    w.mind.output.begin_round();
    assert_eq!(t.suggest(&mut w.ctx()), None);
    assert_eq!(t.leader(), None);
    assert_eq!(w.mind.output.events(), &[StrategyEvent::LeftGroup(RobotId::new(1))]);
}

#[test]
fn team_timeout_near_u64_max_does_not_overflow() {
    let mut w = team_world();
    let mut t = Team::default();
    t.timeout_rounds = u64::MAX;
    w.mind.perception.inbox = Inbox::from(vec![position_message(1, LEADER_AT, 1)]);
    assert!(t.suggest(&mut w.ctx()).is_some());
    w.mind.perception.inbox = Inbox::default();
    // (u64::MAX − 1) − 1 and u64::MAX − 1 are both ≤ u64::MAX: still following.
    for round in [u64::MAX - 1, u64::MAX] {
        w.round = round;
        w.mind.output.begin_round();
        let to = move_target(t.suggest(&mut w.ctx()));
        assert!((to - slot()).length() < EPS);
        assert_eq!(t.leader(), Some(RobotId::new(1)));
        assert!(w.mind.output.events().is_empty());
    }
}

// ---------------------------------------------------------------- blocked()

#[test]
fn blocked_means_a_move_held_back() {
    let mut w = TestWorld::from_ascii(ROOM, 1.0).unwrap().knowing_all();
    let mv = Action::MoveTo { to: DVec2::ZERO };
    for (last, want) in [
        ((mv, Outcome::Refused), true),
        ((mv, Outcome::Trimmed), true),
        ((mv, Outcome::Done), false),
        ((Action::Idle, Outcome::Refused), false),
        ((Action::Unload, Outcome::Refused), false),
    ] {
        w.robot.last_action = last;
        assert_eq!(blocked(&w.ctx()), want, "{last:?}");
    }
    // Through apply: a move into the wall is refused, so blocked.
    w.apply(Action::MoveTo {
        to: DVec2::new(0.5, 2.5),
    });
    assert!(blocked(&w.ctx()));
}

/// A frontier search honours a team mate's claim only within `max_detour_m`. A corridor one
/// cell high and 60 m long, in four pieces of free space (x from 1, 17, 33 and 49). The
/// robot at x = 21.5 knows it from x = 19 to x = 39 (discs of 3 m, whose cells lie within
/// 2.5 m of their centres on this line). Its nearest frontier is the west end of what it
/// knows, x = 18.5, 3 m off, in its own piece; a team mate claims it (a claim at x = 17.5
/// with a 3 m radius). The nearest clear one is the east end, x = 39.5, in the next piece
/// east, which the search enters at x = 33: 11.5 m beyond the robot's own piece. So a
/// detour of 20 m is allowed, one of 5 m is not.
#[test]
fn frontier_search_honours_claims_within_max_detour() {
    let inner = format!("{}R{}", ".".repeat(20), ".".repeat(39));
    let art = format!("{w}\n#{inner}#\n{w}", w = "#".repeat(62));
    let mut w = TestWorld::from_ascii(&art, 1.0).unwrap();
    let p = w.robot.position;
    assert_eq!(p, DVec2::new(21.5, 1.5));
    for x in [21.5, 26.5, 31.5, 36.5] {
        w = w.knowing_disc(DVec2::new(x, 1.5), 3.0);
    }
    let ctx = w.ctx();
    let claim = [DVec2::new(17.5, 1.5)];
    let end = |avoid: &[DVec2], detour: f64| {
        let r = Navigator::frontier_route(&ctx, avoid, 3.0, detour).expect("a frontier");
        *r.waypoints.last().unwrap()
    };
    let west = DVec2::new(18.5, 1.5);
    let east = DVec2::new(39.5, 1.5);
    // Unclaimed, the west end; claimed, the east end unless the detour is bounded below
    // 11.5 m.
    for detour in [f64::INFINITY, 0.0] {
        assert!(end(&[], detour).distance(west) < EPS);
    }
    for detour in [f64::INFINITY, 20.0, 11.6] {
        assert!(end(&claim, detour).distance(east) < EPS, "detour {detour}");
    }
    for detour in [11.4, 5.0, 0.0] {
        assert!(end(&claim, detour).distance(west) < EPS, "detour {detour}");
    }
}
