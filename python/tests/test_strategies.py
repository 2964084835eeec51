"""Strategies written in Python: named in XML configs, deterministic, contained when they
fail, checkpointed."""

import math
import re
import subprocess
import sys
import time

import pytest
import smartteams

from conftest import REPO, write_config

WALKERS = """<simulation name="walkers" seed="{seed}" rounds="{rounds}">
  <map file="MAP"/>
  <group name="walkers" count="8" type="explorer" strategy="{strategy}" start="home">
    <param name="turn_probability" value="0.2"/>
  </group>
</simulation>
"""


class Walker:
    """Walks straight, turning with a probability per round or when held back."""

    needs = ["known_map"]

    def __init__(self, params):
        self.turn_probability = float(params.get("turn_probability", "0.1"))
        self.heading = None

    def decide(self, robot):
        if self.heading is None or robot.last_outcome != "done" or robot.random() < self.turn_probability:
            angle = robot.uniform(0.0, 2.0 * math.pi)
            self.heading = (math.cos(angle), math.sin(angle))
        return smartteams.Move(self.heading[0] * robot.speed_m, self.heading[1] * robot.speed_m)


smartteams.register_strategy("py_walker", Walker)


def walkers(tmp_path, seed=1, rounds=80, strategy="py_walker"):
    return write_config(tmp_path, WALKERS.format(seed=seed, rounds=rounds, strategy=strategy), name=f"w{seed}.xml")


def test_a_python_strategy_runs_from_an_xml_config(tmp_path):
    assert ("py_walker", "written in Python (Walker)") in smartteams.strategies()
    sim = smartteams.Simulation(str(walkers(tmp_path)))
    sim.run()
    robots = sim.robots()
    assert (robots["distance_m"] > 10.0).all()
    assert robots["alive"].all()
    assert sim.metrics()["strategies_failed"][-1] == 0


def test_python_strategies_give_the_same_run_whatever_the_thread_count(tmp_path):
    config = str(walkers(tmp_path))
    digests = set()
    for threads in (1, 2, 2):
        sim = smartteams.Simulation(config, threads=threads)
        sim.run()
        digests.add((sim.digest, tuple(sim.metrics()["distance_m"].tolist())))
    assert len(digests) == 1
    other = smartteams.Simulation(str(walkers(tmp_path, seed=2)))
    other.run()
    assert other.digest not in {d for d, _ in digests}


class East:
    needs = []
    dx = 10.0

    def __init__(self, params):
        pass

    def decide(self, robot):
        return smartteams.Move(East.dx, 0.0)


def one_robot(tmp_path, name, strategy, rounds=2):
    """A run of one explorer from home with `strategy`, registered as `name`."""
    smartteams.register_strategy(name, strategy)
    config = write_config(
        tmp_path,
        f'<simulation seed="1" rounds="{rounds}"><map file="MAP"/>'
        f'<group count="1" type="explorer" strategy="{name}" start="home"/></simulation>',
    )
    return smartteams.Simulation(str(config))


def test_a_move_longer_than_the_speed_is_one_speed_long(tmp_path):
    sim = one_robot(tmp_path, "py_east", East)
    before = sim.robots()
    sim.run()
    after = sim.robots()
    # An explorer moves 1 m a round; home is clear, so two rounds take it 2 m east.
    assert after["x"][0] - before["x"][0] == pytest.approx(2.0, abs=1e-12)
    assert after["y"][0] == before["y"][0]


def test_a_move_too_long_to_square_is_one_speed_long(tmp_path):
    # 1e200 squared overflows a float; the move is still one speed long.
    East.dx = 1e200
    try:
        sim = one_robot(tmp_path, "py_far_east", East)
        before = sim.robots()
        sim.run()
    finally:
        East.dx = 10.0
    assert sim.robots()["x"][0] - before["x"][0] == pytest.approx(2.0, abs=1e-12)


class Talker:
    made = []

    def __init__(self, params):
        self.heard = []
        Talker.made.append(self)

    def decide(self, robot):
        self.heard.extend((m["from"], m["kind"], m["data"]) for m in robot.messages)
        return [smartteams.Idle(), smartteams.Broadcast("hello", bytes([robot.id, robot.round % 256]))]


def test_messages_sent_from_python_arrive_next_round(tmp_path):
    Talker.made.clear()
    smartteams.register_strategy("py_talker", Talker)
    config = write_config(
        tmp_path,
        '<simulation seed="1" rounds="3"><map file="MAP"/>'
        '<group count="3" type="explorer" strategy="py_talker" start="home"/></simulation>',
    )
    sim = smartteams.Simulation(str(config))
    sim.run()
    assert len(Talker.made) == 3
    # Robots stand at home within radio range: in rounds 2 and 3 each hears the other two's
    # messages of the round before.
    for me, talker in enumerate(Talker.made):
        expected = sorted((other, "hello", bytes([other, r])) for r in (1, 2) for other in range(3) if other != me)
        assert sorted(talker.heard) == expected
    assert sim.metrics()["messages"].tolist() == [3, 3, 3]


