#!/usr/bin/env python3
"""OpenCV's ORB from Python (cv2) as the peer of `portaslam bench`, for machines that have cv2 but
no OpenCV C++ libraries (the GPU machine), where portaslam is built without its cv::ORB peer.

It times cv2.ORB_create(nfeatures, scaleFactor=1.2, nlevels, edgeThreshold=31, firstLevel=0,
WTA_K=2, scoreType=ORB_HARRIS_SCORE, patchSize=31, fastThreshold=20) with the protocol of
`portaslam bench` (apps/portaslam/bench_command.cpp): per cell (resolution x levels x mode) a fresh
ORB, W untimed warm-up frames, then N timed frames cycling through the same input images, each the
wall time of one call (detect / detectAndCompute / both images + BFMatcher(NORM_HAMMING,
crossCheck=True)); median, p10, p90 (linear interpolation between ranks), frames/s = 1e6 / median.

The input images are chosen, centre-cropped and resized exactly as portaslam bench does
(apps/portaslam/bench_inputs.cpp), with cv2.resize (INTER_AREA when shrinking, else INTER_LINEAR);
with no data folder, the built-in synthetic pair is regenerated bit for bit
(apps/portaslam/synthetic_pair.cpp). With --ours OURS.json (from `portaslam bench --json`), the
cells, frames, warm-up and nfeatures (our mean keypoints per image in each cell, of the first of
our backends that finished it, as the C++ peer does) come from our run, the input descriptions are
compared with ours, and the ratio peer median / our median is printed for each of our rows.

Python adds to each time: well under a microsecond per call for the binding and the perf_counter
pair, plus a fraction of a microsecond for every keypoint and match returned, since each becomes a
Python object (hundreds of microseconds for a thousand keypoints). Both are measured; each row
reports its estimate (python_overhead_us, inside its times), and the ratios are printed with and
without it. Needs Python 3.8+, numpy and cv2
(opencv-python or opencv-python-headless).

  python3 bench/orb_peer.py --ours ours.json --json peer.json
  python3 bench/orb_peer.py --ours ours.json --ratios peer.json      # ratios only, no timing
  python3 bench/orb_peer.py --resolutions 640x480 --levels 8 --modes extract --nfeatures 800
"""
import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time

PEER_NAME = "opencv-orb-python"
MODES = ("detect", "extract", "stereo")
DEFAULT_RESOLUTIONS = "320x240,640x480,752x480,1242x375"
MAX_SEQUENCE_FRAMES = 32  # apps/portaslam/bench_inputs.cpp: kMaxSequenceFrames
SYNTHETIC_VARIANTS = 8
EUROC_SIZE = (752, 480)
SCALE_FACTOR = 1.2  # FrontendSettings defaults, as the C++ peer uses them
FAST_THRESHOLD = 20
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEER_NOTE = ("cv2.ORB on the CPU from Python, nfeatures = our mean keypoints per image in the same cell, "
             "scale 1.2, FAST threshold 20, Harris score, patch 31; stereo = detectAndCompute on both images "
             "+ cv2.BFMatcher(NORM_HAMMING, crossCheck): no row or disparity constraint, not the same stereo "
             "matching as ours, the closest cheap peer; each time includes Python's overhead (python_overhead_us)")


class PeerError(Exception):
    """A problem with what the user gave (an option, a file): printed, exit status 1."""


def import_cv2():
    try:
        import cv2  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as e:
        raise PeerError(f"cannot import {e.name}: install opencv-python-headless (pip install "
                        f"opencv-python-headless), which brings numpy") from e
    return cv2


# ---- Options --------------------------------------------------------------------------------------

def parse_list(text, option):
    items = []
    for item in text.split(","):
        if item and item not in items:
            items.append(item)
    if not items:
        raise PeerError(f"option {option} needs at least one value, got '{text}'")
    return items


