#!/usr/bin/env python3
"""Summary of ci/gpu-slam-variants.sh: one line per timed run and the medians per variant.

Reads OUT_DIR/NAME-ROUND/fast-BACKEND-1.json (the run's summary) and .mapping.csv (local mapping's
steps per keyframe) for every variant NAME and ROUND; prints Markdown tables to stdout. Standard
library only (the GPU machine has no extra Python packages).

    usage: bench/slam_variants.py OUT_DIR
"""
import csv
import json
import re
import statistics
import sys
from pathlib import Path


def run_row(json_path):
    summary = json.loads(json_path.read_text())
    stages = summary["stages_ms"]
    row = {
        "frames/s": summary["throughput"]["frames_per_s"],
        "median ms": stages["frame"]["median"],
        "mean ms": stages["frame"]["mean"],
        "tracking ms": stages["tracking"]["median"],
        "mapping wait ms": stages["mapping wait"]["mean"],
        "CPU s/frame": summary["throughput"]["cpu_s_per_frame"],
        "keyframes": summary["keyframes"],
        "relocalised": summary["relocalisation"]["count"],
        "lost": summary["lost"],
        "ATE m": (summary.get("ate") or {}).get("rmse_m", float("nan")),
    }
    # Tracking's hold on the map's lock, means per frame (the last two from trees that release it).
    for name, stage in (("map lock wait ms", "map lock wait"), ("unlocked ms", "without map lock"),
                        ("retake ms", "map lock retake")):
        if stage in stages:
            row[name] = stages[stage]["mean"]
    mapping = json_path.with_name(json_path.name.replace(".json", ".mapping.csv"))
    if mapping.is_file():
        rows = list(csv.DictReader(mapping.open()))
        if rows:
            row["mapped"] = len(rows)
            row["fusion ran %"] = 100.0 * sum(float(r["fusion_ms"]) > 0 for r in rows) / len(rows)
            row["BA ran %"] = 100.0 * sum(r["ba_ran"] == "1" for r in rows) / len(rows)
            row["spread %"] = 100.0 * sum(r["spread"] == "1" for r in rows) / len(rows)
            row["mapping ms (mean)"] = statistics.mean(float(r["total_ms"]) for r in rows)
            row["link ms (median)"] = statistics.median(float(r["process_ms"]) for r in rows)
            row["triangulation ms (median)"] = statistics.median(float(r["triangulation_ms"]) for r in rows)
            if "lock_wait_ms" in rows[0]:  # trees from 22c6110 on
                row["mapping lock wait ms (mean)"] = statistics.mean(float(r["lock_wait_ms"]) for r in rows)
    return row


def fmt(value):
    if isinstance(value, float):
        return f"{value:.4f}" if abs(value) < 1 else f"{value:.2f}" if abs(value) < 100 else f"{value:.1f}"
    return str(value)


def main():
    if len(sys.argv) != 2 or not Path(sys.argv[1]).is_dir():
        sys.exit("usage: bench/slam_variants.py OUT_DIR (a folder written by ci/gpu-slam-variants.sh)")
    out = Path(sys.argv[1])
    runs = []  # (variant, round, row)
    for folder in sorted(out.iterdir()):
        match = re.fullmatch(r"(.+)-([0-9]+)", folder.name)
        if not folder.is_dir() or not match:
            continue
        for json_path in sorted(folder.glob("fast-*-1.json")):
            try:
                runs.append((match.group(1), int(match.group(2)), run_row(json_path)))
            except (OSError, ValueError, KeyError, TypeError, csv.Error) as e:
                sys.exit(f"bench/slam_variants.py: {json_path}: not a portaslam run summary "
                         f"({type(e).__name__}: {e})")
    if not runs:
        sys.exit(f"no runs (NAME-ROUND/fast-*-1.json) in {out}")
    columns = [c for c in runs[0][2]] + [c for c in sorted({c for _, _, r in runs for c in r}) if c not in runs[0][2]]
    print("| variant | round | " + " | ".join(columns) + " |")
    print("|---|---|" + "---|" * len(columns))
    for variant, rnd, row in sorted(runs, key=lambda t: (t[1], t[0])):
        print(f"| {variant} | {rnd} | " + " | ".join(fmt(row.get(c, "")) for c in columns) + " |")
    print("\nMedians over the rounds:\n")
    print("| variant | runs | " + " | ".join(columns) + " |")
    print("|---|---|" + "---|" * len(columns))
    for variant in sorted({v for v, _, _ in runs}):
        rows = [row for v, _, row in runs if v == variant]
        medians = []
        for c in columns:
            values = [row[c] for row in rows if c in row]
            medians.append(fmt(float(statistics.median(values))) if values else "")
        print(f"| {variant} | {len(rows)} | " + " | ".join(medians) + " |")


if __name__ == "__main__":
    main()
