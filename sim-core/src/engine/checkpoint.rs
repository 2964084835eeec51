//! The state of a running simulation, for checkpoints: everything a round changes, so that
//! a simulation set up again from the same scenario and given this state plays on exactly
//! as the one that was saved (`a_restored_run_plays_on_bit_for_bit`, tests/kernel.rs). What
//! the scenario fixes (map, types, groups, treasure positions and index, the navigation
//! graph) is rebuilt, not stored; so are the robot indexes (from the positions) and the
//! random generators (each is a function of seed, robot and round). The state is CBOR
//! (`ciborium`), written from references so a checkpoint never copies a known map; the file
//! around it is `io::checkpoint`'s.

use std::collections::HashMap;

use glam::DVec2;
use serde::{Deserialize, Serialize};

use crate::agent::DataModule;
use crate::engine::simulation::Simulation;
use crate::spatial::{Disc, KnownMap, RobotId};
use crate::world::{ExploredMilestones, Message, Payload, Recipient, Robot, TreasureState};
use crate::{Error, Result};

/// What changes in a run, as written (borrowed from the simulation).
#[derive(Serialize)]
struct StateRef<'a> {
    round: u64,
    robots: &'a [Robot],
    treasures: &'a [TreasureState],
    strategies_failed: u32,
    explored: &'a KnownMap,
    explored_free_cells: u64,
    milestones: ExploredMilestones,
    explored_views: &'a [Option<Disc>],
    agents: Vec<AgentRef<'a>>,
    /// Payloads of the messages in flight, each once (receivers of a broadcast share it).
    payloads: Vec<&'a Payload>,
    /// Per robot, the messages it will read next round.
    inboxes: Vec<Vec<InFlight>>,
}

/// [`StateRef`] read back.
#[derive(Deserialize)]
struct State {
    round: u64,
    robots: Vec<Robot>,
    treasures: Vec<TreasureState>,
    strategies_failed: u32,
    explored: KnownMap,
    explored_free_cells: u64,
    milestones: ExploredMilestones,
    explored_views: Vec<Option<Disc>>,
    agents: Vec<AgentState>,
    payloads: Vec<Payload>,
    inboxes: Vec<Vec<InFlight>>,
}

#[derive(Serialize)]
struct AgentRef<'a> {
    /// One byte string, not a list of numbers (a CBOR item per byte made checkpoints slow).
    #[serde(with = "serde_bytes")]
    strategy: Vec<u8>,
    data: &'a DataModule,
    goal: Option<DVec2>,
    path: &'a [DVec2],
    /// In id order (the map is only looked up, so its order does not matter).
    merged_from: Vec<(RobotId, u64)>,
}

#[derive(Deserialize)]
struct AgentState {
    #[serde(with = "serde_bytes")]
    strategy: Vec<u8>,
    data: DataModule,
    goal: Option<DVec2>,
    path: Vec<DVec2>,
    merged_from: Vec<(RobotId, u64)>,
}

#[derive(Serialize, Deserialize)]
struct InFlight {
    from: RobotId,
    sent_round: u64,
    to: Recipient,
    payload: u32,
}

impl Simulation {
    /// Fails, naming the group, if a robot's strategy cannot save its state
    /// ([`Strategy::save_state`](crate::agent::Strategy::save_state)), so that a run asked
    /// to checkpoint is refused before its first round rather than at its first checkpoint.
    pub fn check_checkpointable(&self) -> Result<()> {
        for (a, r) in self.agents.iter().zip(&self.robots) {
            if a.strategy.save_state().is_none() {
                return Err(self.not_checkpointable(r));
            }
        }
        Ok(())
    }

    /// The error for a robot whose strategy cannot save its state.
    fn not_checkpointable(&self, r: &Robot) -> Error {
        let g = &self.groups[r.group];
        Error::InvalidParameter(format!(
            "group '{}': strategy '{}' cannot save its state (its `Strategy::save_state` gave \
             none), so this run cannot be checkpointed",
            g.name, g.strategy
        ))
    }