class Faulty:
    def __init__(self, params):
        pass

    def decide(self, robot):
        if robot.id == 2 and robot.round == 5:
            raise ValueError("boom at round 5")
        return smartteams.Idle()


def test_an_exception_in_decide_disables_that_robot_alone(tmp_path):
    smartteams.register_strategy("py_faulty", Faulty)
    config = write_config(
        tmp_path,
        '<simulation seed="1" rounds="10"><map file="MAP"/>'
        '<group count="4" type="explorer" strategy="py_faulty" start="home"/></simulation>',
    )
    sim = smartteams.Simulation(str(config))
    # The script hears of it without reading the event log.
    with pytest.warns(RuntimeWarning, match="round 5: robot 2 is disabled: its strategy failed") as heard:
        sim.run()
    assert len(heard) == 1
    assert sim.robots()["alive"].tolist() == [True, True, False, True]
    assert sim.metrics()["strategies_failed"].tolist() == [0] * 4 + [1] * 6
    events = [text for round_, text in sim.events() if round_ == 5]
    assert len(events) == 1
    assert events[0].startswith("robot 2 is disabled: its strategy failed: decide raised")
    assert "Traceback" in events[0] and "ValueError: boom at round 5" in events[0]


class Confused:
    def __init__(self, params):
        pass

    def decide(self, robot):
        return "north"


def why_disabled(tmp_path, name, strategy):
    """Run one robot of `strategy` (registered as `name`) for 2 rounds: the event that
    disabled it."""
    sim = one_robot(tmp_path, name, strategy)
    with pytest.warns(RuntimeWarning, match="robot 0 is disabled"):
        sim.run()
    (text,) = [t for _, t in sim.events() if "disabled" in t]
    return text


def test_a_wrong_return_value_disables_the_robot_with_a_clear_reason(tmp_path):
    text = why_disabled(tmp_path, "py_confused", Confused)
    assert "decide returned 'north'; expected an action" in text


class TupleMover:
    def __init__(self, params):
        pass

    def decide(self, robot):
        return (1.0, 0.0)


def test_a_tuple_of_numbers_is_named_whole_with_the_action_to_return(tmp_path):
    text = why_disabled(tmp_path, "py_tuple_mover", TupleMover)
    assert "decide returned (1.0, 0.0), whose item 1.0 is neither an action nor a message" in text
    assert "return smartteams.Move(dx, dy)" in text


class Unpicklable:
    def __init__(self, params):
        self.choose = lambda robot: smartteams.Idle()

    def decide(self, robot):
        return self.choose(robot)


def test_a_checkpoint_of_an_unpicklable_strategy_says_why(tmp_path):
    sim = one_robot(tmp_path, "py_unpicklable", Unpicklable, rounds=4)
    sim.step(2)
    with pytest.raises(smartteams.SmartTeamsError) as error:
        sim.checkpoint(str(tmp_path / "u.ckpt"))
    message = str(error.value)
    assert "strategy 'py_unpicklable' cannot save its state" in message
    assert "does not pickle" in message and "lambda" in message


class Keeper:
    kept = []

    def __init__(self, params):
        pass

    def decide(self, robot):
        Keeper.kept.append(robot)
        return smartteams.Idle()


def test_robot_methods_work_only_inside_decide(tmp_path):
    Keeper.kept.clear()
    one_robot(tmp_path, "py_keeper", Keeper, rounds=1).run()
    (robot,) = Keeper.kept
    assert robot.id == 0 and robot.round == 1
    with pytest.raises(smartteams.SmartTeamsError, match="only while"):
        robot.random()
    with pytest.raises(smartteams.SmartTeamsError, match="only while"):
        robot.broadcast("x", b"")


class Driver:
    """Steps the simulation it runs in from its own decide."""

    sim = None

    def __init__(self, params):
        pass

    def decide(self, robot):
        Driver.sim.step(1)
        return smartteams.Idle()


def test_a_strategy_that_steps_its_own_simulation_is_disabled_not_a_panic(tmp_path):
    sim = one_robot(tmp_path, "py_driver", Driver)
    Driver.sim = sim
    with pytest.warns(RuntimeWarning, match="robot 0 is disabled"):
        sim.run()
    Driver.sim = None
    (text,) = [t for _, t in sim.events() if "disabled" in t]
    assert "RuntimeError: Already borrowed" in text and "Panic" not in text, text
    # The simulation is whole: it played its rounds and reads as before.
    assert sim.round == 2 and sim.metrics()["round"].tolist() == [1, 2]


class GoalSetter:
    """Sets goals wrongly, then rightly."""

    errors = []

    def __init__(self, params):
        pass

    def decide(self, robot):
        for args in ((1.0,), (math.nan, 1.0), (math.inf, 6.0)):
            try:
                robot.set_goal(*args)
            except smartteams.SmartTeamsError as e:
                GoalSetter.errors.append(str(e))
        robot.set_goal(3.0, 4.0)
        return smartteams.Idle()


