"""Run the demo from Python, plot what the swarm explored and delivered, and record it.

    pip install ./python matplotlib
    python examples/python/quickstart.py        # writes quickstart.png and quickstart.rrd

Open the recording with `rerun quickstart.rrd` (pip install rerun-sdk==0.36.3).
"""

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import smartteams  # noqa: E402

config = pathlib.Path(__file__).resolve().parents[2] / "configs" / "demo.xml"
sim = smartteams.Simulation(str(config), seed=42, rrd="quickstart.rrd")
while not sim.done:
    sim.step(100)
    print(f"round {sim.round}: {sim.metrics()['explored_fraction'][-1]:.1%} explored")
sim.close()

m = sim.metrics()
fig, (explored, delivered) = plt.subplots(1, 2, figsize=(10, 4))
explored.plot(m["round"], m["explored_fraction"])
explored.set(xlabel="round", ylabel="explored fraction of the free area", title="Exploration")
delivered.plot(m["round"], m["units_delivered"], label="units delivered")
delivered.plot(m["round"], m["units_dug"], label="units dug")
delivered.set(xlabel="round", ylabel="units", title="Treasures")
delivered.legend()
fig.tight_layout()
fig.savefig("quickstart.png", dpi=100)

robots = sim.robots()
print(f"{len(robots['id'])} robots walked {robots['distance_m'].sum():.0f} m; digest {sim.digest}")
print("wrote quickstart.png and quickstart.rrd")