def parse_resolution(text):
    w, sep, h = text.lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit():
        raise PeerError(f"option --resolutions expects sizes WxH separated by commas, got '{text}'")
    if min(int(w), int(h)) < 40 or max(int(w), int(h)) > 16384:
        raise PeerError(f"option --resolutions: size {text} is out of range: each side must be in [40, 16384]")
    return int(w), int(h)


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="orb_peer.py", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n" + "\n".join(line for line in __doc__.splitlines() if line.startswith("  python3")) +
        "\n\nExit status: 0 success; 1 bad option or file (message on stderr). docs/USER_GUIDE.md has the details.")
    p.add_argument("--ours", metavar="OURS.json", help="a `portaslam bench --json` file: cells, frames, warm-up, "
                   "nfeatures per cell, and the rows to print ratios for")
    p.add_argument("--json", metavar="FILE", help="write every number, the machine, date and commit as JSON")
    p.add_argument("--ratios", metavar="PEER.json", help="do not time: read an earlier run's --json and print "
                   "the ratios against --ours")
    p.add_argument("--resolutions", metavar="LIST", help=f"sizes WxH (default: our JSON's, else {DEFAULT_RESOLUTIONS})")
    p.add_argument("--levels", metavar="LIST", help="pyramid levels, each in [1, 12] (default: our JSON's, else 1,4,8)")
    p.add_argument("--modes", metavar="LIST", help="detect, extract, stereo (default: our JSON's, else all three)")
    p.add_argument("--frames", type=int, metavar="N", help="timed frames per cell (default: our JSON's, else 200)")
    p.add_argument("--warmup", type=int, metavar="W", help="untimed frames before them (default: our JSON's, else 20)")
    p.add_argument("--nfeatures", type=int, metavar="N", help="ORB nfeatures for every cell (default: our mean keypoints "
                   "per cell from --ours; one of the two is needed)")
    p.add_argument("--cv-threads", type=int, metavar="N", help="cv2.setNumThreads(N) with N >= 1 (default: "
                   "OpenCV's default, all cores; note that OpenCV reads 0 as 'no threading')")
    p.add_argument("--data", metavar="DIR", help="the shared data folder (default: $PORTA_DATA_DIR, else the "
                   "one our JSON names, else ../shared/data from here, else beside this repository)")
    a = p.parse_args(argv)
    if a.ratios and not a.ours:
        raise PeerError("option --ratios needs --ours OURS.json to compare with")
    for name in ("frames", "warmup", "nfeatures", "cv_threads"):
        value, low = getattr(a, name), 0 if name == "warmup" else 1
        if value is not None and not low <= value <= 1000000:
            raise PeerError(f"option --{name.replace('_', '-')} expects a count in [{low}, 1000000], got {value}")
    if a.json and os.path.dirname(a.json) and not os.path.isdir(os.path.dirname(a.json)):
        raise PeerError(f"cannot write '{a.json}': folder '{os.path.dirname(a.json)}' does not exist")
    return a


def read_json(path, what):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise PeerError(f"cannot read {what} '{path}': {e.strerror}") from e
    except json.JSONDecodeError as e:
        raise PeerError(f"{what} '{path}' is not JSON: {e}") from e


def our_cells(ours):
    """Our JSON's cells in order: (resolution text, levels, mode) -> our mean keypoints (or None)."""
    if ours.get("tool") != "portaslam bench" or not isinstance(ours.get("results"), list):
        raise PeerError("--ours: not a `portaslam bench --json` file (no \"tool\": \"portaslam bench\" "
                        "with \"results\")")
    cells = {}
    for row in ours["results"]:
        key = (row["resolution"], row["levels"], row["mode"])
        cells.setdefault(key, None)
        if cells[key] is None and "error" not in row and row["backend"] not in ("opencv-orb", PEER_NAME):
            cells[key] = row["mean_keypoints"]
    return cells


