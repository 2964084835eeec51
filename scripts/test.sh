#!/usr/bin/env bash
# The project's test command (README.md, .ci/run): format, lints, then every test, all in
# the one `ci` cargo profile so CI compiles the workspace once.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${SMARTTEAMS_DATA:-}" ] && [ -d ../shared/data ]; then
  # Opt-in tests on external maps (see ../shared/data/README.md); they skip when unset.
  SMARTTEAMS_DATA="$(cd ../shared/data && pwd)"
  export SMARTTEAMS_DATA
fi
if [ -z "${SMARTTEAMS_RERUN_PYTHON:-}" ]; then
  # The Rerun tests read recordings back with the official SDK and its `rerun` binary, pinned
  # to the crate's version; the venv lives under target/ so `cargo clean` removes it.
  venv=target/rerun-venv
  if ! "$venv/bin/python" -c 'import rerun, sys; sys.exit(rerun.__version__ != "0.36.3")' 2>/dev/null; then
    echo "== rerun-sdk 0.36.3 venv ($venv)"
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check rerun-sdk==0.36.3
  fi
  SMARTTEAMS_RERUN_PYTHON="$(pwd)/$venv/bin/python"
  # The native viewer binary, not the venv's `rerun` script: that script runs the binary as a
  # child, so tests that kill or pause "the viewer" would only hit the script.
  SMARTTEAMS_RERUN_BIN="$("$venv/bin/python" -c 'import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), "rerun"))')"
  export SMARTTEAMS_RERUN_PYTHON SMARTTEAMS_RERUN_BIN
fi
echo "SMARTTEAMS_RERUN_PYTHON=$SMARTTEAMS_RERUN_PYTHON"
# What this script set up must be used: a test that would skip for want of it fails instead
# (tests/src/skip.rs). Other skips are noted in the log and listed at the end.
require=rerun
if [ -n "${SMARTTEAMS_DATA:-}" ]; then require="$require,data"; fi
mkdir -p target
# A one-node Slurm for the cluster tests (viewer-bridge/tests/slurm.rs), stopped at the end;
# only where it cannot be installed (no root or apt-get) do they skip, and say so.
slurm_started=
if [ -z "${SLURM_CONF:-}" ]; then
  if bash scripts/slurm-local.sh start; then
    eval "$(bash scripts/slurm-local.sh env)"
    slurm_started=1
    require="$require,slurm"
  else
    status=$?
    if [ "$status" -ne 3 ]; then
      echo "scripts/slurm-local.sh start failed ($status); see target/slurm/*.log" >&2
      exit "$status"
    fi
    echo "note: Slurm cannot be installed here: the cluster tests will skip"
  fi
else
  require="$require,slurm"
fi
export SMARTTEAMS_REQUIRE="${SMARTTEAMS_REQUIRE:-$require}"
export SMARTTEAMS_SKIP_LOG="$(pwd)/target/test-skips.log"
: > "$SMARTTEAMS_SKIP_LOG"
finish() {
  local n
  if [ -n "$slurm_started" ]; then bash scripts/slurm-local.sh stop; fi
  n=$(wc -l < "$SMARTTEAMS_SKIP_LOG")
  echo "== skipped tests: $n (required to run: $SMARTTEAMS_REQUIRE)"
  if [ "$n" -gt 0 ]; then sed 's/^/   /' "$SMARTTEAMS_SKIP_LOG"; fi
}
trap finish EXIT
echo "SMARTTEAMS_REQUIRE=$SMARTTEAMS_REQUIRE"
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy (ci profile, all targets, -D warnings)"
cargo clippy --profile ci --workspace --all-targets --locked -- -D warnings
echo "== cargo doc (ci profile, no dependencies, warnings are errors: every link resolves)"
RUSTDOCFLAGS="-D warnings" cargo doc --profile ci --workspace --no-deps --locked
echo "== cargo test (ci profile)"
cargo test --profile ci --workspace --locked
echo "== Python package: pip install ./python into target/python-venv, then its pytest suite"
pyvenv=target/python-venv
if ! "$pyvenv/bin/python" -c 'import numpy, pytest, gymnasium, pettingzoo, matplotlib' 2>/dev/null; then
  python3 -m venv "$pyvenv"
  "$pyvenv/bin/pip" install --quiet --disable-pip-version-check numpy pytest gymnasium pettingzoo matplotlib
fi
# Built as a user builds it (pip and maturin from pyproject.toml), in the `ci` profile so that
# it reuses the workspace build above.
MATURIN_PEP517_ARGS="--profile ci" "$pyvenv/bin/pip" install --quiet --disable-pip-version-check \
  --force-reinstall --no-deps ./python
SMARTTEAMS_BIN="$(pwd)/target/ci/smartteams" "$pyvenv/bin/python" -m pytest -q python/tests
