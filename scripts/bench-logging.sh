#!/usr/bin/env bash
# The Rerun logging benchmark of BENCHMARKS.md: 1,000 robots for 200 rounds
# (configs/bench-1000.xml; CONFIG=configs/bench-10000.xml for 10,000 robots), `--no-viewer` against `--rrd`, alternating so that a machine's
# drift hits both alike. Prints each pair, then the medians and the median ratio.
#   usage: bash scripts/bench-logging.sh [PAIRS] [extra smartteams run options for the --rrd runs]
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
plain=() logged=()
for i in $(seq "$pairs"); do
    a=$("$bin" run "$config" --no-viewer | secs)
    summary=$("$bin" run "$config" --rrd "$out/bench.rrd" "$@")
    b=$(echo "$summary" | secs)
    plain+=("$a") logged+=("$b")
    echo "pair $i: --no-viewer $a s, --rrd $b s ($(echo "$summary" | sed -n 's/.*; logging \(.*\))/logging \1/p'))"
done
size=$(stat -c %s "$out/bench.rrd")
python3 - "$size" "${plain[*]}" "${logged[*]}" <<'PY'
import statistics, sys
size = int(sys.argv[1])
a = [float(x) for x in sys.argv[2].split()]
b = [float(x) for x in sys.argv[3].split()]
ratios = sorted(y / x for x, y in zip(a, b))
print(f"median --no-viewer {statistics.median(a):.2f} s, --rrd {statistics.median(b):.2f} s; "
      f"per-pair overhead {', '.join(f'{100 * (r - 1):+.0f} %' for r in ratios)}; "
      f"median {100 * (statistics.median(ratios) - 1):+.1f} %")
print(f".rrd {size / 1e6:.1f} MB, {size / 201 / 1e3:.0f} KB a logged round (201 rounds)")
PY
