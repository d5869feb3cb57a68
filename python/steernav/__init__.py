"""steernav: rotation-invariant keypoints, GIST, monocular EKF SLAM and a neural-field
navigation controller, with numpy arrays in and out.

The compiled half is ``steernav._native``, re-exported here whole; ``steernav.ray`` (a Ray Data
stage) is imported only when asked for, so Ray stays an optional extra
(``pip install ./python[ray]``)."""

from ._native import *  # noqa: F401,F403  (the whole compiled API)
from ._native import __version__  # noqa: F401


def _rebuild_detector(backend, settings):
    """What an unpickled ``Detector`` is built from: its requested backend and its settings,
    so a worker makes its own GPU context (or CPU detector) with the same configuration."""
    return Detector(backend, **settings)  # noqa: F405
