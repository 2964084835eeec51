#!/usr/bin/env bash
# The Rerun logging benchmark of BENCHMARKS.md: 1,000 robots for 200 rounds
# (configs/bench-1000.xml; CONFIG=configs/bench-10000.xml for 10,000 robots), `--no-viewer`
# against `--rrd`, alternating so that a machine's drift hits both alike. Prints each pair,
# then the medians and the median ratio.
# LIVE=1 streams the logged runs to a `rerun --save` receiver on this machine (`--connect`)
# instead of writing a file (the native rerun of SMARTTEAMS_RERUN_BIN, else of the venv that
# scripts/test.sh makes).
#   usage: bash scripts/bench-logging.sh [PAIRS] [extra smartteams run options for the logged runs]
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-5}
config=${CONFIG:-configs/bench-1000.xml}
shift || true
cargo build --profile ci -p viewer-bridge -p editor --bins --locked -q
bin=target/ci/smartteams
map=maps/bench-1km.stmap
if [ ! -f "$map" ]; then
    target/ci/smartteams-editor generate mesas --width-m 1024 --height-m 1024 --scale-m 32 \
        --density 0.2 --seed 11 --treasures 200 --quantity 1..5 -o "$map"
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The rounds' wall time from the run summary ("… in 12.34 s …").
secs() { sed -n 's/.* robots in \([0-9.]*\) s .*/\1/p'; }
live=${LIVE:-0}
if [ "$live" = 1 ]; then
    rerun=${SMARTTEAMS_RERUN_BIN:-$(target/rerun-venv/bin/python -c \
        "import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), 'rerun'))")}
    port=9877
fi
# One logged run: to a file, or live to a receiver started for it.
logged_run() {
    if [ "$live" = 1 ]; then
        rm -f "$out/bench.rrd"
        "$rerun" --port "$port" --save "$out/bench.rrd" >/dev/null 2>&1 &
        local receiver=$!
        sleep 2
        "$bin" run "$config" --connect="127.0.0.1:$port" "$@"
        sleep 1
        kill "$receiver"
        wait "$receiver" 2>/dev/null || true
    else
        "$bin" run "$config" --rrd "$out/bench.rrd" "$@"
    fi
}
plain=() logged=() worlds=0
for i in $(seq "$pairs"); do
    a=$("$bin" run "$config" --no-viewer | secs)
    summary=$(logged_run "$@")
    b=$(echo "$summary" | secs)
    plain+=("$a") logged+=("$b")
    worlds=$(echo "$summary" | sed -n 's/.*(\([0-9]*\) rounds of world state.*/\1/p')
    echo "pair $i: --no-viewer $a s, logged $b s ($(echo "$summary" | sed -n 's/.*; logging \(.*\))/logging \1/p'))"
done
size=$(stat -c %s "$out/bench.rrd")
python3 - "$size" "${plain[*]}" "${logged[*]}" "$worlds" <<'PY'
import statistics, sys
size = int(sys.argv[1])
worlds = int(sys.argv[4])
a = [float(x) for x in sys.argv[2].split()]
b = [float(x) for x in sys.argv[3].split()]
ratios = sorted(y / x for x, y in zip(a, b))
print(f"median --no-viewer {statistics.median(a):.2f} s, logged {statistics.median(b):.2f} s; "
      f"per-pair overhead {', '.join(f'{100 * (r - 1):+.0f} %' for r in ratios)}; "
      f"median {100 * (statistics.median(ratios) - 1):+.1f} %")
print(f".rrd {size / 1e6:.1f} MB, {size / worlds / 1e3:.0f} KB a logged round ({worlds} rounds)")
PY
