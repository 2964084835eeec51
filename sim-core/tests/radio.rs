//! Radio budgets: a receiver takes messages addressed to it first, then broadcasts, until
//! the next would overflow `radio_bytes_per_round`. And who receives at all: robots alive
//! when a message is sent. Expected inboxes are worked out by hand from the payload sizes
//! (a position is 33 bytes, a custom message its tag plus its data).

use sim_core::agent::{Ctx, Needs, Strategy, StrategyRegistry};
use sim_core::engine::{Group, ScenarioBuilder, Simulation};
use sim_core::glam::DVec2;
use sim_core::spatial::{Grid, ObstacleMap, RobotId};
use sim_core::world::{Action, HomeBase, MapData, Payload, Recipient, RobotType};

/// Every round: broadcast its position, and send 10 bytes ("hi" + 8 bytes) to robot 0.
struct Chatter;

impl Strategy for Chatter {
    fn needs(&self) -> Needs {
        Needs {
            messages: true,
            ..Needs::NONE
        }
    }
    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        ctx.broadcast(Payload::Position {
            position: ctx.position(),
            goal: None,
        });
        if ctx.me.id != RobotId::new(0) {
            ctx.send(
                RobotId::new(0),
                Payload::Custom {
                    kind: "hi".into(),
                    data: vec![0; 8],
                },
            );
        }
        Action::Idle
    }
}

/// 12 chatters at the home of a free 20 m × 20 m map (all within each other's 20 m range).
fn chatters(radio_bytes_per_round: u64) -> Simulation {
    let kind = RobotType::explorer().with_radio_bytes_per_round(radio_bytes_per_round);
    chatting(vec![kind], vec![Group::new("chatter", 0, 12)])
}

/// Groups of chatters of the given types at the home of a free 20 m × 20 m map.
fn chatting(types: Vec<RobotType>, groups: Vec<Group>) -> Simulation {
    let grid = Grid::new(DVec2::ZERO, 1.0, 20, 20).unwrap();
    let map = MapData {
        obstacles: ObstacleMap::empty(grid),
        home: HomeBase::Disc {
            center: DVec2::splat(10.0),
            radius_m: 3.0,
        },
        treasures: Vec::new(),
    };
    let mut registry = StrategyRegistry::empty();
    registry.register("chatter", "test", |_| Ok(Box::new(Chatter)));
    let scenario = groups
        .into_iter()
        .fold(ScenarioBuilder::new(map).with_types(types), ScenarioBuilder::with_group)
        .build(&registry)
        .unwrap();
    Simulation::new(scenario).unwrap()
}

/// (sender, is a broadcast) of each robot's pending messages.
fn inboxes(sim: &Simulation) -> Vec<Vec<(u32, bool)>> {
    sim.pending_messages()
        .iter()
        .map(|inbox| {
            inbox
                .iter()
                .map(|m| (m.from.get(), m.to == Recipient::Broadcast))
                .collect()
        })
        .collect()
}

#[test]
fn a_budget_that_never_fills_delivers_exactly_what_no_budget_does() {
    let mut free = chatters(u64::MAX);
    let mut roomy = chatters(u64::MAX - 1);
    for _ in 0..3 {
        free.step();
        roomy.step();
        assert_eq!(inboxes(&free), inboxes(&roomy));
    }
    // Robot 0 hears 11 direct messages and 11 broadcasts, in sender order.
    assert_eq!(inboxes(&free)[0].len(), 22);
    assert_eq!(inboxes(&free)[5].len(), 11);
}

/// 150 chatters, more senders than one block of addressing takes: every inbox holds the
/// round's messages to it in sender order (each sender's in the order queued: its
/// broadcast, then its direct message to robot 0), with or without a budget, on 1 and 4
/// threads.
#[test]
fn many_senders_are_delivered_in_sender_order() {
    let n = 150u32;
    let expected: Vec<Vec<(u32, bool)>> = (0..n)
        .map(|r| {
            (0..n)
                .filter(|&s| s != r)
                .flat_map(|s| {
                    let direct = (r == 0).then_some((s, false));
                    std::iter::once((s, true)).chain(direct)
                })
                .collect()
        })
        .collect();
    for budget in [u64::MAX, u64::MAX - 1] {
        for threads in [1, 4] {
            let kind = RobotType::explorer().with_radio_bytes_per_round(budget);
            let mut sim = chatting(vec![kind], vec![Group::new("chatter", 0, n)]);
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| sim.step());
            assert_eq!(inboxes(&sim), expected, "budget {budget}, {threads} threads");
        }
    }
}

