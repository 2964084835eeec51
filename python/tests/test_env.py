"""The learning environments pass PettingZoo's and Gymnasium's own checkers, and episodes
are deterministic."""

import warnings

import numpy as np
import pytest

from conftest import REPO, write_config

pytest.importorskip("pettingzoo", reason="the rl extra (pip install 'smartteams[rl]')")

import gymnasium  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

import smartteams  # noqa: E402
from smartteams.env import gym_env, parallel_env  # noqa: E402

DEMO = REPO / "configs" / "demo.xml"


def test_parallel_env_passes_pettingzoo_api_test():
    env = parallel_env(DEMO, groups=["scouts"], max_rounds=60, patch_cells=9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(env, num_cycles=100)


def test_parallel_env_passes_pettingzoo_seed_test():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_seed_test(lambda: parallel_env(DEMO, max_rounds=40), num_cycles=50)


def test_gym_env_passes_gymnasium_check_env():
    env = gym_env(DEMO, robot=3, max_rounds=40)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)


def play(env, seed, rounds, actions_seed):
    """Observations and rewards of `rounds` rounds of random actions."""
    rng = np.random.default_rng(actions_seed)
    obs, _ = env.reset(seed=seed)
    trace = [sorted((a, o["patch"].tobytes(), o["state"].tobytes()) for a, o in obs.items())]
    for _ in range(rounds):
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        obs, rewards, term, trunc, _ = env.step(actions)
        trace.append(sorted((a, o["patch"].tobytes(), o["state"].tobytes(), rewards[a], term[a], trunc[a]) for a, o in obs.items()))
    return trace


def test_episodes_are_the_same_for_the_same_seed_and_actions_on_any_thread_count():
    one = play(parallel_env(DEMO, max_rounds=30, threads=1), 7, 30, 1)
    two = play(parallel_env(DEMO, max_rounds=30, threads=2), 7, 30, 1)
    assert one == two
    # Other actions, another episode.
    assert one != play(parallel_env(DEMO, max_rounds=30), 7, 30, 2)


def test_observations_rewards_and_truncation_mean_what_they_say():
    env = parallel_env(DEMO, groups=["scouts", "diggers"], max_rounds=25, patch_cells=11)
    assert env.possible_agents == [f"robot_{i}" for i in range(16)]
    obs, infos = env.reset(seed=3)
    first = obs["robot_0"]
    assert first["patch"].shape == (11, 11) and first["patch"].dtype == np.uint8
    # Before the first round nobody has looked round yet.
    assert (first["patch"] == 0).all()
    state = first["state"]
    assert state.dtype == np.float32 and state[0] == pytest.approx(1.0)  # full energy
    assert np.hypot(state[2], state[3]) == pytest.approx(1.0, abs=1e-6) or (state[2:4] == 0).all()
    total = 0.0
    for r in range(25):
        actions = {a: np.array([1.0, 0.0], dtype=np.float32) for a in env.agents}
        obs, rewards, term, trunc, _ = env.step(actions)
        total += sum(rewards.values())
        assert all(trunc.values()) == (r == 24)
        if r == 0:
            # After a round the robot has seen round it: its own cell is known free.
            assert obs["robot_0"]["patch"][5, 5] == 1
    assert env.agents == []
    # Moving east from home, the robots explored new ground: rewards are the m² they were
    # first to see, so positive, and whole cells of 1 m² each.
    assert total > 0 and total == int(total)
    assert env.metrics()["round"][-1] == 25


def test_the_random_policy_example_prints_the_same_every_run():
    import subprocess
    import sys

    example = REPO / "examples" / "python" / "pettingzoo_random.py"
    outputs = [
        subprocess.run([sys.executable, str(example)], capture_output=True, text=True, check=True).stdout
        for _ in range(2)
    ]
    assert "rounds; mean return" in outputs[0]
    assert outputs[0] == outputs[1]


def test_out_of_range_arguments_raise_saying_which():
    with pytest.raises(smartteams.SmartTeamsError, match="patch_cells must not be negative, got -3"):
        parallel_env(DEMO, patch_cells=-3)
    env = parallel_env(DEMO, max_rounds=-1)
    with pytest.raises(smartteams.SmartTeamsError, match="max_rounds must not be negative, got -1"):
        env.reset(seed=1)


class _Failing:
    def __init__(self, params):
        pass

    def decide(self, robot):
        return 1 / 0


def test_the_environments_give_the_whole_reason_a_mate_was_disabled(tmp_path):
    smartteams.register_strategy("py_failing_mate", _Failing)
    config = write_config(
        tmp_path,
        '<simulation seed="1" rounds="5"><map file="MAP"/>'
        '<group name="learners" count="1" type="explorer" strategy="random_walk" start="home"/>'
        '<group name="mates" count="1" type="explorer" strategy="py_failing_mate" start="home"/></simulation>',
    )
    for env in (parallel_env(config, groups=["learners"]), gym_env(config, robot=0)):
        env.reset(seed=1)
        with pytest.warns(RuntimeWarning, match="robot 1 is disabled.*events\\(\\) has the whole reason"):
            if isinstance(env, gymnasium.Env):
                env.step(np.zeros(2, dtype=np.float32))
            else:
                env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
        (text,) = [t for _, t in env.events() if "disabled" in t]
        assert "ZeroDivisionError" in text, text
