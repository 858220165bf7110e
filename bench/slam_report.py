#!/usr/bin/env python3
"""The report of ci/gpu-slam.sh: tables of the SLAM runs on every backend, from the summary JSON
files `portaslam run` wrote (`--json`) and the GPU samples nvidia-smi took during the timed runs.

Runs are named as ci/gpu-slam.sh names them: det-BACKEND (deterministic mode), fast-BACKEND-N (as
fast as possible, repeat N), rate1-BACKEND (at the recorded frame rate). For the as-fast-as-possible
runs each figure is the median over the repeats. GPU figures come from nvidia-smi's utilization.gpu
(the share of time in which a kernel ran, over the driver's own sampling period) and memory.used
sampled every 100 ms: "GPU busy ms per frame" is the mean utilisation times the run's wall time
divided by its frames, an estimate rather than a kernel-by-kernel sum; "GPU memory" is the largest
memory.used less the first sample's (taken before the program started).

  python3 bench/slam_report.py --results OUT_DIR --work WORK --backends cpu,cuda,vulkan,opencl

Standard library only (the GPU machine's Python may lack numpy).
"""
import argparse
import glob
import json
import os
import statistics
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def gpu_samples(path):
    """(mean utilisation %, memory growth MiB) from an nvidia-smi CSV, or (None, None)."""
    if not os.path.exists(path):
        return None, None
    util, memory = [], []
    with open(path) as f:
        for line in f:
            parts = [p.strip() for p in line.split(",")]
            if len(parts) < 3:
                continue
            try:
                util.append(float(parts[1]))
                memory.append(float(parts[2]))
            except ValueError:
                continue
    if len(util) < 2:
        return None, None
    # The first sample is before the program started; the last ones may be after it ended.
    return statistics.mean(util[1:]), max(memory) - memory[0]


def figures(summary, gpu_csv):
    stages = summary["stages_ms"]
    throughput = summary.get("throughput", {})
    frames = max(summary["frames"], 1)
    util, memory = gpu_samples(gpu_csv)
    wall = throughput.get("wall_s")
    return {
        "frames": summary["frames"],
        "lost": summary["lost"],
        "keyframes": summary["keyframes"],
        "median_ms": stages["frame"]["median"],
        "p95_ms": stages["frame"]["p95"],
        "mean_ms": stages["frame"].get("mean"),
        "input_wait_ms": (stages.get("input wait") or {}).get("mean"),
        "frontend_ms": stages["frontend"]["median"],
        "tracking_ms": stages["tracking"]["median"],
        "fps": throughput.get("frames_per_s"),
        "cpu_s_per_frame": throughput.get("cpu_s_per_frame"),
        "peak_mib": throughput.get("peak_resident_mib"),
        "gpu_util": util,
        "gpu_ms_per_frame": None if util is None or wall is None else util / 100.0 * wall / frames * 1000.0,
        "gpu_mib": memory,
        "ate_m": (summary.get("ate") or {}).get("rmse_m"),
        "cpu_by_thread": (throughput.get("cpu") or {}).get("by_thread_s"),
        "reading_cpu_s": (throughput.get("cpu") or {}).get("reading_s"),
    }


def median_of(rows, key):
    values = [r[key] for r in rows if r.get(key) is not None]
    return statistics.median(values) if values else None


def fmt(value, digits=2):
    if value is None:
        return "-"
    if isinstance(value, int):
        return str(value)
    return f"{value:.{digits}f}"


COLUMNS = [
    ("frames", "frames", 0), ("lost", "lost", 0), ("median ms/frame", "median_ms", 3), ("p95 ms", "p95_ms", 3),
    ("mean ms", "mean_ms", 3), ("input wait ms (mean)", "input_wait_ms", 3), ("frontend ms", "frontend_ms", 3), ("tracking ms", "tracking_ms", 3), ("frames/s", "fps", 1),
    ("host CPU s/frame", "cpu_s_per_frame", 4), ("peak RSS MiB", "peak_mib", 0), ("GPU busy %", "gpu_util", 0),
    ("GPU busy ms/frame", "gpu_ms_per_frame", 3), ("GPU memory MiB", "gpu_mib", 0), ("ATE RMSE m", "ate_m", 4),
]


