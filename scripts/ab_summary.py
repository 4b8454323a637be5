#!/usr/bin/env python3
"""Pairs the records scripts/ab-bench.sh's runs wrote (OXYGEN_AB=before|after).

    scripts/ab_summary.py RECORD_DIR

For every bench configuration (bench, arguments, environment but OXYGEN_AB)
and every measured row of it (a row of `values.rows`, named by its scalar
fields, or the record's top level), each `*_median` figure is collected per
side, one value a run; the table shows the median of each side's values and
after ÷ before. One record with all of it (both commits, the adapter, every
run's value) is appended to RECORD_DIR/ab_bench.jsonl. Exits 1 when the
records of one side are missing.
"""
import datetime
import json
import pathlib
import statistics
import sys

# Fields that measure, rather than name, a row.
MEASURES = ("_ms", "ms_", "_samples", "speed_up", "_kb", "kept_", "first_frame")


def identity(fields):
    return tuple(sorted((k, v) for k, v in fields.items()
                        if not isinstance(v, (list, dict)) and not any(m in k for m in MEASURES)))


def figures(values):
    """(row name, figure, value) for every *_median of a record's values."""
    out = []
    rows = values.get("rows")
    for row in rows if isinstance(rows, list) else [values]:
        name = ", ".join(f"{k}={v}" for k, v in identity(row))
        for k, v in row.items():
            if k.endswith("_median") and isinstance(v, (int, float)):
                out.append((name, k, float(v)))
    return out


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = pathlib.Path(sys.argv[1])
    runs = {}  # (bench, argv, env, row, figure) -> {"before": [...], "after": [...]}
    commits, adapters, hosts = {}, set(), []
    for path in sorted(folder.glob("*.jsonl")):
        if path.name == "ab_bench.jsonl":
            continue
        for line in path.read_text().splitlines():
            record = json.loads(line)
            env = dict(record["command"]["env"])
            label = env.pop("OXYGEN_AB", None)
            if label not in ("before", "after"):
                continue
            commits.setdefault(label, set()).add(record["commit"])
            adapters.add(json.dumps(record["adapter"], sort_keys=True))
            hosts.append(record["host"])
            config = (record["bench"], record["command"]["argv"], json.dumps(env, sort_keys=True))
            for row, figure, value in figures(record["values"]):
                runs.setdefault(config + (row, figure), {"before": [], "after": []})[label].append(value)
    if set(commits) != {"before", "after"}:
        print(f"ab_summary: records of both sides needed in {folder}; found {sorted(commits)}", file=sys.stderr)
        return 1
    if len(adapters) != 1 or any(len(c) != 1 for c in commits.values()):
        # One comparison is one adapter and one build a side.
        print(f"ab_summary: {folder} mixes adapters or builds: {sorted(adapters)}, {commits}", file=sys.stderr)
        return 1
    rows = []
    print("| bench | arguments | row | figure | before (median) | after (median) | after ÷ before | before's IQR ÷ median | runs |")
    print("|---|---|---|---|---:|---:|---:|---:|---:|")
    for (bench, argv, env, row, figure), sides in sorted(runs.items()):
        if not sides["before"] or not sides["after"]:
            continue
        b, a = statistics.median(sides["before"]), statistics.median(sides["after"])
        ratio = a / b if b else None
        # The old build's own run-to-run spread (interquartile range over its
        # median): a ratio whose distance from 1 is smaller is within noise.
        spread = None
        if len(sides["before"]) >= 4 and b:
            q = statistics.quantiles(sides["before"], n=4)
            spread = (q[2] - q[0]) / b
        rows.append({"bench": bench, "argv": argv, "env": json.loads(env), "row": row, "figure": figure,
                     "before": sides["before"], "after": sides["after"], "before_median": b,
                     "after_median": a, "ratio": ratio, "before_spread": spread,
                     "within_spread": None if spread is None or ratio is None else abs(ratio - 1) <= spread})
        shown = f"{ratio:.3f}" if ratio is not None else "—"
        spread_shown = f"{spread:.3f}" if spread is not None else "—"
        print(f"| {bench} | {argv.split(' ', 1)[-1]} | {row} | {figure} | {b:.4g} | {a:.4g} | {shown} "
              f"| {spread_shown} | {len(sides['before'])}+{len(sides['after'])} |")
    # The fields and order of docs/records/README.md; the commit is the
    # new build's, the old one's is in values.
    record = {
        "bench": "ab_bench",
        "commit": next(iter(commits["after"])),
        "dirty": None,
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "adapter": json.loads(next(iter(adapters))),
        "host": hosts[0],
        "command": {"argv": "ab-bench.sh BEFORE_DIR AFTER_DIR RECORD_DIR", "env": {}},
        "values": {"before_commit": next(iter(commits["before"])), "rows": rows},
    }
    with open(folder / "ab_bench.jsonl", "a") as f:
        f.write(json.dumps(record) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
