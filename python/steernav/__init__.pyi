"""steernav: rotation-invariant keypoints, GIST, monocular EKF SLAM and a neural-field
navigation controller, with numpy arrays in and out (type stub)."""

from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

Image = Union[npt.NDArray[np.uint8], npt.NDArray[np.float32]]
"""(H, W) or (H, W, 3) RGB; uint8, or float32 with values in [0, 1]."""

class Keypoints:
    """Keypoints of one image, strongest first."""

    xy: npt.NDArray[np.float32]
    """(K, 2): x, y in pixels, pixel centres at integers, x right, y down."""
    scale: npt.NDArray[np.float32]
    """(K,): characteristic scale in pixels, sqrt(σ_D² + 0.7²): the σ_D of the scale dominating
    the keypoint's cluster with the camera image's own blur, the total that follows a zoom."""
    angle: npt.NDArray[np.float32]
    """(K,): dominant steered orientation, radians in [0, π)."""
    response: npt.NDArray[np.float32]
    """(K,): strongest scale-normalised Harris response of the cluster."""
    descriptor: npt.NDArray[np.float32]
    """(K, L): L = 128 steered responses in the keypoint's frame (unit length) for
    descriptor="steered", the default; 256 (two frames) for "steered-twin"; L = 5 entropies
    (bits) at 16 … 256 colours for descriptor="entropy"."""
    descriptor_kind: str
    """"steered", "steered-twin" or "entropy"."""
    backend: str
    """"cpu" or "gpu": where the detection ran."""
    def __init__(
        self,
        xy: npt.NDArray[np.float32],
        scale: npt.NDArray[np.float32],
        angle: npt.NDArray[np.float32],
        response: npt.NDArray[np.float32],
        descriptor: npt.NDArray[np.float32],
        descriptor_kind: str = "steered",
        backend: str = "cpu",
    ) -> None:
        """Keypoints from their arrays (read back from Parquet, say), checked to pair up and
        copied. Keypoints pickle as these arrays."""
    def __len__(self) -> int: ...
    def to_cv(self) -> List[Any]:
        """OpenCV cv2.KeyPoint list: size = 6·σ_D (the drawn circle's diameter), angle in
        degrees. Needs cv2."""

class Detector:
    """The rotation-invariant keypoint detector.

    Keyword arguments are the keys of the settings file's [detector] table (orientations,
    scales, max_keypoints, basis, merge, threshold, ...); an unknown key or a bad value raises
    ValueError naming it."""

    backend: str
    """"cpu" or "gpu": where frames go."""
    settings: Dict[str, Any]
    """Every setting, defaults included: Detector(d.backend, **d.settings) is the same
    detector. A Detector pickles as the backend asked for and these settings; the copy builds
    its own GPU context where it is unpickled."""
    def __init__(self, backend: str = "auto", **settings: Any) -> None: ...
    def detect(self, image: Image) -> Keypoints: ...
    def detect_batch(
        self,
        images: Iterable[Union[Image, bytes]],
        return_exceptions: bool = False,
        names: Optional[Sequence[str]] = None,
    ) -> List[Union[Keypoints, Exception]]:
        """In order, through the library's stream: two frames in flight on a GPU, as many at
        once as there are cores on the CPU, the GIL released. An item is an image array or the
        bytes of an encoded file (decoded as the CLI decodes it). With return_exceptions=True a
        failing image gives its exception in its place; otherwise the first failure is raised.
        Errors name the item by names[i], or as "image i". Runs in chunks of 16 images with
        Ctrl-C checked between them (KeyboardInterrupt)."""

def gist(
    images: Union[Image, Sequence[Image]], backend: str = "auto", **settings: Any
) -> npt.NDArray[np.float32]:
    """GIST descriptors: (512,) for one image, (N, 512) for a list. Keyword arguments are the
    [gist] table's keys."""

class Slam:
    """Monocular EKF SLAM with inverse-depth landmarks, one frame at a time. Not picklable
    (a running filter): pickle.dumps raises TypeError; build one per worker."""

    def __init__(
        self,
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        width: int,
        height: int,
        distortion: Optional[Sequence[float]] = None,
        backend: str = "auto",
        detector: Optional[Dict[str, Any]] = None,
        **settings: Any,
    ) -> None:
        """distortion: (k1, k2, p1, p2, k3) or a prefix; detector: [detector] keys over the
        tracking preset; settings: the [slam] sub-tables (filter, search, ransac, map, start,
        klt, motion), each a dict."""
    def process(self, image: Image, t: float) -> "FrameReport":
        """Processes the frame taken at t seconds (strictly increasing)."""
    def trajectory(self) -> npt.NDArray[np.float64]:
        """(N, 8) TUM rows: t, x, y, z, qx, qy, qz, qw."""

