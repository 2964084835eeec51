#!/usr/bin/env bash
# A/B timing of the moonshot's crowd: 10,000 robots crowded at home on the paper-scale map
# (the moonshot's first 20 rounds, with the same digest, on a map far quicker to set up),
# one thread.
# Runs the given `smartteams-bench` binaries alternately, RUNS times each, and prints the
# minimum and median of each step's time (perceive + decide, resolve, deliver, the rest) and
# their sum.
#
#   scripts/crowd-ab.sh RUNS OLD_BINARY NEW_BINARY [MORE...]
set -euo pipefail
if [ "$#" -lt 2 ]; then
    echo "usage: $0 RUNS BINARY [BINARY...]" >&2
    exit 2
fi
runs=$1
shift
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for _ in $(seq "$runs"); do
    for bin in "$@"; do
        line=$("$bin" --threads 1 swarm --robots 10000 --home-radius-m 30 --rounds 20 2>&1 | grep "time in the rounds")
        echo "$bin $(echo "$line" | grep -oE '[0-9.]+ s' | tr -d ' s' | tr '\n' ' ')" >>"$out"
    done
done
python3 - "$out" <<'PY'
import collections, statistics, sys
runs = collections.defaultdict(list)
for line in open(sys.argv[1]):
    fields = line.split()
    runs[fields[0]].append([float(x) for x in fields[1:5]])
for binary, rows in runs.items():
    cols = list(zip(*rows)) + [[sum(r) for r in rows]]
    names = ["perceive+decide", "resolve", "deliver", "other", "total"]
    print(binary, "  ".join(f"{n} {min(c):.3f}/{statistics.median(c):.3f}" for n, c in zip(names, cols)), "s (min/median)")
PY