def plan(a, ours):
    """The cells to time: [(width, height, levels, mode, nfeatures)] and the protocol."""
    settings = ours.get("settings", {}) if ours else {}
    frames = a.frames if a.frames is not None else settings.get("frames", 200)
    warmup = a.warmup if a.warmup is not None else settings.get("warmup", 20)
    cells = our_cells(ours) if ours else {}

    def ours_in_order(index):  # our JSON's values of one cell field, in the order of its rows
        values = []
        for key in cells:
            if key[index] not in values:
                values.append(key[index])
        return values

    if a.resolutions or not cells:
        resolutions = parse_list(a.resolutions or DEFAULT_RESOLUTIONS, "--resolutions")
    else:
        resolutions = ours_in_order(0)
    resolutions = [parse_resolution(r) for r in resolutions]
    levels = [int(x) if x.isdigit() else -1 for x in parse_list(a.levels, "--levels")] if a.levels else \
        ours_in_order(1) or [1, 4, 8]
    if not all(1 <= n <= 12 for n in levels):
        raise PeerError(f"option --levels: each value must be an integer in [1, 12], got '{a.levels}'")
    modes = parse_list(a.modes, "--modes") if a.modes else ours_in_order(2) or list(MODES)
    for m in modes:
        if m not in MODES:
            raise PeerError(f"unknown mode '{m}' in --modes: choose from detect, extract, stereo")
    wanted = [(size, n, m) for size in resolutions for n in levels for m in modes]
    out = []
    for (w, h), n, mode in wanted:
        nfeatures = a.nfeatures
        if nfeatures is None:
            mean = cells.get((f"{w}x{h}", n, mode))
            if mean is None:
                raise PeerError(f"no nfeatures for {w}x{h}, {n} levels, {mode}: " +
                                ("our JSON has no finished row for that cell; give --nfeatures N" if ours else
                                 "give --ours OURS.json (nfeatures = our mean keypoints per cell) or --nfeatures N"))
            nfeatures = max(1, int(math.floor(mean + 0.5)))
        out.append((w, h, n, mode, nfeatures))
    return out, frames, warmup


# ---- Input images: apps/portaslam/bench_inputs.cpp, step by step ------------------------------------

def locate_data_folder(a, ours):
    if a.data:
        if not os.path.isdir(a.data):
            raise PeerError(f"data folder '{a.data}' (from --data) is not a folder")
        return a.data, "--data"
    env = os.environ.get("PORTA_DATA_DIR")
    if env:
        if not os.path.isdir(env):
            raise PeerError(f"data folder '{env}' (from $PORTA_DATA_DIR) is not a folder")
        return env, "$PORTA_DATA_DIR"
    named = (ours or {}).get("settings", {}).get("data", "")
    named = named.rsplit(" (", 1)[0] if named != "none found" else ""
    if named and os.path.isdir(named):
        return named, "the data folder our JSON names"
    if os.path.isdir("../shared/data"):
        return "../shared/data", "../shared/data from the current folder"
    beside = os.path.normpath(os.path.join(REPO, "..", "shared", "data"))
    if os.path.isdir(beside):
        return beside, "../shared/data beside this repository"
    return "", ""


def png_names(folder):
    try:
        names = sorted(e.name for e in os.scandir(folder) if e.is_file() and e.name.endswith(".png"))
    except OSError:
        return []
    return names[:MAX_SEQUENCE_FRAMES]


