#!/usr/bin/env bash
# The speed-up from 1 to 2 threads of a `smartteams-bench` scenario, from processes run
# alternately, PAIRS pairs: each pair's robot-rounds/s and ratio, then the medians, min and
# max, and the ratio of the fastest runs. Separate processes, because a 1-thread and a
# 2-thread simulation played in turn in one process slow the 2-thread one (BENCHMARKS.md,
# "Scaling"). Pairs alternate their order (1 then 2 threads, then 2 then 1): on this VM the
# second run of a pair tends to be the slower. A slow spell only slows runs down, so the
# fastest run of each is the least disturbed.
# The digests of each pair must agree, or the script fails.
#
#   scripts/bench-threads.sh PAIRS SCENARIO [ARGS...]
#   scripts/bench-threads.sh 9 random-walk --rounds 1000
#   scripts/bench-threads.sh 5 swarm --robots 10000 --mesas 50000 --home-radius-m 30 --rounds 300
#   scripts/bench-threads.sh 7 --rounds 200 config configs/bench-1000.xml
#
# The binary is target/ci/smartteams-bench, or SMARTTEAMS_BENCH.
set -euo pipefail
if [ "$#" -lt 2 ]; then
    echo "usage: $0 PAIRS SCENARIO [ARGS...]" >&2
    exit 2
fi
pairs=$1
shift
bench=${SMARTTEAMS_BENCH:-$(dirname "$0")/../target/ci/smartteams-bench}
if [ ! -x "$bench" ]; then
    echo "$0: no $bench: cargo build --profile ci -p scale (or set SMARTTEAMS_BENCH)" >&2
    exit 2
fi
out=$(mktemp)
trap 'rm -f "$out"' EXIT
# One run: its robot-rounds/s (four significant digits, where rounds/s has one decimal: a
# slow scenario's 12.0 rounds/s would round the ratio by up to 1 %) and digest from the
# summary line.
run() {
    local line
    line=$("$bench" --threads "$1" "${@:2}" 2>&1 | grep -E ' robot-rounds/s.*digest ' | tail -1) || {
        echo "$0: no summary line from: $bench --threads $1 ${*:2}" >&2
        exit 1
    }
    echo "$(echo "$line" | grep -oE '[0-9.e+]+ robot-rounds/s' | head -1 | cut -d' ' -f1) $(echo "$line" | grep -oE 'digest [0-9a-f]+' | cut -d' ' -f2)"
}
for k in $(seq "$pairs"); do
    if ((k % 2)); then
        read -r one d1 <<<"$(run 1 "$@")"
        read -r two d2 <<<"$(run 2 "$@")"
    else
        read -r two d2 <<<"$(run 2 "$@")"
        read -r one d1 <<<"$(run 1 "$@")"
    fi
    if [ -z "$one" ] || [ -z "$two" ] || [ -z "$d1" ]; then
        echo "$0: $bench ${*}: no rounds/s and digest in its summary (a scenario that plays rounds?)" >&2
        exit 1
    fi
    if [ "$d1" != "$d2" ]; then
        echo "$0: pair $k: digests differ between 1 and 2 threads ($d1, $d2)" >&2
        exit 1
    fi
    echo "$one $two" >>"$out"
    echo "pair $k: 1 thread $one robot-rounds/s, 2 threads $two, $(python3 -c "print(f'{$two / $one:.3f}')")x"
done
python3 - "$out" <<'PY'
import statistics, sys
pairs = [tuple(map(float, line.split())) for line in open(sys.argv[1])]
ratios = [b / a for a, b in pairs]
def summary(v):
    return f"{statistics.median(v):.3f} ({min(v):.3f}-{max(v):.3f})"
def rate(v):
    return f"{statistics.median(v):.4g} ({min(v):.4g}-{max(v):.4g})"
print(f"1 thread {rate([a for a, _ in pairs])} robot-rounds/s, 2 threads {rate([b for _, b in pairs])}")
print(f"1 -> 2 threads: {summary(ratios)}x, median of {len(pairs)} pairs; identical digests")
print(f"fastest runs: {max(b for _, b in pairs) / max(a for a, _ in pairs):.3f}x")
PY
