#!/usr/bin/env python3
"""Make the tracking-loss copies of a rendered KITTI-layout sequence (docs/BENCHMARKS.md, "Tracking
loss"): a covered lens (frames FIRST..FIRST+COUNT-1 of both cameras black) and a kidnap (frames
0..AFTER followed by frames BACK..BACK+COUNT-1 again, times going on at the sequence's rate and the
ground truth following the frames). Images are linked, not copied, where the filesystem allows.

  bench/tracking_loss.py black  SRC DST [--first 200] [--count 30]
  bench/tracking_loss.py kidnap SRC DST [--after 299] [--back 100] [--count 100]

`report COPY RUN --from F` says what a `portaslam run` (its --out folder RUN) made of a copy: the
first frame F of the disturbance (the first black frame; the first kidnapped frame), the frame
relocalised at, the first frame from F on that is at most --near metres behind a place tracked
before F, looking the same way (within 30 degrees), so that the map made there is in view again
(back in sight of the map), and the position error against the truth (raw:
the map's frame is the first camera's, which is the truth's) at the relocalised frame and the worst
after it. Where a frame replays a place tracked before F (a kidnap), its error against that first
pass's estimate is given too, and the limits apply to that one: the map's own error there is not
the relocalisation's. It exits 1 when the error at the relocalised frame exceeds --max-error, the
worst after it --max-error-after, or the delay --within frames, or when tracking is lost again.

  bench/tracking_loss.py report COPY RUN --from F [--near 15] [--max-error M] [--max-error-after M]
                               [--within N]
"""
import argparse
import json
import math
import os
import shutil
import struct
import sys
import zlib


def fail(message):
    print(f"tracking_loss.py: {message}", file=sys.stderr)
    sys.exit(1)


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        fail(f"{path}: not a PNG file")
    return struct.unpack(">II", head[16:24])


def black_png(width, height):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + bytes(width) for _ in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def read_lines(path):
    if not os.path.isfile(path):
        fail(f"{path}: missing (SRC must be a rendered KITTI-layout folder)")
    with open(path) as f:
        lines = [line for line in f.read().splitlines() if line.strip()]
    if not lines:
        fail(f"{path}: empty")
    return lines


def link_or_copy(src, dst):
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


def write_copy(src, dst, order, black):
    """Frame i of the copy is frame order[i] of SRC, black where black(i)."""
    times = read_lines(os.path.join(src, "times.txt"))
    poses_path = os.path.join(src, "poses.txt")
    poses = read_lines(poses_path) if os.path.exists(poses_path) else None
    if max(order) >= len(times):
        fail(f"{src} has {len(times)} frames; the copy needs frame {max(order)}")
    if os.path.exists(dst):
        fail(f"{dst}: exists; give a new folder")
    period = (float(times[-1]) - float(times[0])) / max(1, len(times) - 1)
    tmp = dst + ".partial"
    shutil.rmtree(tmp, ignore_errors=True)
    for camera in ("image_0", "image_1"):
        os.makedirs(os.path.join(tmp, camera))
        width, height = png_size(os.path.join(src, camera, "000000.png"))
        dark = black_png(width, height)
        for i, frame in enumerate(order):
            out = os.path.join(tmp, camera, f"{i:06d}.png")
            if black(i):
                with open(out, "wb") as f:
                    f.write(dark)
            else:
                link_or_copy(os.path.join(src, camera, f"{frame:06d}.png"), out)
    shutil.copyfile(os.path.join(src, "calib.txt"), os.path.join(tmp, "calib.txt"))
    with open(os.path.join(tmp, "times.txt"), "w") as f:
        f.writelines(f"{float(times[0]) + i * period:.6e}\n" for i in range(len(order)))
    if poses is not None:
        with open(os.path.join(tmp, "poses.txt"), "w") as f:
            f.writelines(poses[frame] + "\n" for frame in order)
    os.rename(tmp, dst)


def read_run(copy, run):
    """Per frame of COPY: the true camera centre, and the estimated one (None: not tracked)."""
    times = [float(t) for t in read_lines(os.path.join(copy, "times.txt"))]
    truth = []
    for line in read_lines(os.path.join(copy, "poses.txt")):
        v = [float(x) for x in line.split()]
        if len(v) != 12:
            fail(f"{copy}/poses.txt: a KITTI pose has 12 numbers, got {len(v)}")
        truth.append(((v[3], v[7], v[11]), (v[2], v[6], v[10])))  # centre, optical axis
    estimate = {}
    path = os.path.join(run, "trajectory_tum.txt")
    if not os.path.isfile(path):
        fail(f"{path}: missing (RUN must be the --out folder of a finished portaslam run)")
    for line in read_lines(path):
        if line.startswith("#"):
            continue
        v = [float(x) for x in line.split()]
        estimate[round(v[0], 4)] = (v[1], v[2], v[3])
    return truth, [estimate.get(round(t, 4)) for t in times]


