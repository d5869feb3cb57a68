"""Fixtures shared by the binding tests: the generated sample scene, the same pixels as a PPM
file, and the CLI built beside the bindings."""

import os
import pathlib

import pytest

import steernav

ROOT = pathlib.Path(__file__).resolve().parents[2]


def write_ppm(path, rgb):
    """A binary PPM of RGB uint8 pixels, so the CLI reads exactly the array's pixels."""
    h, w, _ = rgb.shape
    path.write_bytes(b"P6\n%d %d\n255\n" % (w, h) + rgb.tobytes())
    return path


@pytest.fixture(scope="session")
def cli_exe():
    """The CLI binary built beside the bindings (cargo build --release), or $STEERNAV_BIN."""
    exe = os.environ.get("STEERNAV_BIN") or str(ROOT / "target" / "release" / "steernav")
    if not os.path.exists(exe):
        pytest.skip(f"the steernav CLI is not built at {exe}")
    return exe


@pytest.fixture(scope="session")
def sample():
    return steernav.textured_scene(640, 480, 1)


@pytest.fixture(scope="session")
def sample_file(sample, tmp_path_factory):
    return write_ppm(tmp_path_factory.mktemp("img") / "scene.ppm", sample)
