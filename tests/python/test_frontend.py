"""portaslam.Frontend: the same bytes as the C++ Frontend, on every backend present; the arrays'
layout; errors with the CLI's messages; the GIL released while the engine works."""
import threading

import numpy as np
import pytest

import portaslam
from conftest import run


def load_pair(sequence, index=0):
    left, right, _ = portaslam.open_dataset("kitti", str(sequence))[index]
    return left, right


def test_backends_lists_the_four_and_cpu_runs():
    infos = {b["name"]: b for b in portaslam.backends()}
    assert list(infos) == ["cpu", "cuda", "vulkan", "opencl"]
    assert infos["cpu"]["compiled"] and infos["cpu"]["available"]
    for info in infos.values():
        assert isinstance(info["detail"], str) and info["detail"]


def test_arrays_have_the_engines_layout(sequence):
    left, right = load_pair(sequence)
    frontend = portaslam.Frontend(left.shape[1], left.shape[0])
    pair = frontend.detect_stereo(left, right)
    kp = pair.left.keypoints
    assert kp.dtype == portaslam.KEYPOINT_DTYPE and kp.dtype.itemsize == 8
    assert kp.dtype.names == ("x", "y", "response", "level", "angle_bin")
    assert pair.left.descriptors.shape == (len(kp), 32) and pair.left.descriptors.dtype == np.uint8
    assert pair.matches.dtype.names == ("disparity_q8", "right_index") and len(pair.matches) == len(kp)
    assert pair.num_matches == int((pair.matches["right_index"] >= 0).sum()) > 100
    assert sum(pair.left.keypoints_per_level) == len(kp)
    # Canonical order: by level; level-0 positions are the level's positions times its scale.
    assert np.all(np.diff(kp["level"].astype(int)) >= 0)
    scale = 1.2 ** kp["level"].astype(float)
    assert np.allclose(pair.left.level0[:, 0], kp["x"] * scale, atol=1e-3 * kp["x"].max())
    assert np.all(kp["response"] > 0)


def compare_with_cpp(frontend_call, sequence, work, backend):
    stdout, _ = run(frontend_call, sequence / "image_0" / "000000.png", sequence / "image_1" / "000000.png",
                    "--dump", work)
    left, right = load_pair(sequence)
    pair = portaslam.Frontend(left.shape[1], left.shape[0], backend=backend).detect_stereo(left, right)
    for name, array in [("left_keypoints", pair.left.keypoints), ("left_descriptors", pair.left.descriptors),
                        ("right_keypoints", pair.right.keypoints), ("right_descriptors", pair.right.descriptors),
                        ("matches", pair.matches)]:
        expected = (work / f"{name}.bin").read_bytes()
        assert len(expected) > 1000, name
        assert array.tobytes() == expected, f"{backend}: {name} differs from the C++ Frontend on cpu"
    assert f"keypoints {len(pair.left)} {len(pair.right)} matches {pair.num_matches}" in stdout


def test_same_bytes_as_the_cpp_frontend_on_cpu(frontend_call, sequence, work):
    compare_with_cpp(frontend_call, sequence, work, "cpu")


@pytest.mark.parametrize("backend", ["cuda", "vulkan", "opencl"])
def test_every_available_backend_gives_the_cpu_bytes(frontend_call, sequence, work, backend):
    info = {b["name"]: b for b in portaslam.backends()}[backend]
    if not info["available"]:
        # Not a skip into green: ci/test.sh requires vulkan and opencl through the C++ equivalence
        # suite; here an unavailable backend must refuse with a BackendError naming it.
        with pytest.raises(portaslam.BackendError, match=backend):
            portaslam.Frontend(64, 64, backend=backend)
        return
    compare_with_cpp(frontend_call, sequence, work, backend)


def test_a_cropped_view_with_a_row_stride_is_accepted(sequence):
    left, _ = load_pair(sequence)
    crop = left[:, 100:900]  # rows 1242 bytes apart, 800 wide: no copy needed
    frontend = portaslam.Frontend(800, left.shape[0])
    assert frontend.detect(crop).keypoints.tobytes() == frontend.detect(np.ascontiguousarray(crop)).keypoints.tobytes()


def test_wrong_images_raise_clear_errors():
    frontend = portaslam.Frontend(320, 240)
    with pytest.raises(TypeError, match=r"expected a 2-D uint8 array .* got float64 with shape \(240, 320\)"):
        frontend.detect(np.zeros((240, 320)))
    with pytest.raises(TypeError, match="convert colour images to gray"):
        frontend.detect(np.zeros((240, 320, 3), np.uint8))
    with pytest.raises(TypeError, match="rows must be contiguous"):
        frontend.detect(np.zeros((240, 640), np.uint8)[:, ::2])
    with pytest.raises(ValueError, match="input image is 320x100 but this frontend was built for 320x240"):
        frontend.detect(np.zeros((100, 320), np.uint8))
    with pytest.raises(ValueError, match="right image"):
        frontend.detect_stereo(np.zeros((240, 320), np.uint8), np.zeros((240, 300), np.uint8))


def test_errors_carry_the_messages_the_cli_prints(portaslam_bin):
    with pytest.raises(portaslam.BackendError) as backend_error:
        portaslam.Frontend(640, 480, backend="nosuch")
    _, stderr = run(portaslam_bin, "features", "--backend", "nosuch", expect=1)
    assert str(backend_error.value) in stderr

    settings = portaslam.FrontendSettings()
    settings.levels = 13
    with pytest.raises(portaslam.SettingsError) as settings_error:
        portaslam.Frontend(640, 480, settings=settings)
    assert isinstance(settings_error.value, ValueError)
    assert "levels = 13: allowed [1, 12]" in str(settings_error.value)
    _, stderr = run(portaslam_bin, "features", "--levels", "13", expect=1)
    assert str(settings_error.value) in stderr


def test_the_gil_is_released_while_features_are_computed():
    # One long call on a worker thread: while it runs inside the engine, this thread must run too.
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (2400, 3200), dtype=np.uint8)
    frontend = portaslam.Frontend(3200, 2400, threads=1)
    inside = threading.Event()
    done = threading.Event()

    def work():
        inside.set()
        frontend.detect(image)
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    inside.wait()
    spins = 0
    while not done.is_set():
        spins += 1
    worker.join()
    assert spins > 1000, f"the main thread ran {spins} times while detect() ran: the GIL was held"
