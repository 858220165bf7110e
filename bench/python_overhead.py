#!/usr/bin/env python3
"""The Python bindings' per-call overhead: Frontend.detect_stereo from Python against the same call
from C++ (porta_frontend_call --repeat), on the same stereo pair (frame 0 of a KITTI-layout
folder, e.g. one `portaslam render` wrote), backend and settings, in one run.

    PYTHONPATH=build/python build/python-env/bin/python bench/python_overhead.py SEQUENCE \
        --call build/tests/porta_frontend_call [--backend cpu] [--repeat 200] [--rounds 3]

Each round times C++ then Python (median of --repeat calls after one warm-up each); the report
gives each round and the median of the rounds' ratios. "python+arrays" also converts the left and
right keypoints and descriptors and the matches to numpy arrays, as a user reading them does.
"""
import argparse
import statistics
import subprocess
import sys
import time

import portaslam


def time_python(frontend, left, right, repeat, arrays):
    def call():
        pair = frontend.detect_stereo(left, right)
        if arrays:
            pair.left.keypoints, pair.left.descriptors, pair.right.keypoints, pair.right.descriptors, pair.matches
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) * 1e6)
    return statistics.median(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sequence")
    parser.add_argument("--call", required=True, help="the porta_frontend_call program")
    parser.add_argument("--backend", default="cpu")
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if args.repeat < 1 or args.rounds < 1:
        sys.exit("python_overhead.py: --repeat and --rounds must be >= 1")

    left, right, _ = portaslam.open_dataset("kitti", args.sequence)[0]
    left_png = f"{args.sequence}/image_0/000000.png"
    right_png = f"{args.sequence}/image_1/000000.png"
    frontend = portaslam.Frontend(left.shape[1], left.shape[0], backend=args.backend)
    ratios, ratios_arrays = [], []
    print(f"{args.backend}, {left.shape[1]}x{left.shape[0]}, 8 levels, detect_stereo, median of {args.repeat} calls")
    print("round   c++ us   python us   python+arrays us   python/c++   +arrays/c++")
    for r in range(args.rounds):
        out = subprocess.run([args.call, left_png, right_png, "--backend", args.backend, "--repeat", str(args.repeat)],
                             capture_output=True, text=True, check=True).stdout
        cpp = float(out.split("median_us ")[1].split()[0])
        py = time_python(frontend, left, right, args.repeat, arrays=False)
        py_arrays = time_python(frontend, left, right, args.repeat, arrays=True)
        ratios.append(py / cpp)
        ratios_arrays.append(py_arrays / cpp)
        print(f"{r + 1:5d} {cpp:8.1f} {py:11.1f} {py_arrays:18.1f} {py / cpp:12.3f} {py_arrays / cpp:13.3f}")
    print(f"median ratio: python/c++ {statistics.median(ratios):.3f}, "
          f"python+arrays/c++ {statistics.median(ratios_arrays):.3f}")


if __name__ == "__main__":
    main()
