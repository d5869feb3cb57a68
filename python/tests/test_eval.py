"""repeatability(), recall() and match_keypoints() on a known rotation and a zoom."""

import numpy as np
import pytest

import steernav


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
    with pytest.raises(ValueError, match="singular"):
        steernav.repeatability(a.xy, b.xy, np.zeros((3, 3)), (h, w), (h, w))
    with pytest.raises(ValueError, match="3, 3"):
        steernav.repeatability(a.xy, b.xy, np.eye(2), (h, w), (h, w))


def test_match_keypoints_on_a_quarter_turn(sample):
    det = steernav.Detector(backend="cpu")
    turned = np.ascontiguousarray(np.rot90(sample))  # (x, y) -> (y, W - 1 - x)
    a, b = det.detect(sample), det.detect(turned)
    m = steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor)
    assert len(m) == len(m.i) >= 100
    assert np.all(np.diff(m.distance) >= 0)
    w = sample.shape[1]
    p, q = a.xy[m.i], b.xy[m.j]
    expected = np.stack([p[:, 1], w - 1 - p[:, 0]], axis=1)
    correct = np.linalg.norm(q - expected, axis=1) <= 2.0
    assert correct.mean() >= 0.9
    assert m.inlier[correct].mean() >= 0.95
    assert m.model.shape == (3, 3)
    with pytest.raises(ValueError, match="verify"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, verify="affine")
    with pytest.raises(ValueError, match="ratio"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, ratio=1.5)
    with pytest.raises(ValueError, match="threshold"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, threshold=0.0)
    with pytest.raises(ValueError, match="described the same way"):
        steernav.match_keypoints(a.xy, a.descriptor, b.xy, np.ascontiguousarray(b.descriptor[:, :5]))


def test_guided_matching_adds_correct_inliers_under_a_zoom(sample):
    det = steernav.Detector(backend="cpu")
    # A half-size copy: a zoom by 2 between the views, where the ratio test over every
    # keypoint rejects many true pairs that the model's neighbourhood keeps.
    small = np.ascontiguousarray(sample[::2, ::2])
    a, b = det.detect(sample), det.detect(small)
    plain = steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor, guided=False)
    guided = steernav.match_keypoints(a.xy, a.descriptor, b.xy, b.descriptor)
    assert plain.model is not None and guided.model is not None
    assert guided.inlier.sum() >= 1.4 * plain.inlier.sum()  # 240 against 128
    # Pixel i of the copy is pixel 2i of the sample.
    p, q = a.xy[guided.i[guided.inlier]], b.xy[guided.j[guided.inlier]]
    correct = np.linalg.norm(q - p / 2.0, axis=1) <= 3.0
    assert correct.mean() >= 0.9
