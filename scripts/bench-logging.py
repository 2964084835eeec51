#!/usr/bin/env python3
"""The Rerun logging benchmark (BENCHMARKS.md, "Rerun logging").

For each config (default: configs/bench-1000.xml and configs/bench-10000.xml) it runs, in
turn and PAIRS times, `smartteams run` headless (--no-viewer), to an .rrd file (--rrd) and
live (--connect) to a headless gRPC receiver, `rerun --serve-grpc`, that it starts on a free
port of 127.0.0.1 (and stops, by its process id, after each run, so every live run starts on
an empty receiver). A run that warns (a stream the receiver refused or cut) stops the
benchmark: its time would not include sending. It prints the
rounds/s of each (median, min-max), the ratios of the logged runs' wall time to the
headless one's (median of the pairs), the simulation thread's share of logging against the
headless round, and the recording's size.

    python3 scripts/bench-logging.py [--pairs 5] [--configs A.xml B.xml] [--smartteams BIN]

The rerun binary is SMARTTEAMS_RERUN_BIN, else the one of target/rerun-venv (scripts/test.sh
makes it), else `rerun` on PATH.
"""

import argparse
import os
import pathlib
import re
import shutil
import socket
import statistics
import subprocess
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]


def rerun_binary():
    if os.environ.get("SMARTTEAMS_RERUN_BIN"):
        return os.environ["SMARTTEAMS_RERUN_BIN"]
    python = REPO / "target" / "rerun-venv" / "bin" / "python"
    if python.exists():
        code = "import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), 'rerun'))"
        return subprocess.run([str(python), "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    found = shutil.which("rerun")
    if found:
        return found
    raise SystemExit(
        "bench-logging: no rerun binary: set SMARTTEAMS_RERUN_BIN, put `rerun` on PATH "
        "(pip install rerun-sdk==0.36.3) or run scripts/test.sh once (it makes target/rerun-venv)"
    )


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(binary, config, extra):
    done = subprocess.run([binary, "run", str(config), *extra], capture_output=True, text=True, check=True)
    if "warning" in done.stderr:
        raise SystemExit(f"bench-logging: {' '.join(extra)}: {done.stderr.strip()}")
    out = done.stdout
    m = re.search(r"(\d+) rounds with \d+ robots in ([0-9.]+) s", out)
    rounds, secs = int(m.group(1)), float(m.group(2))
    sim = re.search(r"logging ([0-9.]+) s on the simulation thread", out)
    return rounds, secs, float(sim.group(1)) if sim else 0.0


def live_run(binary, rerun, config):
    port = free_port()
    server = subprocess.Popen(
        # `rerun server` is a data server: it refuses a stream (the SDK then drops the data).
        [rerun, "--serve-grpc", "--bind", "127.0.0.1", "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                if server.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"rerun --serve-grpc did not start on port {port}")
                time.sleep(0.05)
        return run(binary, config, [f"--connect=127.0.0.1:{port}"])
    finally:
        server.terminate()
        server.wait()


def summary(values):
    return f"{statistics.median(values):.1f} ({min(values):.1f}-{max(values):.1f})"


def bench(binary, rerun, config, pairs):
    headless, rrd, live, sim_share = [], [], [], []
    ratios_rrd, ratios_live = [], []
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "bench.rrd"
        for _ in range(pairs):
            rounds, h, _ = run(binary, config, ["--no-viewer"])
            _, r, sim = run(binary, config, ["--rrd", str(path)])
            _, lv, _ = live_run(binary, rerun, config)
            headless.append(rounds / h)
            rrd.append(rounds / r)
            live.append(rounds / lv)
            ratios_rrd.append(r / h)
            ratios_live.append(lv / h)
            sim_share.append(sim / h)
        size = path.stat().st_size
    name = pathlib.Path(config).name
    print(f"{name}, {pairs} alternated runs each (rounds/s):")
    print(f"  headless {summary(headless)} | --rrd {summary(rrd)} | --connect {summary(live)}")
    print(
        f"  logged / headless time: --rrd {statistics.median(ratios_rrd):.2f} ({min(ratios_rrd):.2f}-{max(ratios_rrd):.2f}), "
        f"--connect {statistics.median(ratios_live):.2f} ({min(ratios_live):.2f}-{max(ratios_live):.2f}); "
        f"simulation thread's logging {100 * statistics.median(sim_share):.0f} % of the headless time; "
        f".rrd {size / 1e6:.1f} MB"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pairs", type=int, default=5)
    parser.add_argument("--configs", nargs="+", default=[REPO / "configs/bench-1000.xml", REPO / "configs/bench-10000.xml"])
    parser.add_argument("--smartteams", default=str(REPO / "target" / "ci" / "smartteams"))
    args = parser.parse_args()
    rerun = rerun_binary()
    for config in args.configs:
        bench(args.smartteams, rerun, config, args.pairs)


if __name__ == "__main__":
    main()