def table(title, rows):
    out = [f"### {title}", "", "| run | " + " | ".join(c[0] for c in COLUMNS) + " |",
           "|---" * (len(COLUMNS) + 1) + "|"]
    for name, r in rows:
        out.append(f"| {name} | " + " | ".join(fmt(r.get(key), digits) for _, key, digits in COLUMNS) + " |")
    return out + [""]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--results", required=True, help="ci/gpu-slam.sh's OUT_DIR")
    parser.add_argument("--work", default="", help="its work folder (for the record)")
    parser.add_argument("--backends", required=True, help="comma list, cpu first")
    args = parser.parse_args()
    res = args.results
    backends = [b for b in args.backends.split(",") if b]
    if not os.path.isdir(res):
        sys.exit(f"slam_report.py: --results {res!r} is not a folder")
    if not backends:
        sys.exit("slam_report.py: --backends names no backend")
    if not glob.glob(os.path.join(res, "*.json")):
        sys.exit(f"slam_report.py: no run summaries (*.json) in {res!r}: did ci/gpu-slam.sh's runs fail?")

    lines = ["# PortaSLAM: the whole SLAM on every backend (ci/gpu-slam.sh)", "", "```"]
    for name in ("machine.txt", "render.log", "render_md5.txt"):
        path = os.path.join(res, name)
        if os.path.exists(path):
            lines += [line.rstrip() for line in open(path) if line.strip() and "%" not in line[:3]][-6:]
    lines += ["```", ""]

    det = {}
    for b in backends:
        path = os.path.join(res, f"det-{b}.json")
        if os.path.exists(path):
            det[b] = figures(load(path), "")
    lines += table("Deterministic mode (mapping completes after each keyframe; the runs side by side, so "
                   "their times are not comparable)", [(f"det {b}", r) for b, r in det.items()])
    path = os.path.join(res, "determinism.txt")
    if os.path.exists(path):
        lines += ["Byte-for-byte comparison with the cpu backend's files:", "", "```"]
        lines += [line.rstrip() for line in open(path)]
        lines += ["```", ""]

    fast = {}
    for b in backends:
        runs = []
        for path in sorted(glob.glob(os.path.join(res, f"fast-{b}-*.json"))):
            runs.append(figures(load(path), path[: -len(".json")] + ".gpu.csv"))
        if runs:
            fast[b] = {key: median_of(runs, key) for _, key, _ in COLUMNS}
            fast[b]["runs"] = len(runs)
    lines += table("As fast as possible (realtime mode: tracking and mapping threads; median of the repeats)",
                   [(f"{b} ({r['runs']} runs)", r) for b, r in fast.items()])

    rate = {}
    for b in backends:
        path = os.path.join(res, f"rate1-{b}.json")
        if os.path.exists(path):
            rate[b] = figures(load(path), os.path.join(res, f"rate1-{b}.gpu.csv"))
    if rate:
        lines += table("At camera rate (--rate 1: each frame handed over at its time stamp, 10 Hz)",
                       [(f"rate 1 {b}", r) for b, r in rate.items()])
        for b, r in rate.items():
            if r["cpu_s_per_frame"] is not None:
                lines.append(f"- {b} at 10 Hz: host CPU {100.0 * r['cpu_s_per_frame'] * 10.0:.1f} % of one core "
                             "(goal <= 25 %)")
            if r["cpu_by_thread"]:
                frames = max(r["frames"], 1)
                parts = ", ".join(f"{name} {1000.0 * s / frames:.2f}" for name, s in r["cpu_by_thread"].items())
                reading = r["reading_cpu_s"]
                lines.append(f"  - by thread, ms of CPU per frame: {parts}"
                             + (f"; reading the images {1000.0 * reading / frames:.2f} of it" if reading else ""))
        lines.append("")

    lines += ["### Targets", ""]
    cuda = fast.get("cuda")
    cpu_det = det.get("cpu")
    if cuda:
        lines.append(f"- cuda as fast as possible: median {fmt(cuda['median_ms'], 3)} ms per frame (target <= 2), "
                     f"{fmt(cuda['fps'], 1)} frames/s (target >= 500), lost {fmt(cuda['lost'])} (target 0)")
        if cpu_det and cpu_det["ate_m"] and cuda["ate_m"]:
            lines.append(f"- cuda ATE {cuda['ate_m']:.4f} m = {cuda['ate_m'] / cpu_det['ate_m']:.2f}x the "
                         f"deterministic cpu run's {cpu_det['ate_m']:.4f} m (target <= 1.2x)")
    for b in ("vulkan", "opencl"):
        if b in fast and cuda and cuda["median_ms"]:
            lines.append(f"- {b}: median {fmt(fast[b]['median_ms'], 3)} ms per frame = "
                         f"{fast[b]['median_ms'] / cuda['median_ms']:.2f}x cuda's")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
