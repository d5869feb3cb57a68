"""The Python bindings against the CLI and on bad input."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import steernav

ROOT = pathlib.Path(__file__).resolve().parents[2]


def steernav_cli():
    """The CLI binary built beside the bindings (cargo build --release), or $STEERNAV_BIN."""
    exe = os.environ.get("STEERNAV_BIN") or str(ROOT / "target" / "release" / "steernav")
    if not os.path.exists(exe):
        pytest.skip(f"the steernav CLI is not built at {exe}")
    return exe


def write_ppm(path, rgb):
    """A binary PPM of RGB uint8 pixels, so the CLI reads exactly the array's pixels."""
    h, w, _ = rgb.shape
    path.write_bytes(b"P6\n%d %d\n255\n" % (w, h) + rgb.tobytes())
    return path


@pytest.fixture(scope="module")
def sample():
    return steernav.textured_scene(640, 480, 1)


@pytest.fixture(scope="module")
def sample_file(sample, tmp_path_factory):
    return write_ppm(tmp_path_factory.mktemp("img") / "scene.ppm", sample)


def test_detect_matches_the_cli(sample, sample_file):
    ours = steernav.Detector(backend="cpu").detect(sample)
    cli = subprocess.run(
        [steernav_cli(), "detect", "--backend", "cpu", str(sample_file)],
        check=True,
        capture_output=True,
        text=True,
    )
    theirs = json.loads(cli.stdout)["keypoints"]
    assert len(ours) == len(theirs) > 100
    xy = np.array([[k["x"], k["y"]] for k in theirs], np.float32)
    assert np.abs(ours.xy - xy).max() <= 1e-4
    assert np.allclose(ours.scale, [k["scale"] for k in theirs], atol=1e-4)
    assert np.allclose(ours.angle, [k["angle"] for k in theirs], atol=1e-4)
    assert np.allclose(ours.descriptor, [k["descriptor"] for k in theirs], atol=1e-4)
    assert ours.xy.dtype == np.float32 and ours.descriptor.shape == (len(ours), 128)
    assert ours.descriptor_kind == "steered"
    paper = steernav.Detector(backend="cpu", descriptor="entropy").detect(sample)
    assert paper.descriptor.shape == (len(paper), 5) and paper.descriptor_kind == "entropy"


def test_gist_matches_the_cli(sample, sample_file):
    ours = steernav.gist(sample, backend="cpu")
    cli = subprocess.run(
        [steernav_cli(), "gist", "--backend", "cpu", str(sample_file)],
        check=True,
        capture_output=True,
        text=True,
    )
    theirs = np.array(json.loads(cli.stdout)["gist"], np.float32)
    assert ours.shape == (512,)
    assert np.abs(ours - theirs).max() <= 1e-4 * np.abs(theirs).max()
    both = steernav.gist([sample, sample[::2, ::2].copy()], backend="cpu")
    assert both.shape == (2, 512) and np.allclose(both[0], ours)


def test_grey_float_and_batch_inputs(sample):
    det = steernav.Detector(backend="cpu", orientations=8, max_keypoints=100)
    grey = sample.mean(axis=2).astype(np.float32) / 255.0
    found = det.detect(grey)
    assert 0 < len(found) <= 100
    batch = det.detect_batch([sample, sample[:240, :320].copy(), grey])
    assert [len(k) for k in batch][0] == len(det.detect(sample))
    assert len(batch) == 3


def test_bad_input_raises_clear_exceptions(sample):
    with pytest.raises(ValueError, match="orientatons"):
        steernav.Detector(backend="cpu", orientatons=8)
    with pytest.raises(ValueError, match="scales"):
        steernav.Detector(backend="cpu", scales=0)
    with pytest.raises(ValueError, match="backend"):
        steernav.Detector(backend="tpu")
    det = steernav.Detector(backend="cpu")
    with pytest.raises(TypeError, match="uint8 or float32"):
        det.detect(sample.astype(np.float64))
    with pytest.raises(ValueError, match="shape"):
        det.detect(np.zeros((10, 10, 4), np.uint8))
    nan = np.full((64, 64), np.nan, np.float32)
    with pytest.raises(ValueError, match="not finite"):
        det.detect(nan)
    with pytest.raises(TypeError):
        det.detect("not an array")


