"""portaslam.System, the dataset reader and the evaluation: the same trajectory as `portaslam run`
to the byte, accurate against the rendered ground truth, and errors with the CLI's messages."""
import numpy as np
import pytest

import portaslam
from conftest import run


def run_system(sequence, mode="deterministic", **kwargs):
    dataset = portaslam.open_dataset("kitti", str(sequence))
    system = portaslam.System(portaslam.SlamSettings(dataset.camera), mode=mode, **kwargs)
    results = []
    for i in range(len(dataset)):
        left, right, time_s = dataset[i]
        results.append(system.process(left, right, time_s))
    system.finish()
    return dataset, system, results


def test_the_dataset_reader(sequence):
    dataset = portaslam.open_dataset("kitti", str(sequence))
    assert len(dataset) == 30
    camera = dataset.camera
    assert (camera.width, camera.height) == (1242, 375) and camera.baseline_m > 0
    left, right, time_s = dataset[-1]
    assert left.shape == right.shape == (375, 1242) and left.dtype == np.uint8
    assert time_s == pytest.approx(2.9)
    assert len(dataset.ground_truth) == 30
    with pytest.raises(IndexError):
        dataset[30]


def test_deterministic_slam_equals_the_cli_byte_for_byte(sequence, portaslam_bin, work):
    dataset, system, results = run_system(sequence)
    assert all(r["tracked"] for r in results), [r["lost_reason"] for r in results if not r["tracked"]]
    assert results[0]["keyframe"] and system.num_keyframes >= 2 and system.num_points > 1000
    trajectory = system.trajectory()
    assert len(trajectory) == 30 and trajectory.poses.shape == (30, 4, 4)
    trajectory.write(str(work / "python_tum.txt"), "tum")

    run(portaslam_bin, "run", "--dataset", "kitti", sequence, "--mode", "deterministic", "--out", work / "cli",
        "--quiet")
    assert (work / "python_tum.txt").read_bytes() == (work / "cli" / "trajectory_tum.txt").read_bytes()

    # process() returns T_world_cam, as the trajectory holds it (which local BA may since have moved
    # by millimetres; the inverse, T_cam_world, would be 23 m off at the end of these 30 frames).
    assert np.allclose(results[-1]["pose"], trajectory.poses[-1], atol=0.01)

    metrics = portaslam.evaluate(dataset.ground_truth, trajectory)
    assert metrics["pairs"] == 30
    assert metrics["ate_m"]["rmse"] < 0.05


def test_realtime_mode_tracks_every_frame(sequence):
    _, system, results = run_system(sequence, mode="realtime", paced=False)
    assert sum(r["tracked"] for r in results) == 30
    assert len(system.trajectory()) == 30


def test_map_save_and_localisation_on_it(sequence, work):
    _, system, _ = run_system(sequence)
    path = str(work / "map.pmap")
    system.save_map(path)
    dataset = portaslam.open_dataset("kitti", str(sequence))
    settings = portaslam.SlamSettings(dataset.camera)
    settings.localization_only = True
    localiser = portaslam.System(settings)
    localiser.load_map(path)
    keyframes = localiser.num_keyframes
    assert keyframes == system.num_keyframes
    for i in (0, 1, 2):
        left, right, time_s = dataset[i]
        assert localiser.process(left, right, time_s)["tracked"]
    assert localiser.num_keyframes == keyframes


def test_trajectories_round_trip_through_arrays_and_files(work):
    poses = np.stack([np.eye(4)] * 3)
    poses[:, 0, 3] = [0.0, 1.0, 3.0]
    trajectory = portaslam.Trajectory(np.array([0.0, 0.1, 0.2]), poses)
    assert trajectory.path_length_m() == pytest.approx(3.0)
    trajectory.write(str(work / "t.txt"), "tum")
    again = portaslam.Trajectory.read(str(work / "t.txt"))
    assert np.allclose(again.poses, poses) and np.allclose(again.times, [0.0, 0.1, 0.2])
    bad = poses.copy()
    bad[1, :3, :3] *= 2.0
    with pytest.raises(ValueError, match="rigid"):
        portaslam.Trajectory(np.array([0.0, 0.1, 0.2]), bad)
    with pytest.raises(ValueError, match=r"\(N, 4, 4\)"):
        portaslam.Trajectory(np.zeros(2), poses)


def test_errors_carry_the_messages_the_cli_prints(portaslam_bin, work):
    missing = str(work / "no_such_sequence")
    with pytest.raises(portaslam.DatasetError) as error:
        portaslam.open_dataset("kitti", missing)
    _, stderr = run(portaslam_bin, "run", "--dataset", "kitti", missing, "--out", work / "out", expect=1)
    assert str(error.value) in stderr and "no_such_sequence" in str(error.value)

    (work / "broken.pmap").write_bytes(b"PMAP but not really a map file")
    with pytest.raises(portaslam.MapFileError) as map_error:
        system = portaslam.System(portaslam.SlamSettings(portaslam.StereoCamera(640, 480, 500, 500, 320, 240, 0.1)))
        system.load_map(str(work / "broken.pmap"))
    _, stderr = run(portaslam_bin, "map", "info", work / "broken.pmap", expect=1)
    assert str(map_error.value) in stderr

    with pytest.raises(ValueError, match="baseline"):
        portaslam.StereoCamera(640, 480, 500, 500, 320, 240, 0.0)
    with pytest.raises(ValueError, match="unknown mode 'fast'"):
        portaslam.System(portaslam.SlamSettings(portaslam.StereoCamera(640, 480, 500, 500, 320, 240, 0.1)),
                         mode="fast")
    with pytest.raises(ValueError, match="unknown dataset kind 'tum'"):
        portaslam.open_dataset("tum", missing)


def test_the_example_script_prints_the_ate(sequence, source_dir, tmp_path):
    import subprocess
    import sys
    # The script writes trajectory_tum.txt into its working folder: a fresh one, not the checkout.
    done = subprocess.run([sys.executable, str(source_dir / "examples" / "python" / "run_slam.py"), str(sequence)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "30 of 30 frames tracked" in done.stdout
    ate = float(done.stdout.split("ATE RMSE ")[1].split()[0])
    assert ate < 0.05
    assert (tmp_path / "trajectory_tum.txt").stat().st_size > 0