#[test]
fn a_full_radio_drops_the_rest() {
    let mut sim = chatters(70);
    sim.step();
    let got = inboxes(&sim);
    // Robot 0: direct messages first, 10 bytes each: 7 fit in 70 bytes (senders 1..=7, in
    // order); then no 33-byte broadcast fits.
    assert_eq!(got[0], (1..=7).map(|s| (s, false)).collect::<Vec<_>>());
    // Everyone else: two 33-byte broadcasts fit in 70 bytes, a third would not.
    for (r, inbox) in got.iter().enumerate().skip(1) {
        assert_eq!(inbox.len(), 2, "robot {r}: {inbox:?}");
        assert!(inbox.iter().all(|&(s, broadcast)| broadcast && s != r as u32));
        assert!(inbox[0].0 < inbox[1].0, "sender order: {inbox:?}");
    }
    // Sent counts are unaffected: 12 broadcasts and 11 direct messages.
    assert_eq!(sim.report().metrics.messages, 23);
}

/// The round's links, worked out from the inboxes when asked, are every pending delivery
/// (sender → receiver), receiver by receiver, with or without radio budgets; counted by
/// hand for the chatters.
#[test]
fn links_are_the_pending_deliveries() {
    for budget in [u64::MAX, 70] {
        let mut sim = chatters(budget);
        sim.step();
        let links: Vec<(u32, u32)> = sim.links().map(|l| (l.from.get(), l.to.get())).collect();
        let from_inboxes: Vec<(u32, u32)> = inboxes(&sim)
            .iter()
            .enumerate()
            .flat_map(|(r, inbox)| inbox.iter().map(move |&(s, _)| (s, r as u32)))
            .collect();
        assert_eq!(links, from_inboxes);
        assert_eq!(sim.link_count(), links.len());
        // Unlimited: 12 × 11 broadcasts and 11 direct messages to robot 0. With 70 bytes a
        // round: 7 direct messages for robot 0, two broadcasts each for the other 11.
        let want = if budget == u64::MAX { 12 * 11 + 11 } else { 7 + 11 * 2 };
        assert_eq!(links.len(), want, "budget {budget}");
        assert!(links.iter().all(|&(s, r)| s != r), "nobody hears itself");
    }
}

/// Sampling every k-th link from the inboxes gives what stepping through all of them gives.
#[test]
fn links_every_is_links_step_by() {
    for budget in [u64::MAX, 70] {
        let mut sim = chatters(budget);
        for _ in 0..3 {
            sim.step();
            for stride in [1, 2, 3, 7, 11, 50, 1000] {
                let pair = |l: sim_core::world::Link| (l.from.get(), l.to.get());
                let all: Vec<_> = sim.links().step_by(stride).map(pair).collect();
                let every: Vec<_> = sim.links_every(stride).map(pair).collect();
                assert_eq!(every, all, "budget {budget}, stride {stride}");
            }
        }
    }
}

/// Messages without budgets are put in the inboxes after step 3, yet a receiver takes a
/// message only if it was alive when the message was sent. Robot 5 runs dry in its own turn
/// of round 1 (its upkeep is all its energy), before it sends: it hears robots 0 to 4,
/// whose turns came first, and not 6 to 11; nobody hears it.
#[test]
fn a_robot_that_runs_dry_hears_only_who_sent_before_its_turn() {
    let normal = RobotType::explorer();
    let frail = RobotType::explorer().with_energy_capacity(normal.energy_idle);
    let groups = vec![
        Group::new("chatter", 0, 5),
        Group::new("chatter", 1, 1),
        Group::new("chatter", 0, 6),
    ];
    let mut sim = chatting(vec![normal, frail], groups);
    sim.step();
    assert!(!sim.robots()[5].alive, "robot 5 ran dry");
    let got = inboxes(&sim);
    assert_eq!(got[5], (0..5).map(|s| (s, true)).collect::<Vec<_>>());
    for (r, inbox) in got.iter().enumerate().filter(|&(r, _)| r != 5) {
        assert!(inbox.iter().all(|&(s, _)| s != 5), "robot {r} heard robot 5: {inbox:?}");
        // Everyone else hears the other ten broadcasts (robot 0 also ten direct messages).
        let broadcasts = inbox.iter().filter(|&&(_, b)| b).count();
        assert_eq!(broadcasts, 10, "robot {r}: {inbox:?}");
    }
    assert_eq!(got[0].len(), 20);
}