def load_gray(cv2, path):
    """What portaslam's OpenCV build makes of a file (apps/portaslam/image_files.cpp)."""
    m = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if m is None:
        raise PeerError(f"cannot decode image '{path}'")
    if m.dtype.name == "uint16":
        m = cv2.convertScaleAbs(m, alpha=1.0 / 257.0)
    if m.ndim == 3 and m.shape[2] in (3, 4):
        m = cv2.cvtColor(m, cv2.COLOR_BGRA2GRAY if m.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    elif m.ndim == 3:
        m = m[:, :, 0].copy()
    return m


def stem(name):
    return os.path.splitext(name)[0]


def load_kitti(cv2, data):
    folder = os.path.join(data, "kitti07-left-head", "image_0")
    names = png_names(folder)
    if not names:
        return None
    left = [load_gray(cv2, os.path.join(folder, n)) for n in names]
    right = [left[(i + 1) % len(left)] for i in range(len(left))]
    h, w = left[0].shape
    return (left, right, f"KITTI 07 left camera, frames {stem(names[0])}..{stem(names[-1])} ({len(names)}, {w}x{h})",
            "stereo: the next frame as the right image (timing only)")


def load_euroc(cv2, data):
    cam0 = os.path.join(data, "euroc-v101-head", "mav0", "cam0", "data")
    cam1 = os.path.join(data, "euroc-v101-head", "mav0", "cam1", "data")
    pairs = [n for n in png_names(cam0) if os.path.exists(os.path.join(cam1, n))]
    if not pairs:
        return None
    left = [load_gray(cv2, os.path.join(cam0, n)) for n in pairs]
    right = [load_gray(cv2, os.path.join(cam1, n)) for n in pairs]
    h, w = left[0].shape
    return (left, right, f"EuRoC V1_01 cam0, {len(pairs)} frames ({w}x{h})",
            "stereo: cam1 of the same time (not rectified: timing only)")


# apps/portaslam/synthetic_pair.cpp's layers: x0, y0, x1, y1, disparity, seed, brightness.
LAYERS = [
    (-1000000, -1000000, 1000000, 1000000, 6, 0x5EED0001, 0.50),
    (40, 50, 270, 230, 14, 0x5EED0002, 0.30),
    (200, 180, 420, 330, 18, 0x5EED0006, 0.55),
    (330, 70, 590, 250, 22, 0x5EED0003, 0.72),
    (90, 280, 300, 450, 30, 0x5EED0004, 0.62),
    (380, 300, 600, 440, 40, 0x5EED0005, 0.38),
]
SYNTHETIC_SIZE = (640, 480)


def lattice_value(np, ix, iy, seed):
    u = np.uint64
    with np.errstate(over="ignore"):
        z = u(seed) ^ (ix.astype(u) * u(0x9E3779B97F4A7C15)) ^ (iy.astype(u) * u(0xC2B2AE3D27D4EB4F))
        z = (z ^ (z >> u(30))) * u(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> u(27))) * u(0x94D049BB133111EB)
        z = z ^ (z >> u(31))
    return (z >> u(11)).astype(np.float64) / float(1 << 53)


def value_noise(np, x, y, seed):
    """Multi-octave value noise at integer plane coordinates, in the C++ order of operations."""
    total = np.zeros(x.shape)
    weight, amplitude, cell, octave = 0.0, 1.0, 48, 0
    while cell >= 3:
        fx, fy = (x + 0.5) / cell, (y + 0.5) / cell
        ix, iy = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
        tx, ty = fx - ix, fy - iy
        sx, sy = tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty)
        s = seed + 0x1000 * octave
        top = lattice_value(np, ix, iy, s) * (1 - sx) + lattice_value(np, ix + 1, iy, s) * sx
        bottom = lattice_value(np, ix, iy + 1, s) * (1 - sx) + lattice_value(np, ix + 1, iy + 1, s) * sx
        total = total + amplitude * (top * (1 - sy) + bottom * sy)
        weight += amplitude
        cell, octave, amplitude = cell // 2, octave + 1, amplitude * 0.6
    return total / weight


def layer_pixels(np, layer, x, y):
    v = (layer[6] + 1.7 * (value_noise(np, x, y, layer[5]) - 0.5)) * 255.0
    r = np.floor(v)
    r = r + (v - r >= 0.5)  # std::lround for v >= 0; below 0 both clamp to 0
    return np.clip(r, 0, 255).astype(np.uint8)


def covers(layer, x, y):
    return (x >= layer[0]) & (x < layer[2]) & (y >= layer[1]) & (y < layer[3])


def synthetic_pair(np):
    w, h = SYNTHETIC_SIZE
    y, x = np.mgrid[0:h, 0:w].astype(np.int64)
    left = np.zeros((h, w), np.uint8)
    right = np.zeros((h, w), np.uint8)
    for layer in LAYERS:  # back to front: a nearer plane overwrites a farther one
        mask = covers(layer, x, y)
        left[mask] = layer_pixels(np, layer, x[mask], y[mask])
    taken = np.zeros((h, w), bool)
    for layer in reversed(LAYERS):  # the right image shows the front-most plane covering x + d
        d = layer[4]
        mask = covers(layer, x + d, y) & ~taken
        right[mask] = layer_pixels(np, layer, x[mask] + d, y[mask])
        taken |= mask
    return left, right


