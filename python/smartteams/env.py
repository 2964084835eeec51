"""Learning environments over a Smart Teams run.

- ``parallel_env(config, *, groups=None, max_rounds=None, patch_cells=11, seed=None)``: a
  PettingZoo ``ParallelEnv`` whose agents are the robots of the chosen groups (all by
  default), named ``robot_<id>``.
- ``gym_env(config, *, robot=0, ...)``: a Gymnasium ``Env`` that moves one robot while the
  others run their configured strategies.

Observation of a robot: a dict with ``patch``, the ``patch_cells`` × ``patch_cells`` window
of its own known map centred on it (``uint8``: 0 unknown, 1 free, 2 blocked or off the map;
row 0 the southern row), and ``state``, a ``float32`` vector (energy fraction, load
fraction, unit vector towards home x and y, treasures in view). Action: a ``Box(-1, 1,
(2,), float32)`` move, times the robot's speed and at most its speed long. Reward: the free
area the robot was first to explore this round, in m², plus the units it delivered. A robot
whose energy runs out is terminated; ``max_rounds`` (or the config's rounds) truncates.

Episodes are deterministic: ``reset(seed=s)`` plays the same episode for the same actions,
whatever the thread count. ``reset()`` without a seed draws the next episode's seed from
the last one given (or the ``seed`` argument, or the config's).
"""

import gymnasium
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from ._native import EnvCore

__all__ = ["parallel_env", "gym_env", "SmartTeamsParallelEnv", "SmartTeamsGymEnv"]

def _observation_space(patch_cells, treasures):
    low = np.array([0.0, 0.0, -1.0, -1.0, 0.0], dtype=np.float32)
    high = np.array([1.0, 1.0, 1.0, 1.0, max(treasures, 1)], dtype=np.float32)
    return spaces.Dict(
        {
            "patch": spaces.Box(0, 2, (patch_cells, patch_cells), np.uint8),
            "state": spaces.Box(low, high, dtype=np.float32),
        }
    )


def _action_space():
    return spaces.Box(-1.0, 1.0, (2,), np.float32)


class _Seeds:
    """The seeds of successive episodes: the one given, else drawn from the last one given."""

    def __init__(self, first):
        self._first = first
        self._rng = None

    def next(self, seed):
        if seed is not None:
            self._rng = np.random.default_rng(seed)
            return int(seed)
        if self._rng is None:
            self._rng = np.random.default_rng(self._first)
            return int(self._first)
        return int(self._rng.integers(2**63))


class SmartTeamsParallelEnv(ParallelEnv):
    """A PettingZoo ``ParallelEnv`` over a Smart Teams run (see the module's docs)."""

    metadata = {"name": "smartteams_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, config, *, groups=None, max_rounds=None, patch_cells=11, seed=None, threads=None):
        self._core = EnvCore(str(config), groups=groups, patch_cells=patch_cells, threads=threads)
        self._ids = list(self._core.robot_ids)
        self.possible_agents = [f"robot_{i}" for i in self._ids]
        self._index = {a: k for k, a in enumerate(self.possible_agents)}
        treasures = self._core.treasure_count
        self._observation_spaces = {a: _observation_space(patch_cells, treasures) for a in self.possible_agents}
        self._action_spaces = {a: _action_space() for a in self.possible_agents}
        self.max_rounds = max_rounds
        self.render_mode = None
        self.agents = []
        self._seeds = _Seeds(self._core.config_seed if seed is None else seed)

    def observation_space(self, agent):
        return self._observation_spaces[agent]

    def action_space(self, agent):
        return self._action_spaces[agent]

    def reset(self, seed=None, options=None):
        patches, states = self._core.reset(self._seeds.next(seed), self.max_rounds)
        self.agents = list(self.possible_agents)
        observations = {a: self._observation(patches, states, a) for a in self.agents}
        return observations, {a: {} for a in self.agents}

    def step(self, actions):
        live = list(self.agents)
        moves = np.zeros((len(self._ids), 2), dtype=np.float32)
        for agent, action in actions.items():
            moves[self._index[agent]] = action
        patches, states, rewards, alive, done = self._core.step(moves)
        observations, rewards_out, terminations, truncations, infos = {}, {}, {}, {}, {}
        for agent in live:
            k = self._index[agent]
            observations[agent] = self._observation(patches, states, agent)
            rewards_out[agent] = float(rewards[k])
            terminations[agent] = not bool(alive[k])
            truncations[agent] = bool(done) and bool(alive[k])
            infos[agent] = {}
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        return observations, rewards_out, terminations, truncations, infos

    def _observation(self, patches, states, agent):
        k = self._index[agent]
        return {"patch": patches[k], "state": states[k]}

    @property
    def round(self):
        """Rounds played in this episode."""
        return self._core.round

    def metrics(self):
        """The episode's metrics so far, as ``Simulation.metrics()`` gives them."""
        return self._core.metrics()

    def events(self):
        """The episode's events so far, as ``Simulation.events()`` gives them: ``(round,
        text)``, a disabled robot's whole reason included."""
        return self._core.events()

    def close(self):
        pass


class SmartTeamsGymEnv(gymnasium.Env):
    """A Gymnasium ``Env`` moving one robot of a Smart Teams run (see the module's docs)."""

    metadata = {"render_modes": []}

    def __init__(self, config, *, robot=0, max_rounds=None, patch_cells=11, seed=None, threads=None):
        self._core = EnvCore(str(config), robots=[robot], patch_cells=patch_cells, threads=threads)
        self.observation_space = _observation_space(patch_cells, self._core.treasure_count)
        self.action_space = _action_space()
        self.max_rounds = max_rounds
        self.render_mode = None
        self._seeds = _Seeds(self._core.config_seed if seed is None else seed)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        patches, states = self._core.reset(self._seeds.next(seed), self.max_rounds)
        return {"patch": patches[0], "state": states[0]}, {}

    def step(self, action):
        moves = np.asarray(action, dtype=np.float32).reshape(1, 2)
        patches, states, rewards, alive, done = self._core.step(moves)
        terminated = not bool(alive[0])
        truncated = bool(done) and not terminated
        return {"patch": patches[0], "state": states[0]}, float(rewards[0]), terminated, truncated, {}

    @property
    def round(self):
        """Rounds played in this episode."""
        return self._core.round

    def metrics(self):
        """The episode's metrics so far, as ``Simulation.metrics()`` gives them."""
        return self._core.metrics()

    def events(self):
        """The episode's events so far, as ``Simulation.events()`` gives them: ``(round,
        text)``, a disabled robot's whole reason included."""
        return self._core.events()


def parallel_env(config, *, groups=None, max_rounds=None, patch_cells=11, seed=None, threads=None):
    """A PettingZoo ``ParallelEnv`` over the XML config ``config`` (see the module's docs)."""
    return SmartTeamsParallelEnv(
        config, groups=groups, max_rounds=max_rounds, patch_cells=patch_cells, seed=seed, threads=threads
    )


def gym_env(config, *, robot=0, max_rounds=None, patch_cells=11, seed=None, threads=None):
    """A Gymnasium ``Env`` moving robot ``robot`` of the XML config ``config`` (see the module's docs)."""
    return SmartTeamsGymEnv(
        config, robot=robot, max_rounds=max_rounds, patch_cells=patch_cells, seed=seed, threads=threads
    )