    /// Append the state of the run after the rounds played so far to `out` (CBOR). Fails
    /// if a robot's strategy cannot save its state.
    pub fn write_state(&self, out: &mut Vec<u8>) -> Result<()> {
        // Each strategy saves its state once (not once to check, then again to write).
        let agents = self
            .agents
            .iter()
            .zip(&self.robots)
            .map(|(a, r)| {
                let strategy = a.strategy.save_state().ok_or_else(|| self.not_checkpointable(r))?;
                let mut merged_from: Vec<(RobotId, u64)> = a.merged_from.iter().map(|(&k, &v)| (k, v)).collect();
                merged_from.sort_unstable();
                Ok(AgentRef {
                    strategy,
                    data: &a.mind.data,
                    goal: a.mind.output.goal(),
                    path: a.mind.output.path(),
                    merged_from,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        // Each message of the bag once (receivers of a broadcast read the same one).
        let mut ids: HashMap<u32, u32> = HashMap::new();
        let mut payloads = Vec::new();
        let inboxes = self
            .inboxes
            .iter()
            .map(|picks| {
                picks
                    .iter()
                    .map(|&k| {
                        let m = &self.mailbag[k as usize];
                        let payload = *ids.entry(k).or_insert_with(|| {
                            payloads.push(&m.payload);
                            u32::try_from(payloads.len() - 1).unwrap_or(u32::MAX)
                        });
                        InFlight {
                            from: m.from,
                            sent_round: m.sent_round,
                            to: m.to,
                            payload,
                        }
                    })
                    .collect()
            })
            .collect();
        let state = StateRef {
            round: self.round,
            robots: &self.robots,
            treasures: &self.treasures,
            strategies_failed: self.strategies_failed,
            explored: &self.explored,
            explored_free_cells: self.explored_free_cells,
            milestones: self.milestones,
            explored_views: &self.explored_views,
            agents,
            payloads,
            inboxes,
        };
        ciborium::into_writer(&state, out).map_err(|e| Error::Malformed(format!("cannot encode the run's state: {e}")))
    }

    /// Continue from a state written by [`write_state`](Self::write_state) from a run of
    /// the same scenario: this simulation (just set up) then plays on exactly as that one
    /// would have. A state that does not decode, or does not fit the scenario, is refused
    /// with an error saying what does not fit; the simulation may then be partly restored
    /// (strategies restore one by one) and should be dropped.
    pub fn read_state(&mut self, bytes: &[u8]) -> Result<()> {
        let state: State = ciborium::from_reader(bytes)
            .map_err(|e| Error::Malformed(format!("the run's state does not decode: {e}")))?;
        self.check_state(&state)?;
        // Strategies first: the only step that can still fail.
        for (i, (agent, saved)) in self.agents.iter_mut().zip(&state.agents).enumerate() {
            agent
                .strategy
                .restore_state(&saved.strategy)
                .map_err(|e| Error::Malformed(format!("robot {i}'s strategy state: {e}")))?;
        }
        for (agent, saved) in self.agents.iter_mut().zip(state.agents) {
            agent.mind.data = saved.data;
            agent.mind.output.restore(saved.goal, saved.path);
            agent.merged_from = saved.merged_from.into_iter().collect();
        }
        self.restore_mailbag(&state.payloads, state.inboxes)?;
        self.round = state.round;
        self.robots = state.robots;
        self.treasures = state.treasures;
        self.strategies_failed = state.strategies_failed;
        self.explored = state.explored;
        self.explored_free_cells = state.explored_free_cells;
        self.milestones = state.milestones;
        self.explored_views = state.explored_views;
        self.rebuild_robot_indexes();
        self.report.round = self.round;
        self.report.metrics = self.metrics(self.round, 0, 0, self.robot_memory_bytes());
        Ok(())
    }

    /// The saved messages back in the bag, each once: the receivers of a message name the
    /// same payload with the same sender, round and addressing, and read one entry, as
    /// before the save, so that the state saves to the same bytes again. (A payload named
    /// with other headers too gets an entry for each.)
    fn restore_mailbag(&mut self, payloads: &[Payload], inboxes: Vec<Vec<InFlight>>) -> Result<()> {
        let mut placed: HashMap<u32, usize> = HashMap::new();
        self.mailbag.clear();
        for (picks, saved) in self.inboxes.iter_mut().zip(inboxes) {
            picks.clear();
            for m in saved {
                let same = |b: &Message| b.from == m.from && b.sent_round == m.sent_round && b.to == m.to;
                let at = match placed.get(&m.payload) {
                    Some(&at) if same(&self.mailbag[at]) => at,
                    _ => {
                        self.mailbag.push(Message {
                            from: m.from,
                            sent_round: m.sent_round,
                            to: m.to,
                            payload: payloads[m.payload as usize].clone(),
                        });
                        placed.entry(m.payload).or_insert(self.mailbag.len() - 1);
                        self.mailbag.len() - 1
                    }
                };
                picks.push(u32::try_from(at).map_err(|_| Error::Malformed("too many messages".into()))?);
            }
        }
        Ok(())
    }

    /// Everything `read_state` relies on: counts, ids and indices in range, known maps
    /// well formed and over this map's grid, positions on the map.
    fn check_state(&self, s: &State) -> Result<()> {
        self.check_counts(s)?;
        self.check_robots_and_treasures(s)?;
        self.check_known_maps(s)?;
        check_inboxes(s, self.robots.len())
    }

    /// As many robots, agents, inboxes, views and treasures as this scenario, at a round
    /// within its run.
    fn check_counts(&self, s: &State) -> Result<()> {
        let n = self.robots.len();
        if s.robots.len() != n || s.agents.len() != n || s.inboxes.len() != n || s.explored_views.len() != n {
            return Err(unfit(format!("{} robots saved, the scenario has {n}", s.robots.len())));
        }
        if s.treasures.len() != self.treasures.len() {
            return Err(unfit(format!(
                "{} treasures saved, the map has {}",
                s.treasures.len(),
                self.treasures.len()
            )));
        }
        if s.round > self.rounds {
            return Err(unfit(format!(
                "round {} is past the run's {} rounds",
                s.round, self.rounds
            )));
        }
        Ok(())
    }

    /// Each robot and treasure the one of this scenario, robots on the map with finite
    /// energy, carrying treasures that exist.
    fn check_robots_and_treasures(&self, s: &State) -> Result<()> {
        let extent = self.map.obstacles.grid().extent();
        for (i, (r, here)) in s.robots.iter().zip(&self.robots).enumerate() {
            if r.id != here.id || r.type_index != here.type_index || r.group != here.group {
                return Err(unfit(format!("robot {i} is another robot (id, type or group differ)")));
            }
            let on_map = r.position.is_finite() && extent.distance_squared_to(r.position) == 0.0;
            if !(on_map && r.energy.is_finite()) {
                return Err(unfit(format!(
                    "robot {i} is at {} with energy {}",
                    r.position, r.energy
                )));
            }
            if let Some((t, _)) = r.cargo.iter().find(|(t, _)| t.index() >= s.treasures.len()) {
                return Err(unfit(format!("robot {i} carries unknown treasure {t}")));
            }
        }
        for (i, (t, here)) in s.treasures.iter().zip(&self.treasures).enumerate() {
            if t.id != here.id || t.position != here.position || t.initial != here.initial {
                return Err(unfit(format!("treasure {i} is another treasure")));
            }
        }
        Ok(())
    }

    /// The explored map, the known maps in flight and the robots' own well formed and over
    /// this map's grid; a known map kept exactly by the strategies that keep one here; maps
    /// merged from robots that exist.
    fn check_known_maps(&self, s: &State) -> Result<()> {
        let n = self.robots.len();
        let grid = *self.map.obstacles.grid();
        let check_map = |k: &KnownMap, what: &str| {
            if *k.grid() != grid {
                return Err(unfit(format!("{what} is over another grid")));
            }
            k.validate().map_err(|e| unfit(format!("{what}: {e}")))
        };
        check_map(&s.explored, "the explored map")?;
        for p in &s.payloads {
            if let Payload::KnownMap(k) = p {
                check_map(k, "a known map in flight")?;
            }
        }
        for (i, (agent, saved)) in self.agents.iter().zip(&s.agents).enumerate() {
            if saved.data.known.is_some() != agent.mind.data.known.is_some() {
                return Err(unfit(format!(
                    "robot {i}'s strategy keeps a known map in one run and not the other"
                )));
            }
            if let Some(k) = &saved.data.known {
                check_map(k, &format!("robot {i}'s known map"))?;
            }
            if let Some((id, _)) = saved.merged_from.iter().find(|(id, _)| id.index() >= n) {
                return Err(unfit(format!("robot {i} merged a map from unknown robot {id}")));
            }
        }
        Ok(())
    }
}

/// Every message in the inboxes from, and to, one of the `n` robots, with a payload saved.
fn check_inboxes(s: &State, n: usize) -> Result<()> {
    for (i, inbox) in s.inboxes.iter().enumerate() {
        for m in inbox {
            let to_ok = match m.to {
                Recipient::Broadcast => true,
                Recipient::Direct(id) => id.index() < n,
            };
            if m.from.index() >= n || !to_ok || m.payload as usize >= s.payloads.len() {
                return Err(unfit(format!(
                    "a message to robot {i} names a robot or payload that does not exist"
                )));
            }
        }
    }
    Ok(())
}

/// The error of a saved state that does not fit the scenario, saying why.
fn unfit(why: impl std::fmt::Display) -> Error {
    Error::Malformed(format!("the saved state does not fit this scenario: {why}"))
}