def make_synthetic(np, why):
    left, right = synthetic_pair(np)
    h, w = left.shape
    shifts = [k * h // SYNTHETIC_VARIANTS for k in range(SYNTHETIC_VARIANTS)]
    return ([np.roll(left, -s, axis=0) for s in shifts], [np.roll(right, -s, axis=0) for s in shifts],
            f"SYNTHETIC input ({why}): the built-in {w}x{h} stereo pair in {SYNTHETIC_VARIANTS} variants with rows "
            f"rolled by k/{SYNTHETIC_VARIANTS} of the height", "stereo: its right image, rolled alike")


def fit(cv2, image, size):
    h, w = image.shape
    tw, th = size
    if (w, h) == (tw, th):
        return image, "used at their own size"
    cw, ch = w, h
    aspect = tw / th
    if w / h > aspect:
        cw = min(max(int(math.floor(h * aspect + 0.5)), 1), w)
    else:
        ch = min(max(int(math.floor(w / aspect + 0.5)), 1), h)
    x0, y0 = (w - cw) // 2, (h - ch) // 2
    shrink = cw >= tw and ch >= th
    out = cv2.resize(image[y0:y0 + ch, x0:x0 + cw], (tw, th), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)
    how = (f"centre-cropped to {cw}x{ch} (the aspect of {tw}x{th}) and resized to it "
           f"({'area' if shrink else 'bilinear'})")
    return out, how


def load_frames(cv2, np, data, size, cache):
    """(left, right, source) for one resolution, as load_bench_frames() makes them."""
    sequence = None
    if data:
        euroc_size = size == EUROC_SIZE
        loaders = [("euroc", load_euroc), ("kitti", load_kitti)] if euroc_size else \
            [("kitti", load_kitti), ("euroc", load_euroc)]
        for key, loader in loaders:
            if key not in cache:
                cache[key] = loader(cv2, data)
            if cache[key]:
                sequence = cache[key]
                break
    if sequence is None:
        why = ("no data folder found; give --data DIR or set PORTA_DATA_DIR" if not data
               else f"no KITTI or EuRoC frames in {data}")
        if "synthetic" not in cache:
            cache["synthetic"] = make_synthetic(np, why)
        sequence = cache["synthetic"]
    left_in, right_in, description, pairing = sequence
    left, right, how = [], [], ""
    for l_img, r_img in zip(left_in, right_in):
        fitted, how = fit(cv2, l_img, size)
        left.append(np.ascontiguousarray(fitted))
        fitted, how = fit(cv2, r_img, size)
        right.append(np.ascontiguousarray(fitted))
    return left, right, f"{description}, {how}; {pairing}"


# ---- Timing ---------------------------------------------------------------------------------------

def percentile(sorted_us, p):
    rank = p / 100.0 * (len(sorted_us) - 1)
    lo = int(rank)
    hi = min(lo + 1, len(sorted_us) - 1)
    return sorted_us[lo] + (rank - lo) * (sorted_us[hi] - sorted_us[lo])


def time_cell(cv2, left, right, levels, mode, nfeatures, frames, warmup):
    orb = cv2.ORB_create(nfeatures=nfeatures, scaleFactor=SCALE_FACTOR, nlevels=levels, edgeThreshold=31,
                         firstLevel=0, WTA_K=2, scoreType=cv2.ORB_HARRIS_SCORE, patchSize=31,
                         fastThreshold=FAST_THRESHOLD)
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True)
    clock = time.perf_counter
    us, keypoints, matches = [], 0.0, 0.0
    for i in range(warmup + frames):
        l_img = left[i % len(left)]
        r_img = right[i % len(right)]
        m = []
        if mode == "detect":
            t0 = clock()
            kl = orb.detect(l_img, None)
            t = clock() - t0
            kr = None
        elif mode == "extract":
            t0 = clock()
            kl, _ = orb.detectAndCompute(l_img, None)
            t = clock() - t0
            kr = None
        else:
            t0 = clock()
            kl, dl = orb.detectAndCompute(l_img, None)
            kr, dr = orb.detectAndCompute(r_img, None)
            if dl is not None and dr is not None and len(dl) and len(dr):
                m = matcher.match(dl, dr)
            t = clock() - t0
        if i >= warmup:
            us.append(t * 1e6)
            keypoints += (len(kl) + len(kr)) / 2.0 if kr is not None else len(kl)
            matches += len(m)
    us.sort()
    return us, keypoints / frames, matches / frames