def test_a_goal_needs_two_finite_numbers(tmp_path):
    GoalSetter.errors = []
    sim = one_robot(tmp_path, "py_goal_setter", GoalSetter, rounds=1)
    sim.run()
    assert GoalSetter.errors == [
        "set_goal(x, y) takes two finite numbers, or none to clear the goal; got (1, None)",
        "set_goal(x, y) takes two finite numbers, or none to clear the goal; got (NaN, 1)",
        "set_goal(x, y) takes two finite numbers, or none to clear the goal; got (inf, 6)",
    ]


class Sleeper:
    def __init__(self, params):
        pass

    def decide(self, robot):
        time.sleep(0.15)
        return smartteams.Idle()


def test_a_slow_decision_is_warned_of_with_its_robot_and_round(tmp_path):
    sim = one_robot(tmp_path, "py_sleeper", Sleeper, rounds=2)
    with pytest.warns(RuntimeWarning) as caught:
        sim.run()
    texts = [str(w.message) for w in caught]
    assert len(texts) == 2, texts
    for round, text in zip((1, 2), texts):
        assert re.fullmatch(rf"round {round}: robot 0 took \d+ ms to decide, more than 100 ms", text), text


class StaleUser:
    """Keeps the robot of its first round and acts through it in the next."""

    kept = None
    errors = []

    def __init__(self, params):
        pass

    def decide(self, robot):
        if StaleUser.kept is None:
            StaleUser.kept = robot
        else:
            for act in (lambda r: r.set_goal(3.0, 3.0), lambda r: r.broadcast("x", b""), lambda r: r.random()):
                try:
                    act(StaleUser.kept)
                except smartteams.SmartTeamsError as e:
                    StaleUser.errors.append(str(e))
        return smartteams.Idle()


def test_a_robot_kept_from_an_earlier_round_does_not_act_in_a_later_one(tmp_path):
    StaleUser.kept, StaleUser.errors = None, []
    sim = one_robot(tmp_path, "py_stale_user", StaleUser, rounds=2)
    sim.run()
    assert len(StaleUser.errors) == 3, StaleUser.errors
    assert all("in the call that gave it" in e for e in StaleUser.errors)


def assert_resumes_as_whole(config, checkpoint, at):
    """`config` run whole, and checkpointed at round `at` into `checkpoint` and resumed,
    ends the same."""
    whole = smartteams.Simulation(config)
    whole.run()
    part = smartteams.Simulation(config)
    part.step(at)
    part.checkpoint(str(checkpoint))
    resumed = smartteams.Simulation.resume(str(checkpoint))
    resumed.run()
    assert resumed.digest == whole.digest


def test_a_run_with_python_strategies_checkpoints_and_resumes(tmp_path):
    assert_resumes_as_whole(str(walkers(tmp_path, rounds=60)), tmp_path / "w.ckpt", 25)


class ActionKeeper(Walker):
    """A walker that keeps its last actions, of every kind, in its state."""

    def decide(self, robot):
        move = super().decide(robot)
        self.last = [move, smartteams.MoveTo(1.0, 2.0), smartteams.Excavate(3), smartteams.Load(4)]
        self.last += [smartteams.Broadcast("k", b"\x00a"), smartteams.Send(1, "s", b"b"), smartteams.Idle()]
        return move


smartteams.register_strategy("py_action_keeper", ActionKeeper)


def test_a_strategy_that_keeps_actions_checkpoints_and_resumes(tmp_path):
    config = str(walkers(tmp_path, rounds=40, strategy="py_action_keeper"))
    assert_resumes_as_whole(config, tmp_path / "a.ckpt", 15)


def test_register_strategy_refuses_builtin_names_non_words_and_non_callables():
    with pytest.raises(smartteams.SmartTeamsError, match="built-in"):
        smartteams.register_strategy("frontier", Walker)
    with pytest.raises(smartteams.SmartTeamsError, match="not callable"):
        smartteams.register_strategy("py_bad", 3)
    for name in ("", "two words", "a/b"):
        with pytest.raises(smartteams.SmartTeamsError, match="a strategy's name is a word"):
            smartteams.register_strategy(name, Walker)


def test_the_readme_python_example_runs_its_strategy(tmp_path):
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("## Python"):]
    code = section[section.index("```python\n") + len("```python\n"):]
    code = code[: code.index("```")]
    # From the repository root, as README says, with the recording kept out of the tree.
    for folder in ("configs", "maps"):
        (tmp_path / folder).symlink_to(REPO / folder)
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    explored, walked = map(float, done.stdout.split())
    # Ten explorers (1 m a round) walk at most 3,000 m in 300 rounds; wanderers most of it.
    assert 1500 < walked <= 10 * 300 * 1.0 + 1e-6
    assert 0.05 < explored < 1
    assert (tmp_path / "wanderers.rrd").stat().st_size > 0
