"""Smart Teams from Python: simulate large robot swarms that explore unknown terrain, find
treasures, dig them out and carry them home.

    import smartteams
    sim = smartteams.Simulation("configs/demo.xml", seed=1)
    sim.run()
    m = sim.metrics()          # dict of numpy arrays, one element per round
    m["explored_fraction"][-1]

Strategies written in Python (no rebuild): ``register_strategy(name, factory)``, then name
it in a config's ``<group strategy="name">``. Learning environments: ``smartteams.env``
(PettingZoo and Gymnasium; ``pip install 'smartteams[rl]'``).
"""

from ._native import (
    Broadcast,
    Excavate,
    Idle,
    Load,
    Move,
    MoveTo,
    Robot,
    Send,
    Simulation,
    SmartTeamsError,
    Unload,
    register_strategy,
    strategies,
)

__all__ = [
    "Broadcast",
    "Excavate",
    "Idle",
    "Load",
    "Move",
    "MoveTo",
    "Robot",
    "Send",
    "Simulation",
    "SmartTeamsError",
    "Unload",
    "register_strategy",
    "strategies",
]


def __getattr__(name):
    # `smartteams.env` needs Gymnasium and PettingZoo: imported on first use only.
    if name == "env":
        import importlib

        return importlib.import_module(".env", __name__)
    raise AttributeError(f"module 'smartteams' has no attribute {name!r}")
