#!/usr/bin/env python3
"""bench/backend_table.py on hand-made bench runs: medians over runs, the statistic per cell (the
median one frame at a time, the mean with frames in flight), the ratios, the targets' verdicts, and
bad input refused by name (ctest cli.backend_table)."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "bench" / "backend_table.py"


def row(backend, in_flight, source, median, mean):
    return {"backend": backend, "resolution": "752x480", "width": 752, "height": 480, "levels": 8,
            "mode": "detect", "in_flight": in_flight, "input": source, "frames": 200, "median_us": median,
            "mean_us": mean}


class BackendTable(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.path = Path(self.dir.name)

    def tearDown(self):
        self.dir.cleanup()

    def write(self, name, content):
        path = self.path / name
        path.write_text(content if isinstance(content, str) else json.dumps(content))
        return str(path)

    def run_table(self, *args):
        return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True)

    def runs(self):
        # One frame at a time (copied input) the median counts, with 4 in flight (pinned) the mean:
        # each row's other statistic is set far off, so that reading the wrong one fails the test.
        a = {"results": [row("cpu", 1, "copy", 500, 9000), row("cuda", 1, "copy", 100, 9000),
                         row("vulkan", 1, "copy", 140, 1), row("opencl", 1, "copy", 520, 1),
                         row("cuda", 4, "pinned", 1, 30), row("vulkan", 4, "pinned", 1, 50),
                         row("opencl", 4, "pinned", 9000, 40)]}
        b = {"results": [row("cpu", 1, "copy", 520, 1), row("cuda", 1, "copy", 120, 1),
                         row("vulkan", 1, "copy", 160, 9000), row("opencl", 1, "copy", 540, 9000),
                         row("cuda", 4, "pinned", 9000, 34), row("vulkan", 4, "pinned", 9000, 52)]}
        c = {"results": [row("opencl", 4, "pinned", 1, 44), row("opencl", 4, "pinned", 1, 42)]}
        return [self.write("a.json", a), self.write("b.json", b), self.write("c.json", c)]

    def test_medians_ratios_and_verdicts(self):
        result = self.run_table("--within", "vulkan=1.5", "--within", "opencl=2", "--faster-than", "cpu",
                                *self.runs())
        self.assertEqual(result.returncode, 0, result.stderr)
        lines = result.stdout.splitlines()
        self.assertEqual(lines[0], "| cell | runs | cpu | cuda | vulkan | opencl | vulkan / cuda | opencl / cuda | "
                                   "vulkan / cpu | opencl / cpu |")
        # medians: cpu 510, cuda 110, vulkan 150, opencl 530 (two runs each).
        self.assertIn("| 752x480/8 detect | 2 | 510 (500-520) | 110 (100-120) | 150 (140-160) | 530 (520-540) | "
                      "**1.36x** | 4.82x | **0.29x** | 1.04x |", lines)
        # means with 4 in flight: cuda 32, vulkan 51, opencl 41 of a.json's 40 and c.json's 42 (its
        # second row of the same cell replaces its first, 44).
        self.assertIn("| 752x480/8 detect /4+pin | 2 |  | 32 (30-34) | 51 (50-52) | 41 (40-42) | 1.59x | **1.28x** |  "
                      "|  |", lines)
        self.assertIn("- vulkan ≤ 1.5x cuda: held in 1 of 2 cells; not in 752x480/8 detect /4+pin 1.59x", lines)
        self.assertIn("- opencl ≤ 2x cuda: held in 1 of 2 cells; not in 752x480/8 detect 4.82x", lines)
        self.assertIn("- every backend but cuda faster than cpu: held in 0 of 1 cells; not in 752x480/8 detect "
                      "(opencl 1.04x)", lines)

    def test_one_run_prints_no_range(self):
        result = self.run_table(self.runs()[0])
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn("| 752x480/8 detect | 1 | 500 | 100 | 140 | 520 |", result.stdout)

    def test_bad_input_is_refused_by_name(self):
        good = self.runs()[0]
        cases = [
            ([self.write("cut.json", '{"results": [')], "cut.json: not a portaslam bench JSON (JSONDecodeError"),
            ([str(self.path / "none.json")], "none.json: cannot read it (No such file or directory)"),
            ([self.write("other.json", {"stages_ms": {}})], "other.json: not a portaslam bench JSON (no 'results' list)"),
            ([self.write("short.json", {"results": [{"backend": "cuda"}]})],
             "short.json: result 0 lacks a field of a bench row (KeyError"),
            ([self.write("empty.json", {"results": []})], "no bench rows in "),
            (["--within", "vulkan", good], "--within 'vulkan': expected BACKEND=RATIO"),
            (["--within", "vulkan=x", good], "--within 'vulkan=x': expected BACKEND=RATIO"),
            (["--within", "vulkan=-1", good], "--within 'vulkan=-1': expected BACKEND=RATIO"),
        ]
        for args, message in cases:
            with self.subTest(message=message):
                result = self.run_table(*args)
                self.assertEqual(result.returncode, 2, result.stdout)
                self.assertTrue(result.stderr.startswith("backend_table.py: "), result.stderr)
                self.assertIn(message, result.stderr)
                self.assertEqual(result.stdout, "")


if __name__ == "__main__":
    unittest.main()
