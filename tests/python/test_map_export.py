"""`portaslam run --export-map` read back by a third-party PLY parser (plyfile, from PyPI).

Renders a short street sequence, runs SLAM on it with --export-map, and reads the PLY with plyfile:
binary little-endian, one `vertex` element with float x, y, z and uchar red, green, blue, as many
vertices as summary.json reports (map points + keyframe centres), every coordinate finite, the
keyframe centres last in magenta.

The program comes from the environment variable PORTASLAM_BIN (the test fails when it is unset).
Needs: pytest, numpy, plyfile.
"""

import json
import os
import subprocess

import numpy as np
import pytest
from plyfile import PlyData

FRAMES = 20


def portaslam_bin():
    path = os.environ.get("PORTASLAM_BIN")
    if not path:
        pytest.fail("PORTASLAM_BIN is not set: point it at the portaslam program (e.g. build/apps/portaslam)")
    if not os.access(path, os.X_OK):
        pytest.fail(f"PORTASLAM_BIN={path} is not an executable file")
    return path


def run(*args, cwd):
    result = subprocess.run([portaslam_bin(), *args], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"portaslam {' '.join(args)}: exit {result.returncode}\n{result.stdout}{result.stderr}"
    return result.stdout


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    work = tmp_path_factory.mktemp("map_export")
    run("render", "--count", str(FRAMES), "--out", "seq", "--quiet", cwd=work)
    stdout = run("run", "--dataset", "kitti", "seq", "--mode", "deterministic", "--out", "run",
                 "--export-map", "run/map.ply", "--quiet", cwd=work)
    with open(work / "run" / "summary.json") as f:
        summary = json.load(f)
    return {"ply": PlyData.read(str(work / "run" / "map.ply")), "summary": summary, "stdout": stdout,
            "work": work}


def test_layout_is_binary_little_endian_with_plain_vertex_properties(exported):
    ply = exported["ply"]
    assert not ply.text
    assert ply.byte_order == "<"
    assert [e.name for e in ply.elements] == ["vertex"]
    vertex = ply["vertex"]
    assert [p.name for p in vertex.properties] == ["x", "y", "z", "red", "green", "blue"]
    assert vertex.data.dtype["x"] == np.dtype("<f4")
    assert vertex.data.dtype["red"] == np.dtype("u1")


def test_vertex_count_is_the_one_the_summary_reports(exported):
    ply, summary = exported["ply"], exported["summary"]
    export = summary["map_export"]
    assert summary["frames"] == FRAMES and summary["tracked"] == FRAMES
    assert ply["vertex"].count == export["vertices"]
    assert export["vertices"] == export["map_points"] + export["keyframe_centres"]
    assert export["map_points"] == summary["map_points"] > 0
    assert export["keyframe_centres"] == summary["keyframes"] > 0
    assert f"{export['vertices']} vertices ({export['map_points']} map points + " in exported["stdout"]


def test_coordinates_are_finite_and_in_front_of_the_cameras(exported):
    v = exported["ply"]["vertex"].data
    xyz = np.stack([v["x"], v["y"], v["z"]], axis=1)
    assert np.isfinite(xyz).all()
    # The street lies ahead of the first camera (z forward), within the renderer's world.
    assert np.median(xyz[:, 2]) > 0
    assert np.abs(xyz).max() < 1e4


def test_keyframe_centres_are_the_last_vertices_in_magenta(exported):
    v = exported["ply"]["vertex"].data
    cameras = exported["summary"]["map_export"]["keyframe_centres"]
    rgb = np.stack([v["red"], v["green"], v["blue"]], axis=1)
    assert (rgb[-cameras:] == [255, 0, 255]).all()
    assert not (rgb[:-cameras] == [255, 0, 255]).all(axis=1).any()
    # The first keyframe is the first camera, at the origin of the map's frame.
    first = np.array([v["x"][-cameras], v["y"][-cameras], v["z"][-cameras]])
    assert np.abs(first).max() < 1e-6


def test_top_view_picture_is_written(exported):
    top = exported["work"] / "run" / "map_top.png"
    assert exported["summary"]["top_view"] == "run/map_top.png"
    with open(top, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