def median_us(call, repeats):
    clock = time.perf_counter
    samples = []
    for _ in range(repeats):
        t0 = clock()
        call()
        samples.append((clock() - t0) * 1e6)
    samples.sort()
    return percentile(samples, 50)


def python_call_overhead_us(cv2):
    """A perf_counter pair around a trivial cv2 call: the fixed part of Python's share of each time."""
    orb = cv2.ORB_create()
    return median_us(orb.getMaxFeatures, 2000)


class ResultOverhead:
    """Python's share that grows with the result: every keypoint (and match) comes back as a new
    Python object. Measured as cv2.KeyPoint_convert(N x 2 array), which builds N cv2.KeyPoint objects
    from C++ and nothing else; DMatch objects are counted at the same cost each."""

    def __init__(self, cv2, np, call_us):
        self.cv2, self.np, self.call_us, self.cache = cv2, np, call_us, {0: 0.0}

    def objects_us(self, n):
        n = int(round(n))
        if n not in self.cache:
            points = self.np.zeros((n, 2), self.np.float32)
            self.cache[n] = median_us(lambda: self.cv2.KeyPoint_convert(points), 31)
        return self.cache[n]

    def of_row(self, mode, keypoints, matches):
        if mode == "stereo":  # two detectAndCompute calls and a match call
            return 3 * self.call_us + 2 * self.objects_us(keypoints) + self.objects_us(matches)
        return self.call_us + self.objects_us(keypoints)


# ---- Context --------------------------------------------------------------------------------------

