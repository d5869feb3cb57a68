"""steernav beside OpenCV's SIFT: detect, draw both sets of keypoints, and score repeatability
under rotation for both with steernav.repeatability.

    pip install ./python opencv-python-headless
    python python/examples/rotation.py [IMAGE] [--out rotation.png]
"""

import argparse
import pathlib

import cv2
import numpy as np

import steernav

ROOT = pathlib.Path(__file__).resolve().parents[2]


def rotate(image, degrees):
    """The image rotated about its centre onto an expanded canvas, and the 3×3 map."""
    h, w = image.shape[:2]
    m = cv2.getRotationMatrix2D((w / 2 - 0.5, h / 2 - 0.5), degrees, 1.0)
    cos, sin = abs(m[0, 0]), abs(m[0, 1])
    # The tolerance keeps 90° and 180° canvases exact (sin 180° is 1.2e-16, not 0).
    nw, nh = int(np.ceil(w * cos + h * sin - 1e-6)), int(np.ceil(w * sin + h * cos - 1e-6))
    m[0, 2] += (nw - w) / 2
    m[1, 2] += (nh - h) / 2
    rotated = cv2.warpAffine(image, m, (nw, nh), flags=cv2.INTER_LINEAR)
    return rotated, np.vstack([m, [0.0, 0.0, 1.0]])


def sift_xy(sift, rgb, n):
    kps = sift.detect(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), None)
    kps = sorted(kps, key=lambda k: -k.response)[:n]
    return kps, np.array([k.pt for k in kps], np.float32).reshape(-1, 2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("image", nargs="?", default=str(ROOT / "assets" / "sample.png"))
    ap.add_argument("--out", default="rotation.png", help="side-by-side picture of both detectors")
    args = ap.parse_args()
    bgr = cv2.imread(args.image, cv2.IMREAD_COLOR)
    if bgr is None:
        raise SystemExit(f"{args.image}: cannot read the image")
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    detector = steernav.Detector(max_keypoints=500)
    sift = cv2.SIFT_create()

    ours = detector.detect(rgb)
    theirs, _ = sift_xy(sift, rgb, 500)
    left = cv2.drawKeypoints(bgr, ours.to_cv(), None, (0, 200, 0), cv2.DRAW_MATCHES_FLAGS_DRAW_RICH_KEYPOINTS)
    right = cv2.drawKeypoints(bgr, theirs, None, (0, 0, 230), cv2.DRAW_MATCHES_FLAGS_DRAW_RICH_KEYPOINTS)
    cv2.imwrite(args.out, np.hstack([left, right]))
    print(f"{len(ours)} steernav keypoints (left, green), {len(theirs)} SIFT (right, red): {args.out}")

    print("angle  steernav  SIFT   (repeatability, eq 11, ε = 2 px)")
    for degrees in range(15, 181, 15):
        rotated, H = rotate(rgb, degrees)
        shapes = (rgb.shape[:2], rotated.shape[:2])
        a, b = ours, detector.detect(rotated)
        rep_ours = steernav.repeatability(a.xy, b.xy, H, *shapes)
        _, s1 = sift_xy(sift, rgb, 500)
        _, s2 = sift_xy(sift, rotated, 500)
        rep_sift = steernav.repeatability(s1, s2, H, *shapes)
        print(f"{degrees:5d}  {rep_ours:8.3f}  {rep_sift:5.3f}")


if __name__ == "__main__":
    main()
