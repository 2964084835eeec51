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
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy (ci profile, all targets, -D warnings)"
cargo clippy --profile ci --workspace --all-targets --locked -- -D warnings
echo "== cargo test (ci profile)"
cargo test --profile ci --workspace --locked
