"""Slam and its FrameReport."""

import numpy as np
import pytest

import steernav


def test_slam_reports_poses_and_a_trajectory(sample):
    h, w = sample.shape[:2]
    slam = steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, backend="cpu")
    reports = [slam.process(sample, 0.1 * k) for k in range(3)]
    for k, r in enumerate(reports):
        assert isinstance(r, steernav.FrameReport)
        assert r.timestamp == pytest.approx(0.1 * k)
        assert r.position.shape == (3,) and r.covariance.shape == (6, 6)
        # The same frame three times: no parallax, so the filter waits at the start pose.
        assert r.initialising and not r.lost
        assert np.array_equal(r.position, [0.0, 0.0, 0.0])
        assert np.array_equal(r.quaternion, [0.0, 0.0, 0.0, 1.0])
        assert np.allclose(r.covariance, r.covariance.T)
    trajectory = slam.trajectory()
    assert trajectory.shape == (3, 8)
    assert np.allclose(trajectory[:, 0], [0.0, 0.1, 0.2])
    assert np.array_equal(trajectory[:, 7], [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="max_landmarkz"):
        steernav.Slam(500.0, 500.0, 320, 240, 640, 480, max_landmarkz=3)
    with pytest.raises(ValueError, match="moved to `slam.map.max_landmarks`"):
        steernav.Slam(500.0, 500.0, 320, 240, 640, 480, max_landmarks=3)
    with pytest.raises(ValueError):
        slam.process(sample[:100], 1.0)
    with pytest.raises(ValueError, match="must increase"):
        slam.process(sample, 0.1)


def test_slam_takes_detector_and_nested_slam_settings(sample):
    h, w = sample.shape[:2]
    slam = steernav.Slam(
        500.0, 500.0, w / 2, h / 2, w, h, backend="cpu",
        detector={"max_keypoints": 50}, map={"max_landmarks": 40, "target_visible": 20},
    )
    assert slam.process(sample, 0.0).landmarks == 0
    with pytest.raises(ValueError, match="orientationz"):
        steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, detector={"orientationz": 3})
    with pytest.raises(ValueError, match="max_landmarks"):
        steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, map={"max_landmarks": 5, "target_visible": 20})


def test_slam_takes_the_wheeled_motion_model_and_names_its_bad_keys(sample):
    h, w = sample.shape[:2]
    slam = steernav.Slam(
        500.0, 500.0, w / 2, h / 2, w, h, backend="cpu", motion={"wheeled": {"slip": 0.02}},
    )
    reports = [slam.process(sample, 0.1 * k) for k in range(2)]
    assert all(r.initialising and not r.lost for r in reports)
    with pytest.raises(ValueError, match="unknown field `arm`"):
        steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, motion={"wheeled": {"arm": 0.1}})
    with pytest.raises(ValueError, match="slam.motion.wheeled.slip"):
        steernav.Slam(500.0, 500.0, w / 2, h / 2, w, h, motion={"wheeled": {"slip": -1.0}})


def test_slam_refuses_pickling_saying_why():
    import pickle

    slam = steernav.Slam(500.0, 500.0, 320, 240, 640, 480, backend="cpu")
    with pytest.raises(TypeError, match="cannot pickle 'steernav.Slam': it holds a running filter"):
        pickle.dumps(slam)


def test_bad_camera_arguments_are_named():
    with pytest.raises(ValueError, match="width = -96: must be a positive whole number"):
        steernav.Slam(500.0, 500.0, 320, 240, -96, 480)
    with pytest.raises(ValueError, match="camera.fx = 1e-300.*170°"):
        steernav.Slam(1e-300, 500.0, 320, 240, 640, 480)
