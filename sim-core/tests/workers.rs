//! The `excavator` and `transporter` strategies (how a worker picks its treasure when team
//! mates claim treasures) and `cooperative` scouts (how a large team walks out, how a small
//! one shares out targets), in tiny worlds ([`TestWorld`]). Distances are worked out by hand
//! in the comments.

mod common;

use sim_core::agent::{Params, StrategyRegistry, TestWorld};
use sim_core::glam::DVec2;
use sim_core::spatial::{RobotId, TreasureId};
use sim_core::world::{Action, Inbox, Message, Payload, Recipient, RobotType, Sighting, Task};

/// A 20 m × 3 m corridor; the robot (id 0) at (1.5, 1.5).
const CORRIDOR: &str = "
    ....................
    .R..................
    ....................";

/// Treasure 0 is 5 m east of the robot, treasure 1 is 10 m east.
const NEAR: DVec2 = DVec2::new(6.5, 1.5);
const FAR: DVec2 = DVec2::new(11.5, 1.5);

fn claim(from: u32, treasure: u32, task: Task, distance_m: f32) -> Message {
    Message {
        from: RobotId::new(from),
        sent_round: 1,
        to: Recipient::Broadcast,
        payload: Payload::Claim {
            treasure: TreasureId::new(treasure),
            task,
            distance_m,
        },
    }
}

/// Let the robot of `w` remember treasure `id` at `position`, seen in round 0.
fn remember(w: &mut TestWorld, id: u32, position: DVec2, buried: u32, loose: u32) {
    let treasure = TreasureId::new(id);
    let sighting = Sighting {
        treasure,
        position,
        buried,
        loose,
        round: 0,
    };
    w.mind.data.treasures.record(treasure, sighting, 0);
}

/// One decision of a fresh `strategy` robot in `w`.
fn decide_once(w: &mut TestWorld, strategy: &str) {
    let mut s = StrategyRegistry::with_builtins()
        .create(strategy, &Params::default())
        .unwrap();
    s.decide(&mut w.ctx());
}

/// The goal a fresh `strategy` robot of type `kind` picks in its first round, knowing the
/// whole corridor and both treasures (3 units buried, or lying loose if `loose`), having
/// heard `heard`; and the claims it broadcast.
fn first_choice(strategy: &str, kind: RobotType, loose: bool, heard: Vec<Message>) -> (Option<DVec2>, Vec<Payload>) {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0)
        .unwrap()
        .with_type(kind)
        .knowing_all();
    let (buried, loose) = if loose { (0, 3) } else { (3, 0) };
    remember(&mut w, 0, NEAR, buried, loose);
    remember(&mut w, 1, FAR, buried, loose);
    w.mind.perception.inbox = Inbox::from(heard);
    decide_once(&mut w, strategy);
    let claims = w
        .mind
        .output
        .outbox()
        .iter()
        .filter(|(_, p)| matches!(p, Payload::Claim { .. }))
        .map(|(_, p)| p.clone())
        .collect();
    (w.mind.output.goal(), claims)
}

fn claimed(payloads: &[Payload]) -> Vec<(u32, Task, f32)> {
    payloads
        .iter()
        .map(|p| match p {
            Payload::Claim {
                treasure,
                task,
                distance_m,
            } => (treasure.get(), *task, *distance_m),
            other => panic!("not a claim: {other:?}"),
        })
        .collect()
}