class FrameReport:
    """What one frame did."""

    timestamp: float
    position: npt.NDArray[np.float64]
    """(3,): the camera position after the update."""
    quaternion: npt.NDArray[np.float64]
    """(4,): (x, y, z, w), camera to world."""
    covariance: npt.NDArray[np.float64]
    """(6, 6): covariance of position and rotation vector."""
    predicted: int
    matched: int
    inliers: int
    rescued: int
    created: int
    deleted: int
    landmarks: int
    lost: bool
    relocalised: bool
    initialising: bool
    update_rejected: bool

class Controller:
    """The neural-field navigation controller; keyword arguments are the [nav.controller]
    table's keys (field, stimulus, camera, visual, field_steps, turn_gain, max_turn_rate,
    rear_inhibition). mode is "laser" or "fusion" (LIDAR plus the camera's GIST, computed on
    backend). Not picklable (live field state):
    pickle.dumps raises TypeError; build one per worker."""

    field: npt.NDArray[np.float32]
    """(N,): the field's activations over world headings 2πi/N after the last step."""
    mode: str
    """"laser" or "fusion"."""
    def __init__(self, mode: str = "laser", backend: str = "auto", **settings: Any) -> None: ...
    def step(
        self,
        ranges: npt.NDArray[np.float32],
        angle_min: float,
        angle_increment: float,
        pose: Tuple[float, float, float],
        goal: Tuple[float, float],
        range_max: float = ...,
        image: Optional[npt.NDArray[Any]] = None,
    ) -> Tuple[float, float, float]:
        """One control cycle: returns (v, ω, heading relative to the robot). In fusion mode
        image is the camera frame, (H, W) or (H, W, 3), uint8 or float32 in [0, 1]."""

def repeatability(
    kp1: npt.NDArray[np.float32],
    kp2: npt.NDArray[np.float32],
    H: npt.NDArray[np.float64],
    shape1: Tuple[int, int],
    shape2: Tuple[int, int],
    eps: float = 2.0,
    margin: float = 10.0,
) -> float:
    """Repeatability (eq 11): (K, 2) points of each view, the 3×3 map view 1 → view 2, the
    images' (H, W)."""

def recall(
    kp1: npt.NDArray[np.float32],
    desc1: npt.NDArray[np.float32],
    kp2: npt.NDArray[np.float32],
    desc2: npt.NDArray[np.float32],
    H: npt.NDArray[np.float64],
    shape1: Tuple[int, int],
    shape2: Tuple[int, int],
    eps: float = 2.0,
    ratio: float = 0.8,
    margin: float = 10.0,
) -> float:
    """Recall (eq 12) of nearest-neighbour matching with Lowe's ratio test."""

def match_keypoints(
    kp1: npt.NDArray[np.float32],
    desc1: npt.NDArray[np.float32],
    kp2: npt.NDArray[np.float32],
    desc2: npt.NDArray[np.float32],
    ratio: float = 0.8,
    verify: str = "homography",
    threshold: float = 3.0,
    iterations: int = 10000,
    seed: int = 1,
    guided: bool = True,
    frames: int = 1,
) -> "Matches":
    """Correspondences as `steernav match` makes them: mutual nearest neighbours passing the
    ratio test both ways, verified by RANSAC ("homography", "fundamental" or "none",
    `threshold` in pixels), then, with `guided`, matched again among the candidates the model
    maps within `threshold` of each other and verified again. `frames`: equal frames per
    descriptor row (2 for "steered-twin"), two rows as near as their nearest pair of frames."""

class Matches:
    """Correspondences between two keypoint sets, sorted by descriptor distance."""

    i: npt.NDArray[np.uint64]
    """(M,): index into the first set."""
    j: npt.NDArray[np.uint64]
    """(M,): index into the second set."""
    distance: npt.NDArray[np.float32]
    inlier: npt.NDArray[np.bool_]
    model: Optional[npt.NDArray[np.float64]]
    """(3, 3): the fitted H or F, or None."""
    def __len__(self) -> int: ...

def textured_scene(width: int, height: int, seed: int = 1) -> npt.NDArray[np.uint8]:
    """The seeded procedural scene of the benchmarks and tests, (H, W, 3) RGB."""

class BagReader:
    """A ROS 2 bag (rosbag2 folder or .mcap file) read frame by frame, streamed. Not
    picklable (an open file): pass the path to a worker instead."""

    def __init__(
        self, path: str, image_topic: Optional[str] = None, max_pixels: int = 100_000_000
    ) -> None: ...
    topics: List[Tuple[str, str]]
    """Every topic as (name, message type)."""
    image_topic: str
    """The Image or CompressedImage topic read."""
    def camera(self, camera_info_topic: Optional[str] = None) -> Dict[str, Any]:
        """The first CameraInfo as `Slam`'s keywords: fx, fy, cx, cy, width, height, distortion."""
    def __iter__(self) -> "BagReader": ...
    def __next__(self) -> Tuple[float, npt.NDArray[np.uint8]]:
        """(header stamp in seconds, (H, W, 3) RGB image)."""
