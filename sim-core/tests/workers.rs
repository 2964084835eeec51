//! The `excavator` and `transporter` strategies: how a worker picks its treasure when team
//! mates claim treasures, in a tiny world ([`TestWorld`]). Distances are worked out by hand
//! in the comments.

use std::sync::Arc;

use sim_core::agent::{Params, StrategyRegistry, TestWorld};
use sim_core::glam::DVec2;
use sim_core::spatial::{RobotId, TreasureId};
use sim_core::world::{Inbox, Message, Payload, Recipient, RobotType, Sighting, Task};

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
        payload: Arc::new(Payload::Claim {
            treasure: TreasureId::new(treasure),
            task,
            distance_m,
        }),
    }
}

/// The goal a fresh `strategy` robot of type `kind` picks in its first round, knowing the
/// whole corridor and both treasures (3 units buried, or lying loose if `loose`), having
/// heard `heard`; and the claims it broadcast.
fn first_choice(strategy: &str, kind: RobotType, loose: bool, heard: Vec<Message>) -> (Option<DVec2>, Vec<Payload>) {
    let mut w = TestWorld::from_ascii(CORRIDOR, 1.0)
        .unwrap()
        .with_type(kind)
        .knowing_all();
    for (i, position) in [NEAR, FAR].into_iter().enumerate() {
        let id = TreasureId::new(u32::try_from(i).unwrap());
        let (buried, loose) = if loose { (0, 3) } else { (3, 0) };
        let sighting = Sighting {
            treasure: id,
            position,
            buried,
            loose,
            round: 0,
        };
        w.mind.data.treasures.record(id, sighting, 0);
    }
    w.mind.perception.inbox = Inbox::from(heard);
    let mut s = StrategyRegistry::with_builtins()
        .create(strategy, &Params::default())
        .unwrap();
    s.decide(&mut w.ctx());
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
        let id = TreasureId::new(0);
        let sighting = Sighting {
            treasure: id,
            position: treasure,
            buried: 3,
            loose,
            round: 0,
        };
        w.mind.data.treasures.record(id, sighting, 0);
        if load > 0 {
            w.robot.cargo.push((TreasureId::new(1), load));
        }
        let mut s = StrategyRegistry::with_builtins()
            .create("transporter", &Params::default())
            .unwrap();
        s.decide(&mut w.ctx());
        w.mind.output.goal()
    };
    // Empty: it goes to wait at the buried treasure.
    assert_eq!(goal_with(0, 0), Some(treasure));
    // 2 units of 10 and nothing loose anywhere it knows: home.
    assert_eq!(goal_with(2, 0), Some(home));
    // 2 units, and loose units at the treasure: it fetches them first.
    assert_eq!(goal_with(2, 1), Some(treasure));
}