/// An excavator leaves a treasure to a team mate that claimed it from nearer, and claims
/// the next one itself.
#[test]
fn an_excavator_leaves_a_treasure_claimed_from_nearer_to_its_claimant() {
    let dig = |heard| first_choice("excavator", RobotType::excavator(), false, heard);
    // Nobody claimed anything: the nearer treasure, 5 m away, claimed at 5 m.
    let (goal, said) = dig(vec![]);
    assert_eq!(goal, Some(NEAR));
    assert_eq!(claimed(&said), vec![(0, Task::Excavate, 5.0)]);
    // Robot 7 claimed it from 2 m: this robot takes the other one, 10 m away.
    let (goal, said) = dig(vec![claim(7, 0, Task::Excavate, 2.0)]);
    assert_eq!(goal, Some(FAR));
    assert_eq!(claimed(&said), vec![(1, Task::Excavate, 10.0)]);
    // Claimed from 8 m, farther than this robot's 5 m: it keeps the nearer one.
    let (goal, _) = dig(vec![claim(7, 0, Task::Excavate, 8.0)]);
    assert_eq!(goal, Some(NEAR));
    // A transporter's claim is not an excavator's business.
    let (goal, _) = dig(vec![claim(7, 0, Task::Transport, 2.0)]);
    assert_eq!(goal, Some(NEAR));
    // Equal distances: the lower id (this robot, 0) keeps it.
    let (goal, _) = dig(vec![claim(7, 0, Task::Excavate, 5.0)]);
    assert_eq!(goal, Some(NEAR));
    // A robot's last word counts: robot 7 moved on from treasure 0 to treasure 1.
    let (goal, _) = dig(vec![claim(7, 0, Task::Excavate, 2.0), claim(7, 1, Task::Excavate, 1.0)]);
    assert_eq!(goal, Some(NEAR));
    // Both claimed from nearer: nothing left to dig, so it explores (no goal at a treasure).
    let (goal, said) = dig(vec![claim(7, 0, Task::Excavate, 2.0), claim(8, 1, Task::Excavate, 1.0)]);
    assert!(goal != Some(NEAR) && goal != Some(FAR), "{goal:?}");
    assert!(said.is_empty());
}

/// Transporters share out loose units the same way, among themselves only.
#[test]
fn a_transporter_leaves_loose_units_claimed_from_nearer_to_its_claimant() {
    let haul = |heard| first_choice("transporter", RobotType::transporter(), true, heard);
    let (goal, said) = haul(vec![]);
    assert_eq!(goal, Some(NEAR));
    assert_eq!(claimed(&said), vec![(0, Task::Transport, 5.0)]);
    let (goal, said) = haul(vec![claim(3, 0, Task::Transport, 0.5)]);
    assert_eq!(goal, Some(FAR));
    assert_eq!(claimed(&said), vec![(1, Task::Transport, 10.0)]);
    let (goal, _) = haul(vec![claim(3, 0, Task::Excavate, 0.5)]);
    assert_eq!(goal, Some(NEAR));
}

/// A transporter carrying a part load delivers it once no loose units it knows of are left,
/// instead of waiting at a buried treasure until half full (which would keep units off the
/// home for hundreds of rounds).
#[test]
fn a_transporter_with_a_part_load_and_nothing_loose_goes_home() {
    // Home 8 m west of the robot, a treasure with 3 units still buried 4 m east.
    let art = "
        ....................
        H.......R...........
        ....................";
    let home = DVec2::new(0.5, 1.5);
    let treasure = DVec2::new(12.5, 1.5);
    let goal_with = |load: u32, loose: u32| {
        let mut w = TestWorld::from_ascii(art, 1.0)
            .unwrap()
            .with_type(RobotType::transporter())
            .knowing_all();
        remember(&mut w, 0, treasure, 3, loose);
        if load > 0 {
            w.robot.cargo.push((TreasureId::new(1), load));
        }
        decide_once(&mut w, "transporter");
        w.mind.output.goal()
    };
    // Empty: it goes to wait at the buried treasure.
    assert_eq!(goal_with(0, 0), Some(treasure));
    // 2 units of 10 and nothing loose anywhere it knows: home.
    assert_eq!(goal_with(2, 0), Some(home));
    // 2 units, and loose units at the treasure: it fetches them first.
    assert_eq!(goal_with(2, 1), Some(treasure));
}

/// A 241 m × 241 m open square with home at its centre (120.5, 120.5) and the robot 5 m
/// east of it; robot id 0, whose bearing from home is east (0 rad).
fn open_square() -> String {
    square_with_robot_at(125)
}

