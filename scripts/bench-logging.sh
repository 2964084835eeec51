#!/usr/bin/env bash
# The Rerun logging benchmark of BENCHMARKS.md: builds the `ci` binaries, then runs
# scripts/bench-logging.py (headless, --rrd and live to its own `rerun --serve-grpc` receiver, alternated).
#   usage: bash scripts/bench-logging.sh [--pairs N] [--configs A.xml ...]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --profile ci -p viewer-bridge --bin smartteams --locked -q
exec python3 scripts/bench-logging.py "$@"
