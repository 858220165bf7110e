"""What every Python test needs: the rendered sequence, the programs it compares against, a work
folder. ctest sets the environment (tests/CMakeLists.txt, "The Python module"); ci/python-package.sh
sets it for the pip-installed package. A missing variable is a failure, not a skip."""
import os
import pathlib
import shutil
import subprocess

import pytest


def _required(name):
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"the environment variable {name} is not set (run these tests through ctest -L python)")
    return value


@pytest.fixture(scope="session")
def sequence():
    """A KITTI-layout street-loop of 30 frames at 1242x375, with ground truth."""
    path = pathlib.Path(_required("PORTA_TEST_SEQUENCE"))
    if not (path / "image_0" / "000000.png").is_file():
        pytest.fail(f"{path} holds no rendered sequence (ctest's python.render_sequence makes it)")
    return path


@pytest.fixture(scope="session")
def portaslam_bin():
    return _required("PORTASLAM_BIN")


@pytest.fixture(scope="session")
def frontend_call():
    return _required("PORTA_FRONTEND_CALL")


@pytest.fixture(scope="session")
def source_dir():
    return pathlib.Path(_required("PORTA_SOURCE_DIR"))


@pytest.fixture()
def work(request):
    """A fresh folder per test, under PORTA_TEST_WORK."""
    path = pathlib.Path(_required("PORTA_TEST_WORK")) / request.node.name
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True)
    return path


def run(*args, expect=0, cwd=None):
    """Runs a program; returns (stdout, stderr); fails the test on another exit status."""
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True, cwd=cwd, timeout=600)
    assert done.returncode == expect, f"{args}: exit {done.returncode}, expected {expect}\n{done.stdout}{done.stderr}"
    return done.stdout, done.stderr