/// The open square of [`open_square`] with the robot at column `x` of home's row.
fn square_with_robot_at(robot_x: usize) -> String {
    (0..241)
        .map(|y| {
            (0..241)
                .map(|x| match (x, y) {
                    (120, 120) => 'H',
                    (x, 120) if x == robot_x => 'R',
                    _ => '.',
                })
                .collect::<String>()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The goal a fresh `strategy` robot of type `kind` picks on the open square, knowing
/// `known_m` round home (the whole square if `None`) and buried treasures at `treasures`
/// (offsets from home), having heard claims from team mates 1..=`mates` on a treasure it
/// does not know.
fn goal_on_square(
    strategy: &str,
    kind: RobotType,
    known_m: Option<f64>,
    treasures: &[DVec2],
    mates: u32,
) -> Option<DVec2> {
    let task = if kind.can_excavate() {
        Task::Excavate
    } else {
        Task::Transport
    };
    let mut w = TestWorld::from_ascii(&open_square(), 1.0).unwrap().with_type(kind);
    let home = w.home.center();
    w = match known_m {
        Some(r) => w.knowing_disc(home, r),
        None => w.knowing_all(),
    };
    for (i, offset) in (0..).zip(treasures) {
        remember(&mut w, i, home + *offset, 3, 0);
    }
    w.mind.perception.inbox = Inbox::from((1..=mates).map(|m| claim(m, 99, task, 1.0)).collect::<Vec<_>>());
    decide_once(&mut w, strategy);
    w.mind.output.goal().map(|g| g - home)
}

/// A worker that has heard from a large team takes only the treasures in its sector (its
/// bearing from home ± π × `sector_overlap` / (team mates heard + 1): about ±9° for an
/// excavator that heard 99) or within `near_m` (40 m) of it; alone, it takes the nearest.
#[test]
fn workers_take_the_treasures_of_their_sector_once_they_know_their_team() {
    let dig = |treasures: &[DVec2], mates| goal_on_square("excavator", RobotType::excavator(), None, treasures, mates);
    // North of home 55 m (55.2 m from the robot, bearing 90°) and east 58 m (53 m away,
    // bearing 0°): alone, the nearer one.
    let north = DVec2::new(0.0, 55.0);
    let east = DVec2::new(58.0, 0.0);
    assert_eq!(dig(&[north, east], 0), Some(east));
    // North at 50 m is the nearer one (50.2 m against 53 m): alone it takes it...
    let north = DVec2::new(0.0, 50.0);
    assert_eq!(dig(&[north, east], 0), Some(north));
    // ...with 99 team mates heard it is in another's sector: the east one, in its own.
    assert_eq!(dig(&[north, east], 99), Some(east));
    // With 3 team mates the sector is the whole circle (π × 5 / 4 > π).
    assert_eq!(dig(&[north, east], 3), Some(north));
    // Within near_m (north 30 m: 30.4 m away) it takes it whatever its bearing.
    let near = DVec2::new(0.0, 30.0);
    assert_eq!(dig(&[near, east], 99), Some(near));
    // Transporters: sector about ±21.6° among 100 (overlap 12), near_m 60; an empty one waits at
    // buried treasures, chosen the same way as loose units.
    let haul =
        |treasures: &[DVec2], mates| goal_on_square("transporter", RobotType::transporter(), None, treasures, mates);
    let north_far = DVec2::new(0.0, 80.0);
    let east_far = DVec2::new(100.0, 0.0);
    assert_eq!(haul(&[north_far, east_far], 0), Some(north_far));
    assert_eq!(haul(&[north_far, east_far], 99), Some(east_far));
    // 25° off its bearing, 90 m out (85.5 m away): outside the sector, so the one east is its
    // choice; 20° off (85.3 m away), inside, and nearer than the east one (95 m).
    let off = DVec2::from_angle(25f64.to_radians()) * 90.0;
    assert_eq!(haul(&[off, east_far], 99), Some(east_far));
    let off = DVec2::from_angle(20f64.to_radians()) * 90.0;
    let goal = haul(&[off, east_far], 99).unwrap();
    assert!(goal.distance(off) < 1e-9, "{goal}");
}

/// With nothing to take, a worker walks out on its bearing to the edge of what it knows:
/// an excavator to the edge itself, a transporter `post_behind_m` (15 m) behind it, both in
/// steps of 8 m. Known: a 50 m disc round home, so along the bearing (east) the edge,
/// probed every 4 m, is at 48 m.
#[test]
fn a_worker_with_nothing_to_take_waits_at_its_post_on_its_bearing() {
    let excavator = goal_on_square("excavator", RobotType::excavator(), Some(50.0), &[], 0);
    assert_eq!(excavator, Some(DVec2::new(48.0, 0.0)));
    // 48 − 15 = 33 m, down to a step of 8: 32 m.
    let transporter = goal_on_square("transporter", RobotType::transporter(), Some(50.0), &[], 0);
    assert_eq!(transporter, Some(DVec2::new(32.0, 0.0)));
}

/// A `cooperative` scout's first move on the open square with the robot 5 m west of home,
/// knowing a 50 m disc round home, having heard where `mates` team mates (ids 1..=`mates`)
/// stand, with `params`: its goal (from home) and the point it moves to (from home).
fn scout_first_move(mates: u32, params: &Params) -> (Option<DVec2>, Option<DVec2>) {
    let mut w = TestWorld::from_ascii(&square_with_robot_at(115), 1.0)
        .unwrap()
        .with_type(RobotType::explorer());
    let home = w.home.center();
    w = w.knowing_disc(home, 50.0);
    let heard = (1..=mates).map(|m| Message {
        from: RobotId::new(m),
        sent_round: 1,
        to: Recipient::Broadcast,
        payload: Payload::Position {
            position: home,
            goal: None,
        },
    });
    w.mind.perception.inbox = Inbox::from(heard.collect::<Vec<_>>());
    let mut s = StrategyRegistry::with_builtins().create("cooperative", params).unwrap();
    let action = s.decide(&mut w.ctx());
    let to = match action {
        Action::MoveTo { to } => Some(to - home),
        _ => None,
    };
    (w.mind.output.goal().map(|g| g - home), to)
}

/// A scout that has heard `spoke_mates` (24) team mates or more walks out along its bearing
/// (robot 0's is east) to just beyond the edge of what it knows, straight where nothing it
/// knows blocks the way; with fewer, or without `spoke_mates`, it explores the nearest
/// frontier. Known: a 50 m disc round home, the robot 5 m west of home. East, the edge,
/// probed every 4 m, is at 48 m; the target lies 2 m beyond it in steps of 4 m: 52 m. The
/// first step is 1 m (the explorer's speed) east. The nearest frontier lies west, 45 m from
/// the robot (the nearest point east is 55 m).
#[test]
fn scouts_of_a_large_team_walk_out_along_their_bearings() {
    let spokes = Params::default().with("spoke_mates", "24");
    let (goal, to) = scout_first_move(30, &spokes);
    assert_eq!(goal, Some(DVec2::new(52.0, 0.0)));
    let to = to.expect("a move");
    assert!(to.distance(DVec2::new(-4.0, 0.0)) < 1e-9, "moved to {to}");
    for (mates, params) in [(3, &spokes), (0, &spokes), (30, &Params::default())] {
        let (goal, _) = scout_first_move(mates, params);
        let goal = goal.expect("a frontier");
        assert!(goal.x < -40.0, "{mates} mates heard: goal {goal}");
    }
}

/// The goals of a `cooperative` robot (id 1) in [`common::corridor_with_two_ends`]: its
/// first, and the one after hearing, in its second round, each of `mates` (id, goal)
/// announce its goal.
fn goals_after_a_mates_announcement(mates: &[(u32, DVec2)]) -> (DVec2, DVec2) {
    let announced: Vec<_> = mates.iter().map(|&(id, goal)| (id, Some(goal))).collect();
    let (first, after) = goals_after_announcements(&[&announced], &Params::default());
    (first, after[0].0.expect("a frontier"))
}

/// [`goals_after_a_mates_announcement`] with `params`, for as many rounds after the first
/// as `heard` has lists: in each, the robot hears its list's (id, goal) announcements.
/// Each of those rounds' goal and action.
fn goals_after_announcements(
    heard: &[&[(u32, Option<DVec2>)]],
    params: &Params,
) -> (DVec2, Vec<(Option<DVec2>, Action)>) {
    let mut w = common::corridor_with_two_ends();
    w.robot.id = RobotId::new(1);
    let mut s = StrategyRegistry::with_builtins().create("cooperative", params).unwrap();
    let first = s.decide(&mut w.ctx());
    let first_goal = w.mind.output.goal().expect("a frontier");
    w.apply(first);
    let mut after = Vec::new();
    for announced in heard {
        let messages = announced.iter().map(|&(id, goal)| Message {
            from: RobotId::new(id),
            sent_round: w.round - 1,
            to: Recipient::Broadcast,
            payload: Payload::Position {
                position: DVec2::new(10.5, 1.5),
                goal,
            },
        });
        w.mind.perception.inbox = Inbox::from(messages.collect::<Vec<_>>());
        let action = s.decide(&mut w.ctx());
        after.push((w.mind.output.goal(), action));
        w.apply(action);
    }
    (first_goal, after)
}

/// Two robots that set out together pick the same nearest frontier: here the west end, 3 m
/// away (the east end is 6.5 m away). Told that mate 0 (a lower id) set out for it, robot 1
/// searches again, skipping targets within `avoid_radius_m` (5 m) of the mate's goal, and
/// takes the east end; a mate with a higher id, or none, leaves its target as it was.
#[test]
fn a_small_teams_robot_yields_a_shared_target_to_a_lower_id() {
    let (first, _) = goals_after_a_mates_announcement(&[]);
    assert!(first.x < 7.5, "the west end first, got {first}");
    let (_, yielded) = goals_after_a_mates_announcement(&[(0, first)]);
    assert!(yielded.x > 16.5, "the east end once mate 0 goes west, got {yielded}");
    for mates in [vec![], vec![(2, first)]] {
        let (_, kept) = goals_after_a_mates_announcement(&mates);
        assert_eq!(kept, first, "mates {mates:?}");
    }
}

/// Robot 1 first heads for the west end; in its second round it hears mate 0 set out for
/// it and mate 2 for a goal east, so it searches again and finds the east end, 7.5 m of
/// corridor away (it stepped 1 m west). With mate 2's goal 6.5 m from that target (not
/// within the 5 m `avoid_radius_m`, but nearer than the robot's walk), the robot leaves
/// the target to mate 2: no goal, and it stays put for `wait_rounds` rounds (5 by
/// default). Mate 2 then announces no goal (in round 3), and once its wait is over the
/// robot searches again and sets out east: in round 7 by default, in round 3 with
/// `wait_rounds` 1. While both mates keep saying their goals (every 10 rounds), the robot
/// searches every 5 rounds, finds the same target and leaves it again, to round 101 and on. Mates that fall silent after round 22 are
/// forgotten 50 rounds later (at round 80, claims are pruned every 10), and the robot sets
/// out at its next search, in round 82, for the nearer end, west. With mate 2's goal 8.5 m from the target,
/// with `wait_rounds` 0, or with mate 0 alone heard (a team of two), it sets out east at
/// once.
#[test]
fn a_robot_of_a_small_team_leaves_a_target_nearer_to_a_mates_goal_and_waits() {
    // Searching again, the robot takes the nearest frontier clear of the mates' goals, as
    // without comparing frontiers (comparing, both ends have a mate's goal nearer than the
    // robot's walk, and it would take the nearer: see the next test).
    let base = Params::default().with("compare_frontiers", "0");
    let mates = |mate_2_x: f64| [(0, Some(DVec2::new(7.0, 1.5))), (2, Some(DVec2::new(mate_2_x, 1.5)))];
    let near = mates(23.5);
    let withdrawn: &[(u32, Option<DVec2>)] = &[(2, None)];
    let quiet: &[(u32, Option<DVec2>)] = &[];
    let east = |goal: Option<DVec2>| goal.is_some_and(|g| g.x > 16.5);
    for (wait_rounds, params) in [(5, base.clone()), (1, base.clone().with("wait_rounds", "1"))] {
        // Heard in rounds 2 (both goals) and 3 (mate 2 withdraws), then nothing.
        let mut heard = vec![&near[..], withdrawn];
        heard.extend(std::iter::repeat_n(quiet, wait_rounds - 1));
        let (first, after) = goals_after_announcements(&heard, &params);
        assert!(first.x < 7.5, "the west end first, got {first}");
        for (k, &(goal, action)) in after.iter().enumerate().take(wait_rounds) {
            assert_eq!((goal, action), (None, Action::Idle), "round {}, {params:?}", k + 2);
        }
        let set_out = after[wait_rounds];
        assert!(
            east(set_out.0),
            "east in round {}, {params:?}: {set_out:?}",
            wait_rounds + 2
        );
    }
    // `after[k]` is round k + 2.
    let saying = |until: usize| -> Vec<_> {
        (0..100)
            .map(|k| if k % 10 == 0 && k <= until { &near[..] } else { quiet })
            .collect()
    };
    let (_, after) = goals_after_announcements(&saying(usize::MAX), &base);
    let moved = after.iter().position(|&step| step != (None, Action::Idle));
    assert_eq!(
        moved,
        None,
        "waits while the mates keep their goals: {:?}",
        moved.map(|k| after[k])
    );
    let (_, after) = goals_after_announcements(&saying(20), &base);
    let moved = after.iter().position(|&step| step != (None, Action::Idle));
    assert_eq!(moved, Some(80), "waits to round 81: {:?}", moved.map(|k| after[k]));
    let west = after[80].0.is_some_and(|g| g.x < 7.5);
    assert!(west, "the nearer west end in round 82: {:?}", after[80]);
    let no_wait = base.clone().with("wait_rounds", "0");
    let far = mates(25.5);
    for (mates, params) in [(&far[..], &base), (&near[..], &no_wait), (&near[..1], &base)] {
        let (_, after) = goals_after_announcements(&[mates], params);
        assert!(
            east(after[0].0),
            "the east end with {mates:?}, {params:?}: got {:?}",
            after[0]
        );
    }
}

/// The goal of a `cooperative` robot (id 1) with `params`, deciding for the first time in a
/// 64 m corridor whose middle it knows (from x = 16 m to 48 m; it stands at 24.5 m), having
/// just heard mate 2 announce `mate_goal`. The west frontier's target lies just across x = 16
/// m, 8.5 m away; the east one's just across x = 48 m, 23.5 m away.
fn first_goal_hearing(mate_goal: DVec2, params: &Params) -> DVec2 {
    let mut w = common::corridor(64, 24, 16..48);
    w.robot.id = RobotId::new(1);
    let announced = Message {
        from: RobotId::new(2),
        sent_round: w.round.saturating_sub(1),
        to: Recipient::Broadcast,
        payload: Payload::Position {
            position: mate_goal,
            goal: Some(mate_goal),
        },
    };
    w.mind.perception.inbox = Inbox::from(vec![announced]);
    let mut s = StrategyRegistry::with_builtins().create("cooperative", params).unwrap();
    s.decide(&mut w.ctx());
    w.mind.output.goal().expect("a frontier")
}

/// A robot of a small team takes, of the frontiers nearest to it (`compare_frontiers`, 8),
/// one that no team mate's goal is nearer to than its own route. Mate 2's goal at x = 10.5
/// m lies 5.5 m from the west target (the robot would walk 8.5 m), outside the 1 m
/// `avoid_radius_m`: the robot takes the east target. At x = 40 m the mate's goal is 24 m
/// from the west target and 8 m from the east one: the robot takes the west. With
/// `compare_frontiers` 0 it takes the nearest frontier clear of the mate's goal: west.
#[test]
fn a_small_teams_robot_takes_a_frontier_no_mate_is_nearer_to() {
    let near_radius = Params::default().with("avoid_radius_m", "1");
    let east = first_goal_hearing(DVec2::new(10.5, 1.5), &near_radius);
    assert!(east.x > 47.5, "east, as the mate is nearer to the west target: {east}");
    let west = first_goal_hearing(DVec2::new(40.0, 1.5), &near_radius);
    assert!(
        (15.0..16.5).contains(&west.x),
        "west, as the mate is nearer to the east target: {west}"
    );
    let nearest = first_goal_hearing(
        DVec2::new(10.5, 1.5),
        &near_radius.clone().with("compare_frontiers", "0"),
    );
    assert!((15.0..16.5).contains(&nearest.x), "west, without comparing: {nearest}");
}