def first_line(command):
    try:
        out = subprocess.run(command, capture_output=True, text=True, check=False, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.splitlines()[0].strip() if out.strip() else ""


def proc_value(path, key):
    try:
        with open(path, encoding="utf-8") as f:
            for line in f:
                if line.startswith(key) and ":" in line:
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return ""


def machine():
    memory_kib = proc_value("/proc/meminfo", "MemTotal").split()
    return {"cpu_model": proc_value("/proc/cpuinfo", "model name") or platform.processor() or "unknown",
            "hardware_threads": os.cpu_count() or 0,
            "memory_gib": round(float(memory_kib[0]) / (1024 * 1024), 1) if memory_kib else 0.0}


def commit():
    c = first_line(["git", "-C", REPO, "rev-parse", "--short", "HEAD"]) or "unknown"
    modified = bool(first_line(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"]))
    return c, modified


# ---- Output ---------------------------------------------------------------------------------------

def result_row(w, h, levels, mode, nfeatures, us, keypoints, matches, overhead_us):
    median = percentile(us, 50)
    row = {"backend": PEER_NAME, "resolution": f"{w}x{h}", "width": w, "height": h, "levels": levels, "mode": mode,
           "frames": len(us), "median_us": median, "p10_us": percentile(us, 10), "p90_us": percentile(us, 90),
           "min_us": us[0], "max_us": us[-1], "frames_per_s": 1e6 / median, "mean_keypoints": keypoints}
    if mode == "stereo":
        row["mean_matches"] = matches
    row["nfeatures"] = nfeatures
    row["python_overhead_us"] = overhead_us  # estimated; included in the times above
    return row


def print_rows(rows):
    print(f"\n{'backend':<17} {'resolution':<10} {'levels':>6}  {'mode':<7} {'median_us':>10} {'p10_us':>10} "
          f"{'p90_us':>10} {'frames/s':>9} {'keypoints':>9} {'matches':>8} {'nfeatures':>9} {'python_us':>9}")
    for r in rows:
        matches = f"{r['mean_matches']:.0f}" if "mean_matches" in r else "-"
        print(f"{r['backend']:<17} {r['resolution']:<10} {r['levels']:>6}  {r['mode']:<7} {r['median_us']:>10.0f} "
              f"{r['p10_us']:>10.0f} {r['p90_us']:>10.0f} {r['frames_per_s']:>9.1f} {r['mean_keypoints']:>9.0f} "
              f"{matches:>8} {r['nfeatures']:>9} {r['python_overhead_us']:>9.0f}")
    print("python_us = estimated Python overhead per frame (call + building the result's Python objects), "
          "inside median_us")


def ratios(ours, peer_rows):
    """One entry per row of ours with a peer row for its cell: peer median / our median."""
    by_cell = {(r["resolution"], r["levels"], r["mode"]): r for r in peer_rows}
    out = []
    for row in ours["results"]:
        peer = by_cell.get((row["resolution"], row["levels"], row["mode"]))
        if peer is None or "error" in row or row["backend"] in ("opencv-orb", PEER_NAME):
            continue
        net = peer["median_us"] - peer.get("python_overhead_us", 0.0)
        in_flight = row.get("in_flight", 1)  # > 1: our throughput with that many frames in flight
        label = row["backend"] + (f"/{in_flight}" if in_flight > 1 else "") + \
            ("+pin" if row.get("input") == "pinned" else "")
        out.append({"backend": label, "in_flight": in_flight, "resolution": row["resolution"], "levels": row["levels"],
                    "mode": row["mode"], "median_us": row["median_us"], "peer_median_us": peer["median_us"],
                    "speedup_vs_peer": peer["median_us"] / row["median_us"],
                    "peer_median_us_without_python": net, "speedup_vs_peer_without_python": net / row["median_us"]})
    return out


def print_ratios(entries, ours_path):
    if not entries:
        print(f"\nno ratios: no finished row of {ours_path} has a cell the peer timed")
        return
    print(f"\nspeedup = {PEER_NAME} median / our median (> 1: ours is faster); ours from {ours_path};\n"
          f"net = the same with the peer's estimated Python overhead taken out (the fairer comparison)")
    print(f"{'backend':<10} {'resolution':<10} {'levels':>6}  {'mode':<7} {'ours_us':>10} {'peer_us':>10} {'speedup':>9} "
          f"{'peer_net_us':>11} {'net':>9}")
    for e in entries:
        print(f"{e['backend']:<10} {e['resolution']:<10} {e['levels']:>6}  {e['mode']:<7} {e['median_us']:>10.0f} "
              f"{e['peer_median_us']:>10.0f} {e['speedup_vs_peer']:>8.2f}x {e['peer_median_us_without_python']:>11.0f} "
              f"{e['speedup_vs_peer_without_python']:>8.2f}x")


def write_json(path, report):
    try:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(report, f, indent=1)
            f.write("\n")
    except OSError as e:
        raise PeerError(f"cannot write '{path}': {e.strerror}") from e
    print(f"wrote {path}")


# ---- The run --------------------------------------------------------------------------------------

def run(a):
    ours = read_json(a.ours, "--ours") if a.ours else None
    if ours:
        our_cells(ours)  # checks the file
    if a.ratios:
        peer = read_json(a.ratios, "--ratios")
        if not isinstance(peer.get("results"), list):
            raise PeerError(f"--ratios: '{a.ratios}' has no \"results\" (not an orb_peer.py --json file)")
        print_ratios(ratios(ours, peer["results"]), a.ours)
        return 0

    cv2 = import_cv2()
    import numpy as np
    if a.cv_threads is not None:
        cv2.setNumThreads(a.cv_threads)
    cells, frames, warmup = plan(a, ours)
    data, origin = locate_data_folder(a, ours)
    overhead = python_call_overhead_us(cv2)
    result_overhead = ResultOverhead(cv2, np, overhead)
    c, modified = commit()
    start = time.perf_counter()
    rows, inputs, notes, cache, frames_by_size = [], {}, [], {}, {}
    for i, (w, h, levels, mode, nfeatures) in enumerate(cells, 1):
        if (w, h) not in frames_by_size:
            frames_by_size[(w, h)] = load_frames(cv2, np, data, (w, h), cache)
            source = frames_by_size[(w, h)][2]
            inputs[f"{w}x{h}"] = source
            theirs = (ours or {}).get("settings", {}).get("inputs", {}).get(f"{w}x{h}")
            if theirs is not None and theirs != source:
                notes.append(f"input {w}x{h} differs from our run's:\n  ours: {theirs}\n  peer: {source}")
        left, right, _ = frames_by_size[(w, h)]
        t0 = time.perf_counter()
        us, keypoints, matches = time_cell(cv2, left, right, levels, mode, nfeatures, frames, warmup)
        rows.append(result_row(w, h, levels, mode, nfeatures, us, keypoints, matches,
                               result_overhead.of_row(mode, keypoints, matches)))
        print(f"[{i}/{len(cells)}] {PEER_NAME} {w}x{h:<5} levels {levels} {mode:<7} median {rows[-1]['median_us']:9.0f} us "
              f"{rows[-1]['frames_per_s']:8.1f} frames/s  ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    seconds = time.perf_counter() - start

    m = machine()
    threads = cv2.getNumThreads()
    print(f"orb_peer.py: per cell {frames} timed frames after {warmup} warm-up frames")
    print(f"machine   {m['cpu_model']}, {m['hardware_threads']} hardware threads, {m['memory_gib']} GiB; "
          f"{datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')}, commit {c}"
          f"{' (with local changes)' if modified else ''}")
    print(f"peer      {PEER_NAME}: OpenCV {cv2.__version__} (cv2) on {threads} threads "
          f"({'cv2.setNumThreads(%d)' % a.cv_threads if a.cv_threads is not None else 'OpenCV default'}), "
          f"Python {platform.python_version()}, numpy {np.__version__}")
    print(f"overhead  Python's share of each time: {overhead:.2f} us per call (perf_counter pair around a trivial "
          f"cv2 call) plus {result_overhead.objects_us(1000) / 1000:.3f} us per keypoint or match returned (a "
          f"Python object each); estimated per row as python_us")
    print(f"data      {data + ' (' + origin + ')' if data else 'none found'}")
    for size, source in inputs.items():
        print(f"input     {size:<9} {source}")
    for note in notes:
        print(f"NOTE      {note}")
    print_rows(rows)
    entries = ratios(ours, rows) if ours else []
    if ours:
        print_ratios(entries, a.ours)
    print(f"{seconds:.1f} s in all")
    if a.json:
        report = {
            "tool": "bench/orb_peer.py",
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "commit": c, "worktree_modified": modified, "seconds": seconds, "machine": m,
            "peer": {"name": PEER_NAME, "opencv_version": cv2.__version__, "opencv_threads": threads,
                     "cv_threads_option": a.cv_threads, "python_version": platform.python_version(),
                     "numpy_version": np.__version__, "python_call_overhead_us": overhead,
                     "python_us_per_returned_object": result_overhead.objects_us(1000) / 1000, "what": PEER_NOTE},
            "settings": {"frames": frames, "warmup": warmup, "nfeatures": "--nfeatures" if a.nfeatures else "ours",
                         "ours": a.ours, "ours_commit": (ours or {}).get("commit"),
                         "data": f"{data} ({origin})" if data else "none found", "inputs": inputs,
                         "input_notes": notes},
            "results": rows, "ratios": entries}
        write_json(a.json, report)
    return 0


def main(argv):
    try:
        return run(parse_args(argv))
    except PeerError as e:
        print(f"orb_peer.py: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
