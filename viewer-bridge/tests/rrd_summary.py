"""Summarise an .rrd with the official Rerun SDK (rerun-sdk 0.36.3), as JSON on stdout.

Used by viewer-bridge/tests/rerun_rrd.rs. Output:
  rows:    {"<entity>|<static 0/1>": rows}
  rounds:  {"<entity>": sorted rounds with a row}        (temporal chunks only)
  scalars: {"<entity>": {"<round>": value}}             (entities with a Scalars column)
  instances: {"<entity>": {"<round>": instances}}      (world/robots, world/treasures)
  robots:  {"round": last round, "<column>": values}    (/world/robots detail columns and
                                                        2D positions at its last round,
                                                        each at its latest value)
  owners:  {"<entity>": sorted distinct `robot` values}  (entities with a `robot` column)
  robot_column_rows: {"<column>": rows of /world/robots that log it}
  images:  {"<entity>": {"format": the Image format struct, "buffer": [bytes]}}
                                                       (static images, their last row)
"""

import json
import sys
from collections import defaultdict

from rerun.experimental import RrdReader


def main(path: str) -> None:
    rows: dict[str, int] = defaultdict(int)
    rounds: dict[str, set[int]] = defaultdict(set)
    scalars: dict[str, dict[str, float]] = defaultdict(dict)
    instances: dict[str, dict[str, int]] = defaultdict(dict)
    robots: dict = {"round": -1}
    owners: dict[str, set[int]] = defaultdict(set)
    latest: dict[str, tuple[int, object]] = {}
    logged_rows: dict[str, int] = defaultdict(int)
    images: dict[str, dict] = {}
    for chunk in RrdReader(path).stream():
        entity = str(chunk.entity_path)
        static = bool(chunk.is_static)
        rows[f"{entity}|{int(static)}"] += chunk.num_rows
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if static:
            buffers = [n for n in names if n.endswith("Image:buffer")]
            formats = [n for n in names if n.endswith("Image:format")]
            if buffers and formats:
                buffer = batch.column(names.index(buffers[0])).to_pylist()[-1]
                fmt = batch.column(names.index(formats[0])).to_pylist()[-1]
                images[entity] = {"format": fmt[0] if isinstance(fmt, list) else fmt,
                                  "buffer": list(buffer[0] if buffer and isinstance(buffer[0], (bytes, list)) else buffer)}
            continue
        if "round" not in names:
            continue
        rs = batch.column(names.index("round")).to_pylist()
        rounds[entity].update(int(r) for r in rs)
        scalar_cols = [n for n in names if n.endswith(":scalars")]
        if scalar_cols:
            values = batch.column(names.index(scalar_cols[0])).to_pylist()
            for r, v in zip(rs, values):
                if v:
                    scalars[entity][str(r)] = float(v[0])
        pos_cols = [n for n in names if n.endswith(":positions")]
        if pos_cols:
            values = batch.column(names.index(pos_cols[0])).to_pylist()
            for r, v in zip(rs, values):
                instances[entity][str(r)] = len(v or [])
        if "robot" in names:
            for v in batch.column(names.index("robot")).to_pylist():
                owners[entity].update(int(x) for x in (v or []))
        if entity == "/world/robots":
            # Latest-at, as the viewer shows it: columns that did not change are not re-logged.
            for name in names:
                if name in ("rerun.controls.RowId", "round"):
                    continue
                for r, v in zip(rs, batch.column(names.index(name)).to_pylist()):
                    logged_rows[name] += v is not None
                    if v is not None and r >= latest.get(name, (-1, None))[0]:
                        latest[name] = (int(r), v)
                robots["round"] = max(robots["round"], max(int(r) for r in rs))
    robots.update({name: v for name, (_, v) in latest.items()})
    json.dump(
        {
            "rows": rows,
            "rounds": {e: sorted(r) for e, r in rounds.items()},
            "scalars": scalars,
            "instances": instances,
            "robots": robots,
            "owners": {e: sorted(o) for e, o in owners.items()},
            "robot_column_rows": logged_rows,
            "images": images,
        },
        sys.stdout,
    )


if __name__ == "__main__":
    main(sys.argv[1])
