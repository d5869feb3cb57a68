"""Controller: laser and fusion modes."""

import numpy as np
import pytest

import steernav


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


def test_controller_refuses_pickling_saying_why():
    import pickle

    with pytest.raises(TypeError, match="cannot pickle 'steernav.Controller': its neural field"):
        pickle.dumps(steernav.Controller())
