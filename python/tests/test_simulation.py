"""The simulation from Python: the same results as the command line, state as arrays,
checkpoints, errors."""

import csv
import os
import subprocess
import sys

import numpy as np
import pytest
import smartteams

from conftest import REPO, need, run_cli, write_config


def read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return header, {name: [r[i] for r in body] for i, name in enumerate(header)}


def test_metrics_are_the_cli_csv(tmp_path, smartteams_bin, demo_config):
    out = run_cli(
        smartteams_bin, "run", demo_config, "--seed", "3", "--rounds", "120", "--no-viewer", "-q",
        "--metrics", tmp_path / "m.csv",
    )
    assert out.returncode == 0, out.stderr
    header, columns = read_csv_columns(tmp_path / "m.csv")

    sim = smartteams.Simulation(str(demo_config), seed=3, rounds=120)
    assert sim.run() == 120 and sim.done and sim.round == 120
    metrics = sim.metrics()
    assert list(metrics) == header
    for name in header:
        values = metrics[name]
        assert values.shape == (120,), name
        # Integer columns are integers, the others the CSV's numbers exactly.
        expected = [int(v) if values.dtype.kind == "i" else float(v) for v in columns[name]]
        assert values.tolist() == expected, name


def test_robots_and_treasures_are_arrays_in_id_order(demo_config):
    sim = smartteams.Simulation(str(demo_config), rounds=40)
    sim.step(40)
    robots = sim.robots()
    for key in ["id", "x", "y", "energy", "load", "alive", "known_area_m2"]:
        assert robots[key].shape == (20,), key
    assert robots["id"].tolist() == list(range(20))
    assert robots["alive"].dtype == np.bool_
    # The demo's groups: 12 scouts, 4 diggers, 4 haulers, in that order.
    assert [sim.group_names[g] for g in robots["group"]] == ["scouts"] * 12 + ["diggers"] * 4 + ["haulers"] * 4
    # Every robot knows at least its view disc's area (explorers 6 m, the others 3 m).
    assert (robots["known_area_m2"] > 0.8 * np.pi * 3.0**2).all()
    treasures = sim.treasures()
    assert set(treasures) >= {"id", "x", "y", "quantity"}
    assert (treasures["quantity"] >= treasures["buried"]).all()
    # The summary digest is the CLI's for the same run.
    assert len(sim.digest) == 16


def test_known_map_and_obstacles_agree_with_the_map(demo_config):
    sim = smartteams.Simulation(str(demo_config), rounds=30)
    sim.step(30)
    cell_m, x0, y0, width_m, height_m = sim.map_extent
    obstacles = sim.obstacles()
    assert obstacles.shape == (round(height_m / cell_m), round(width_m / cell_m))
    assert set(np.unique(obstacles)) <= {0, 1}
    known = sim.known_map(0)
    assert known.shape == obstacles.shape
    # A robot knows a cell blocked exactly where the map is blocked, among the cells it knows.
    seen = known > 0
    assert seen.any() and not seen.all()
    assert ((known == 2) == ((obstacles == 1) & seen)).all()
    # Robot 0's known area is the number of cells it knows.
    area = sim.robots()["known_area_m2"][0]
    assert seen.sum() * cell_m * cell_m == pytest.approx(area)
    # A window is the same cells as the whole map's, cut out (row 0 is the southern row).
    window = sim.known_map(0, x0 + 10 * cell_m, y0 + 20 * cell_m, 8 * cell_m, 5 * cell_m)
    assert (window == known[20:25, 10:18]).all()


def test_checkpoint_and_resume_give_the_uninterrupted_run(tmp_path, demo_config):
    whole = smartteams.Simulation(str(demo_config), seed=5, rounds=80)
    whole.run()
    part = smartteams.Simulation(str(demo_config), seed=5, rounds=80)
    part.step(35)
    part.checkpoint(str(tmp_path / "run.ckpt"))
    del part
    resumed = smartteams.Simulation.resume(str(tmp_path / "run.ckpt"))
    assert resumed.round == 35
    resumed.run()
    assert resumed.digest == whole.digest
    for name, values in whole.metrics().items():
        assert resumed.metrics()[name].tolist() == values.tolist(), name


def test_python_checkpoint_resumes_with_the_cli(tmp_path, smartteams_bin, demo_config):
    sim = smartteams.Simulation(str(demo_config), seed=2, rounds=60)
    sim.step(20)
    sim.checkpoint(str(tmp_path / "py.ckpt"))
    out = run_cli(smartteams_bin, "resume", tmp_path / "py.ckpt", "--no-viewer", "--metrics", tmp_path / "r.csv")
    assert out.returncode == 0, out.stderr
    sim.run()
    digest = [l.split()[1] for l in out.stdout.splitlines() if l.strip().startswith("digest")]
    assert digest == [sim.digest]


