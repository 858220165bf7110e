#!/usr/bin/env python3
"""Backends side by side from `portaslam bench --json` runs: issue 16's table, medians over runs.

Every row of every run (resolution, levels, mode, frames in flight, input) is one cell of the table;
a backend's figure in a cell is the median over the runs that have it of the bench's median µs per
frame one frame at a time, and of its mean with frames in flight (the throughput: results of
merged batches come back together). Ratios are of those medians. Prints Markdown to stdout: the
table, then one line per target saying in how many cells it holds and where it does not. Standard
library only (the GPU machine has no extra Python packages).

    usage: bench/backend_table.py [--reference cuda] [--within BACKEND=RATIO ...]
                                  [--faster-than cpu] RUN.json [RUN.json ...]

--within vulkan=1.5: vulkan's figure at most 1.5 times the reference's (bold in the table).
--faster-than cpu: every other backend but the reference below cpu's figure, where cpu ran.
Exit status 0 with a table (whether the targets hold or not), 2 on bad input (named).
"""
import argparse
import json
import statistics
import sys
from pathlib import Path

ORDER = ["cpu", "cuda", "vulkan", "opencl"]
MODES = {"stereo": 0, "extract": 1, "detect": 2}  # the order within a size


class BadInput(Exception):
    pass


def read_run(path):
    """The rows of one bench JSON: {(cell key): {backend: µs}}."""
    try:
        data = json.loads(Path(path).read_text())
    except OSError as e:
        raise BadInput(f"{path}: cannot read it ({e.strerror})") from e
    except ValueError as e:
        raise BadInput(f"{path}: not a portaslam bench JSON ({type(e).__name__}: {e})") from e
    results = data.get("results") if isinstance(data, dict) else None
    if not isinstance(results, list):
        raise BadInput(f"{path}: not a portaslam bench JSON (no 'results' list)")
    cells = {}
    for i, r in enumerate(results):
        try:
            key = (int(r["width"]), int(r["height"]), int(r["levels"]), str(r["mode"]), int(r["in_flight"]),
                   str(r["input"]))
            value = float(r["median_us"] if key[4] == 1 else r["mean_us"])
            backend = str(r["backend"])
        except (KeyError, TypeError, ValueError) as e:
            raise BadInput(f"{path}: result {i} lacks a field of a bench row ({type(e).__name__}: {e})") from e
        cells.setdefault(key, {})[backend] = value
    return cells


def cell_name(key):
    width, height, levels, mode, in_flight, source = key
    name = f"{width}x{height}/{levels} {mode}"
    if in_flight > 1:
        name += f" /{in_flight}"
    if source == "pinned":
        name += "+pin"
    return name


def figure(values):
    mid = statistics.median(values)
    if len(values) == 1:
        return f"{mid:.0f}"
    return f"{mid:.0f} ({min(values):.0f}-{max(values):.0f})"


def parse_within(items):
    limits = {}
    for item in items:
        backend, sep, ratio = item.partition("=")
        try:
            value = float(ratio)
        except ValueError:
            value = -1.0
        if not sep or not backend or value <= 0:
            raise BadInput(f"--within '{item}': expected BACKEND=RATIO with a positive ratio, e.g. vulkan=1.5")
        limits[backend] = value
    return limits


def table(runs, reference, limits, faster_than):
    merged = {}  # key -> backend -> [µs per run]
    for cells in runs:
        for key, backends in cells.items():
            for backend, value in backends.items():
                merged.setdefault(key, {}).setdefault(backend, []).append(value)
    present = {b for backends in merged.values() for b in backends}
    columns = [b for b in ORDER if b in present] + sorted(present - set(ORDER))
    others = [b for b in columns if b != reference]
    ratio_columns = [(b, reference) for b in others if b != faster_than]
    if faster_than in present:
        ratio_columns += [(b, faster_than) for b in others if b not in (faster_than, reference)]
    lines = ["| cell | runs | " + " | ".join(columns) + " | " +
             " | ".join(f"{a} / {b}" for a, b in ratio_columns) + " |",
             "|" + "---|" * (2 + len(columns) + len(ratio_columns))]
    held = {target: [0, []] for target in list(limits) + ([faster_than] if faster_than in present else [])}
    for key in sorted(merged, key=lambda k: (-k[0] * k[1], -k[2], MODES.get(k[3], 3), k[3], k[4], k[5])):
        backends = merged[key]
        mid = {b: statistics.median(v) for b, v in backends.items()}
        runs_here = max(len(v) for v in backends.values())
        row = [cell_name(key), str(runs_here)] + [figure(backends[b]) if b in backends else "" for b in columns]
        for a, b in ratio_columns:
            if a not in mid or b not in mid or mid[b] <= 0:
                row.append("")
                continue
            ratio = mid[a] / mid[b]
            ok = ratio <= limits[a] if b == reference and a in limits else ratio < 1.0 if b == faster_than else None
            row.append(f"**{ratio:.2f}x**" if ok else f"{ratio:.2f}x")
        lines.append("| " + " | ".join(row) + " |")
        if reference in mid:
            for backend, limit in limits.items():
                if backend in mid:
                    held[backend][0] += 1
                    if mid[backend] / mid[reference] > limit:
                        held[backend][1].append(f"{cell_name(key)} {mid[backend] / mid[reference]:.2f}x")
        if faster_than in mid:
            slower = [f"{b} {mid[b] / mid[faster_than]:.2f}x" for b in others
                      if b not in (faster_than, reference) and b in mid and mid[b] >= mid[faster_than]]
            held[faster_than][0] += 1
            if slower:
                held[faster_than][1].append(f"{cell_name(key)} ({', '.join(slower)})")
    lines.append("")
    lines.append("(bold: within the target; figures: µs per frame, the median over the runs, their range in "
                 "brackets; one frame at a time the bench's median, with frames in flight its mean)")
    lines.append("")
    for target, (cells, misses) in held.items():
        if target == faster_than:
            what = f"every backend but {reference} faster than {faster_than}"
        else:
            what = f"{target} ≤ {limits[target]:g}x {reference}"
        verdict = f"held in {cells - len(misses)} of {cells} cells"
        lines.append(f"- {what}: {verdict}" + (f"; not in {'; '.join(misses)}" if misses else ""))
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", help="portaslam bench --json files")
    parser.add_argument("--reference", default="cuda")
    parser.add_argument("--within", action="append", default=[], metavar="BACKEND=RATIO")
    parser.add_argument("--faster-than", default="", metavar="BACKEND")
    args = parser.parse_args()
    try:
        limits = parse_within(args.within)
        runs = [read_run(path) for path in args.runs]
        if not any(runs):
            raise BadInput("no bench rows in " + ", ".join(args.runs))
    except BadInput as e:
        print(f"backend_table.py: {e}", file=sys.stderr)
        return 2
    print(table(runs, args.reference, limits, args.faster_than))
    return 0


if __name__ == "__main__":
    sys.exit(main())
