#!/usr/bin/env python3
"""Speed of Smart Teams from Python, against the command line (BENCHMARKS.md, "Python").

    pip install './python[rl]'
    python scripts/bench-python.py [--runs 5] [--smartteams target/ci/smartteams]

Prints, each as the median (min–max) of alternated runs:
1. `configs/bench-1000.xml` (200 rounds, no recording): rounds/s of `smartteams run` and of
   `Simulation.run()`, and their ratio;
2. `parallel_env` over the same config (1,000 robots) stepped with random actions, rounds/s
   with observations and rewards built;
3. 1,000 random walkers for 100 rounds: the built-in `random_walk` against the same walk
   written in Python (`register_strategy`), rounds/s.
"""

import argparse
import math
import pathlib
import re
import statistics
import subprocess
import tempfile
import time

import numpy as np
import smartteams

REPO = pathlib.Path(__file__).resolve().parents[1]
BENCH = REPO / "configs" / "bench-1000.xml"
WALKERS = """<simulation name="walkers" seed="1" rounds="{rounds}">
  <map file="{map}"/>
  <group name="walkers" count="1000" type="explorer" strategy="{strategy}" start="home">
    <param name="turn_probability" value="0.1"/>
  </group>
</simulation>
"""


class Walker:
    """`random_walk` without its collision tactic: straight on, turning at random or when held back."""

    needs = ["known_map"]

    def __init__(self, params):
        self.p = float(params.get("turn_probability", "0.05"))
        self.heading = None

    def decide(self, robot):
        if self.heading is None or robot.last_outcome != "done" or robot.random_bool(self.p):
            a = robot.uniform(0.0, 2.0 * math.pi)
            self.heading = (math.cos(a) * robot.speed_m, math.sin(a) * robot.speed_m)
        return smartteams.Move(*self.heading)


def summary(values):
    return f"{statistics.median(values):.1f} ({min(values):.1f}–{max(values):.1f})"


def cli_rate(binary, config, rounds):
    out = subprocess.run(
        [binary, "run", str(config), "--rounds", str(rounds), "--no-viewer"], capture_output=True, text=True, check=True
    ).stdout
    return float(re.search(r"\(([0-9.]+) rounds/s", out).group(1))


def python_rate(config, rounds):
    sim = smartteams.Simulation(str(config), rounds=rounds)
    t0 = time.perf_counter()
    sim.run()
    return rounds / (time.perf_counter() - t0)


def env_rate(rounds):
    from smartteams.env import parallel_env

    env = parallel_env(BENCH, max_rounds=rounds)
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    t0 = time.perf_counter()
    while env.agents:
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        env.step(actions)
    return rounds / (time.perf_counter() - t0)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=5)
    # Compare like with like: the binary of the cargo profile the package was built with.
    parser.add_argument("--smartteams", default=str(REPO / "target" / "ci" / "smartteams"))
    args = parser.parse_args()

    cli, py = [], []
    for _ in range(args.runs):
        cli.append(cli_rate(args.smartteams, BENCH, 200))
        py.append(python_rate(BENCH, 200))
    ratios = [p / c for p, c in zip(py, cli)]
    print(f"bench-1000, 200 rounds: CLI {summary(cli)} rounds/s, Simulation.run() {summary(py)}, "
          f"Python/CLI {statistics.median(ratios):.3f} ({min(ratios):.3f}–{max(ratios):.3f})")

    envs = [env_rate(100) for _ in range(args.runs)]
    print(f"parallel_env, 1,000 robots, random actions: {summary(envs)} rounds/s")

    smartteams.register_strategy("py_walker", Walker)
    with tempfile.TemporaryDirectory() as d:
        rust_cfg, py_cfg = pathlib.Path(d, "rust.xml"), pathlib.Path(d, "py.xml")
        demo = REPO / "maps" / "bench-1km.stmap"
        rust_cfg.write_text(WALKERS.format(rounds=100, map=demo, strategy="random_walk"))
        py_cfg.write_text(WALKERS.format(rounds=100, map=demo, strategy="py_walker"))
        rust, pyw = [], []
        for _ in range(args.runs):
            rust.append(python_rate(rust_cfg, 100))
            pyw.append(python_rate(py_cfg, 100))
    print(f"1,000 random walkers, 100 rounds: random_walk (Rust) {summary(rust)} rounds/s, "
          f"the walk in Python {summary(pyw)} rounds/s")


if __name__ == "__main__":
    main()