def test_the_cli_resumes_a_python_run_writing_what_it_wrote(tmp_path, smartteams_bin):
    # The demo in a folder of its own, so that its <outputs> (which a Python run does not
    # write) would show there.
    cfg, work = tmp_path / "cfg", tmp_path / "work"
    cfg.mkdir()
    work.mkdir()
    config = cfg / "demo.xml"
    config.write_text((REPO / "configs" / "demo.xml").read_text().replace('"../maps/', f'"{REPO / "maps"}/'))
    with smartteams.Simulation(str(config), rounds=20, rrd=str(work / "py.rrd")) as sim:
        sim.step(5)
        sim.checkpoint(str(work / "py.ckpt"))
    out = run_cli(smartteams_bin, "resume", "py.ckpt", cwd=work)
    assert out.returncode == 0, out.stderr
    assert sorted(p.name for p in cfg.iterdir()) == ["demo.xml"]
    assert (work / "py-from-5.rrd").stat().st_size > 0


def test_same_results_on_one_and_two_threads(demo_config):
    runs = []
    for threads in (1, 2):
        sim = smartteams.Simulation(str(demo_config), seed=9, rounds=60, threads=threads)
        sim.run()
        runs.append((sim.digest, sim.metrics()["explored_fraction"].tolist()))
    assert runs[0] == runs[1]


def test_bad_configs_raise_with_file_line_and_column(tmp_path, smartteams_bin):
    missing = tmp_path / "nope.xml"
    with pytest.raises(smartteams.SmartTeamsError, match="nope.xml"):
        smartteams.Simulation(str(missing))
    bad = write_config(
        tmp_path,
        '<simulation rounds="5">\n  <map file="MAP"/>\n  <group count="2" type="explorer" strategy="no_such"/>\n</simulation>\n',
        name="bad.xml",
    )
    with pytest.raises(smartteams.SmartTeamsError) as caught:
        smartteams.Simulation(str(bad))
    message = str(caught.value)
    assert "bad.xml:3:3" in message and "no_such" in message
    # The command line says the same.
    out = run_cli(smartteams_bin, "run", bad, "--no-viewer", "-q")
    # (The list of known strategies that follows also names the Python ones registered.)
    assert out.returncode != 0 and message.split(" (known:")[0] in out.stderr
    with pytest.raises(smartteams.SmartTeamsError, match="threads"):
        smartteams.Simulation(str(REPO / "configs" / "demo.xml"), threads=0)


def test_bad_arguments_raise_saying_what_is_allowed(demo_config):
    sim = smartteams.Simulation(str(demo_config), rounds=3)
    with pytest.raises(smartteams.SmartTeamsError, match="rounds to play, ≥ 0; got -1"):
        sim.step(-1)
    # The demo has 20 robots.
    for robot in (-1, 20):
        with pytest.raises(smartteams.SmartTeamsError, match=f"no robot {robot}: the run has 20 robots, ids 0 to 19"):
            sim.known_map(robot)
    assert sim.round == 0
    # Counts and seeds out of range raise SmartTeamsError naming them, not OverflowError.
    for kwargs, said in [
        ({"rounds": -1}, "rounds must not be negative, got -1"),
        ({"seed": -5}, "seed must not be negative, got -5"),
        ({"seed": 2**64}, f"seed {2**64} is too large"),
        ({"threads": -2}, "threads must not be negative, got -2"),
    ]:
        with pytest.raises(smartteams.SmartTeamsError, match=said):
            smartteams.Simulation(str(demo_config), **kwargs)


def test_a_recording_that_cannot_be_written_raises_with_the_reason(tmp_path, demo_config):
    # In a child Python whose files are capped at 2 MB (SIGXFSZ ignored): a write past the cap
    # fails with "File too large", as one to a full disk fails with "No space left on device".
    script = """
import resource, signal, sys, smartteams
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (2_000_000, resource.RLIM_INFINITY))
sim = smartteams.Simulation(sys.argv[1], rounds=100_000, rrd=sys.argv[2])
try:
    sim.run()
except smartteams.SmartTeamsError as e:
    print(sim.round, e)
"""
    rrd = tmp_path / "capped.rrd"
    out = subprocess.run(
        [sys.executable, "-c", script, str(demo_config), str(rrd)], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    round_reached, said = out.stdout.split(" ", 1)
    assert 0 < int(round_reached) < 100_000
    assert f"cannot write the recording {rrd}: File too large" in said, said


def test_recording_verifies_with_the_rerun_cli(tmp_path, demo_config):
    rrd = tmp_path / "demo.rrd"
    with smartteams.Simulation(str(demo_config), rounds=25, rrd=str(rrd)) as sim:
        sim.run()
    assert rrd.stat().st_size > 0
    binary = os.environ.get("SMARTTEAMS_RERUN_BIN")
    if not binary:
        need("rerun", "test_recording_verifies_with_the_rerun_cli", "SMARTTEAMS_RERUN_BIN is unset")
    verify = subprocess.run([binary, "rrd", "verify", str(rrd)], capture_output=True, text=True)
    assert verify.returncode == 0, verify.stdout + verify.stderr