def report(a):
    n = len(read_lines(os.path.join(a.src, "times.txt")))
    if not 0 < a.first_disturbed < n:
        fail(f"--from {a.first_disturbed} must lie within the {n} frames (after frame 0)")
    truth, estimate = read_run(a.src, a.dst)
    if len(truth) != n:
        fail(f"{a.src}: {len(truth)} poses for {n} times")
    summary_path = os.path.join(a.dst, "summary.json")
    try:
        with open(summary_path) as f:
            relocalised = [k for k in json.load(f)["relocalisation"]["frames"] if k >= a.first_disturbed]
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail(f"{summary_path}: no relocalisation frames ({e})")
    mapped = [truth[k] for k in range(a.first_disturbed) if estimate[k] is not None]

    def sees_mapped_place(k):
        centre, axis = truth[k]
        for place, place_axis in mapped:
            ahead = sum((p - c) * z for p, c, z in zip(place, centre, axis))
            same_way = sum(z * w for z, w in zip(axis, place_axis)) >= math.cos(math.radians(30.0))
            if same_way and 0.0 <= ahead and math.dist(place, centre) <= a.near:
                return True
        return False

    back = next((k for k in range(a.first_disturbed, n) if sees_mapped_place(k)), None)
    print(f"disturbed from frame {a.first_disturbed}; at most {a.near:g} m behind a mapped place, "
          f"looking its way, from frame {back}")
    if not relocalised or estimate[relocalised[0]] is None:
        print("never relocalised")
        return 1
    first = relocalised[0]
    untracked = sum(1 for k in range(a.first_disturbed, first) if estimate[k] is None)
    first_pass = {truth[m][0]: estimate[m] for m in range(a.first_disturbed) if estimate[m] is not None}
    replay = all(truth[k][0] in first_pass for k in range(first, n))
    errors = [(k, math.dist(estimate[k], first_pass[truth[k][0]] if replay else truth[k][0]))
              for k in range(first, n) if estimate[k] is not None]
    worst = max(errors, key=lambda e: e[1])
    against = "the first pass's estimate of the same place" if replay else "the truth"
    truth_too = f" (against the truth {math.dist(estimate[first], truth[first][0]) * 100:.2f} cm)" if replay else ""
    print(f"relocalised at frame {first} ({untracked} frames untracked before it): position error against "
          f"{against} {errors[0][1] * 100:.2f} cm{truth_too}; worst after it {worst[1] * 100:.2f} cm "
          f"at frame {worst[0]}; {len(errors)} of {n - first} frames from it tracked")
    failed = False
    if a.within is not None and (back is None or first > back + a.within):
        print(f"FAIL: relocalised more than {a.within} frames after frame {back}")
        failed = True
    for limit, (k, error) in ((a.max_error, errors[0]), (a.max_error_after, worst)):
        if limit is not None and error > limit:
            print(f"FAIL: position error {error * 100:.2f} cm at frame {k} exceeds {limit * 100:g} cm")
            failed = True
    if len(errors) != n - first:
        print(f"FAIL: lost again after relocalising ({n - first - len(errors)} frames)")
        failed = True
    return 1 if failed else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=["black", "kidnap", "report"])
    parser.add_argument("src", help="the rendered sequence (report: the copy)")
    parser.add_argument("dst", help="the copy to write (report: the run's --out folder)")
    parser.add_argument("--from", dest="first_disturbed", type=int, default=None,
                        help="report: the first black or kidnapped frame")
    parser.add_argument("--near", type=float, default=15.0, help="report: metres from the mapped path")
    parser.add_argument("--max-error", type=float, default=None, help="report: metres, at the relocalised frame")
    parser.add_argument("--max-error-after", type=float, default=None, help="report: metres, any frame after it")
    parser.add_argument("--within", type=int, default=None, help="report: frames after coming back")
    parser.add_argument("--first", type=int, default=200, help="black: first covered frame")
    parser.add_argument("--after", type=int, default=299, help="kidnap: last frame before the kidnap")
    parser.add_argument("--back", type=int, default=100, help="kidnap: the frame the camera is carried back to")
    parser.add_argument("--count", type=int, default=None, help="black: 30 covered frames; kidnap: 100 frames again")
    a = parser.parse_args()
    if a.kind == "report":
        if a.first_disturbed is None:
            fail("report needs --from F (the first black or kidnapped frame)")
        sys.exit(report(a))
    n = len(read_lines(os.path.join(a.src, "times.txt")))
    if a.kind == "black":
        count = 30 if a.count is None else a.count
        if a.first < 0 or count < 1 or a.first + count > n:
            fail(f"--first {a.first} --count {count} must lie within the {n} frames")
        write_copy(a.src, a.dst, list(range(n)), lambda i: a.first <= i < a.first + count)
    else:
        count = 100 if a.count is None else a.count
        if not (0 <= a.back < a.after < n) or count < 1 or a.back + count > n:
            fail(f"need 0 <= --back < --after < {n} frames and --back + --count <= {n}")
        write_copy(a.src, a.dst, list(range(a.after + 1)) + list(range(a.back, a.back + count)), lambda i: False)
    print(f"wrote {a.dst}")


if __name__ == "__main__":
    main()
