#!/usr/bin/env python3
"""Make the tracking-loss copies of a rendered KITTI-layout sequence (docs/BENCHMARKS.md, "Tracking
loss"): a covered lens (frames FIRST..FIRST+COUNT-1 of both cameras black) and a kidnap (frames
0..AFTER followed by frames BACK..BACK+COUNT-1 again, times going on at the sequence's rate and the
ground truth following the frames). Images are linked, not copied, where the filesystem allows.

  bench/tracking_loss.py black  SRC DST [--first 200] [--count 30]
  bench/tracking_loss.py kidnap SRC DST [--after 299] [--back 100] [--count 100]
"""
import argparse
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


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=["black", "kidnap"])
    parser.add_argument("src")
    parser.add_argument("dst")
    parser.add_argument("--first", type=int, default=200, help="black: first covered frame")
    parser.add_argument("--after", type=int, default=299, help="kidnap: last frame before the kidnap")
    parser.add_argument("--back", type=int, default=100, help="kidnap: the frame the camera is carried back to")
    parser.add_argument("--count", type=int, default=None, help="black: 30 covered frames; kidnap: 100 frames again")
    a = parser.parse_args()
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
