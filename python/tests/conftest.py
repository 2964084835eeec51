"""Shared set-up of the pytest suite: the repository's paths and the `smartteams` binary."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def repo():
    return REPO


@pytest.fixture(scope="module")
def smartteams_bin():
    """The command-line binary, built by `scripts/test.sh` (SMARTTEAMS_BIN names it)."""
    path = os.environ.get("SMARTTEAMS_BIN") or str(REPO / "target" / "ci" / "smartteams")
    if not os.path.exists(path):
        pytest.fail(f"the smartteams binary is missing at {path}: build it (cargo build --profile ci)")
    return path


def run_cli(binary, *args, cwd=None):
    out = subprocess.run([binary, *map(str, args)], capture_output=True, text=True, cwd=cwd)
    return out


@pytest.fixture
def demo_config(repo):
    return repo / "configs" / "demo.xml"


def write_config(tmp_path, body, name="run.xml", map_name="demo.stmap"):
    """A config in `tmp_path` whose <map> is the repository's `maps/<map_name>`."""
    path = tmp_path / name
    path.write_text(body.replace("MAP", str(REPO / "maps" / map_name)))
    return path


def need(kind, test, why):
    """Skip `test` for want of `kind`, noted in SMARTTEAMS_SKIP_LOG, or fail when
    SMARTTEAMS_REQUIRE requires it (as tests/src/skip.rs does for the Rust tests)."""
    required = [k.strip() for k in os.environ.get("SMARTTEAMS_REQUIRE", "").split(",")]
    if kind in required:
        pytest.fail(f"{test} cannot run: {why}; SMARTTEAMS_REQUIRE requires its {kind}")
    log = os.environ.get("SMARTTEAMS_SKIP_LOG")
    if log:
        with open(log, "a") as f:
            f.write(f"{kind}\t{test}\t{why}\n")
    pytest.skip(why)
