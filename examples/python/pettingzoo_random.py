"""A random policy over the PettingZoo environment: every scout of the demo moves at random.

    pip install './python[rl]'
    python examples/python/pettingzoo_random.py
"""

import pathlib

import numpy as np

from smartteams.env import parallel_env

config = pathlib.Path(__file__).resolve().parents[2] / "configs" / "demo.xml"
env = parallel_env(config, groups=["scouts"], max_rounds=200, patch_cells=11)
observations, infos = env.reset(seed=1)
# The actions are random but seeded, so the example prints the same every time.
for k, agent in enumerate(env.possible_agents):
    env.action_space(agent).seed(1 + k)
returns = {agent: 0.0 for agent in env.possible_agents}
while env.agents:
    actions = {agent: env.action_space(agent).sample() for agent in env.agents}
    observations, rewards, terminations, truncations, infos = env.step(actions)
    for agent, reward in rewards.items():
        returns[agent] += reward
best = max(returns, key=returns.get)
print(f"{env.round} rounds; mean return {np.mean(list(returns.values())):.1f} m² explored first; best {best}")