def test_repeatability_and_recall_of_a_rotation(sample):
    det = steernav.Detector(backend="cpu")
    rotated = np.ascontiguousarray(np.rot90(sample))
    a, b = det.detect(sample), det.detect(rotated)
    h, w = sample.shape[:2]
    # rot90 (counter-clockwise): (x, y) -> (y, w - 1 - x).
    H = np.array([[0, 1, 0], [-1, 0, w - 1], [0, 0, 1]], np.float64)
    rep = steernav.repeatability(a.xy, b.xy, H, (h, w), rotated.shape[:2])
    assert rep > 0.8
    rec = steernav.recall(a.xy, a.descriptor, b.xy, b.descriptor, H, (h, w), rotated.shape[:2])
    assert 0.0 <= rec <= 1.0
    with pytest.raises(ValueError, match="3, 3"):
        steernav.repeatability(a.xy, b.xy, np.eye(2), (h, w), (h, w))


def test_controller_steps_towards_the_goal():
    c = steernav.Controller()
    ranges = np.full(181, 8.0, np.float32)
    for _ in range(5):
        v, omega, heading = c.step(ranges, -np.pi / 2, np.pi / 180, (0.0, 0.0, 0.0), (5.0, 0.0), 8.0)
    assert v > 0 and abs(heading) < 0.1
    assert c.field.shape == (steernav.Controller().field.shape[0],)
    ranges[3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        c.step(ranges, -np.pi / 2, np.pi / 180, (0.0, 0.0, 0.0), (5.0, 0.0))
    with pytest.raises(ValueError, match="turn_gain"):
        steernav.Controller(turn_gain=-1.0)
    with pytest.raises(ValueError, match="mode"):
        steernav.Controller(mode="sonar")


def test_fusion_controller_needs_and_uses_the_camera(sample):
    c = steernav.Controller(mode="fusion", backend="cpu", turn_gain=2.0)
    assert c.mode == "fusion"
    ranges = np.full(181, 8.0, np.float32)
    with pytest.raises(ValueError, match="camera"):
        c.step(ranges, -np.pi / 2, np.pi / 180, (0.0, 0.0, 0.0), (5.0, 0.0), 8.0)
    for _ in range(5):
        v, omega, heading = c.step(
            ranges, -np.pi / 2, np.pi / 180, (0.0, 0.0, 0.0), (5.0, 0.0), 8.0, image=sample
        )
    # An open scan and a visual model that has not seen enough to speak: straight on.
    assert v > 0 and abs(heading) < 0.1
    laser = steernav.Controller()
    with pytest.raises(ValueError, match="laser-mode"):
        laser.step(ranges, -np.pi / 2, np.pi / 180, (0.0, 0.0, 0.0), (5.0, 0.0), 8.0, image=sample)


def test_slam_reports_poses_and_a_trajectory(sample):
    h, w = sample.shape[:2]
    slam = steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, backend="cpu")
    for k in range(3):
        r = slam.process(sample, 0.1 * k)
        assert r["position"].shape == (3,) and r["covariance"].shape == (6, 6)
    assert slam.trajectory().shape == (3, 8)
    with pytest.raises(ValueError, match="max_landmarkz"):
        steernav.Slam(500.0, 500.0, 320, 240, 640, 480, max_landmarkz=3)
    with pytest.raises(ValueError):
        slam.process(sample[:100], 1.0)


def test_match_keypoints_on_a_quarter_turn(sample):
    det = steernav.Detector(backend="cpu")
    turned = np.ascontiguousarray(np.rot90(sample))  # (x, y) -> (y, W - 1 - x)
    a, b = det.detect(sample), det.detect(turned)
    m = steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor)
    assert len(m["i"]) >= 100
    w = sample.shape[1]
    p, q = a.xy[m["i"]], b.xy[m["j"]]
    expected = np.stack([p[:, 1], w - 1 - p[:, 0]], axis=1)
    correct = np.linalg.norm(q - expected, axis=1) <= 2.0
    assert correct.mean() >= 0.9
    assert m["inlier"][correct].mean() >= 0.95
    assert m["model"].shape == (3, 3)
    with pytest.raises(ValueError, match="verify"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, verify="affine")
    with pytest.raises(ValueError, match="ratio"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, ratio=1.5)
    with pytest.raises(ValueError, match="threshold"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, threshold=0.0)
    with pytest.raises(ValueError, match="described the same way"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, np.ascontiguousarray(b.descriptor[:, :5]))
