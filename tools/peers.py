#!/usr/bin/env python3
"""Run OpenCV's classic detectors for steernav's evaluation (issue: repeatability and recall).

Usage: peers.py DETECTORS IMAGE...   (DETECTORS comma-separated, or "list")
Prints one JSON object per line: {"image", "detector", "keypoints": [[x, y, response, size,
angle], ...], "norm": "l2"|"hamming", "descriptors": [[...], ...]} with keypoints sorted by
response, strongest first. steernav computes every metric itself; this script only detects.
Detectors without a descriptor of their own (FAST, AGAST, STAR, GFTT-Harris) are described
with SIFT at their keypoints, oriented by the intensity centroid of a 31-px disc (as ORB
orients FAST corners), so that recall can be measured for them too, rotation-invariantly.
"""
import json
import sys

import cv2
import numpy as np


def factory(attr):
    """cv2.<attr>, or cv2.xfeatures2d.<attr> where OpenCV 5 moved it (AGAST, and others in
    some builds); None when the installed OpenCV has neither."""
    for module in (cv2, getattr(cv2, "xfeatures2d", None)):
        if module is not None and hasattr(module, attr):
            return getattr(module, attr)
    return None


def make(name):
    simple = {
        "agast": ("AgastFeatureDetector_create", {}, None),
        "brisk": ("BRISK_create", {}, "self"),
        "censure": ("StarDetector_create", {}, None),
        "orb": ("ORB_create", {"nfeatures": 5000}, "self"),
        "sift": ("SIFT_create", {}, "self"),
        "surf": ("SURF_create", {}, "self"),
        "fast": ("FastFeatureDetector_create", {}, None),
        "kaze": ("KAZE_create", {}, "self"),
        "akaze": ("AKAZE_create", {}, "self"),
    }
    if name == "harris":
        return "harris", None
    if name not in simple:
        raise SystemExit(f"unknown detector {name}")
    attr, kwargs, desc = simple[name]
    create = factory(attr)
    if create is None:
        return None, None
    try:
        # SURF is patented: contrib wheels without OPENCV_ENABLE_NONFREE raise here.
        return create(**kwargs), desc
    except Exception:
        return None, None


ALL = ["agast", "brisk", "censure", "orb", "sift", "surf", "fast", "kaze", "akaze", "harris"]


def centroid_angles(gray, kps, radius=15):
    """Orientation (degrees) of each keypoint from the intensity centroid of a disc."""
    h, w = gray.shape
    g = cv2.copyMakeBorder(gray, radius, radius, radius, radius, cv2.BORDER_REFLECT).astype(np.float32)
    ys, xs = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    disc = (xs * xs + ys * ys) <= radius * radius
    out = []
    for k in kps:
        x, y = int(round(k.pt[0])), int(round(k.pt[1]))
        x, y = min(max(x, 0), w - 1), min(max(y, 0), h - 1)
        patch = g[y:y + 2 * radius + 1, x:x + 2 * radius + 1] * disc
        out.append(float(np.degrees(np.arctan2((patch * ys).sum(), (patch * xs).sum())) % 360.0))
    return out


def detect(name, img):
    det, desc = make(name)
    if det is None:
        return None
    gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
    if det == "harris":
        pts = cv2.goodFeaturesToTrack(gray, maxCorners=5000, qualityLevel=1e-4, minDistance=2,
                                      useHarrisDetector=True, k=0.04)
        kps = [] if pts is None else [cv2.KeyPoint(float(p[0][0]), float(p[0][1]), 7.0,
                                                   -1, float(len(pts) - i)) for i, p in enumerate(pts)]
    else:
        kps = list(det.detect(gray, None))
    kps.sort(key=lambda k: -k.response)
    kps = kps[:5000]
    if desc != "self":
        for k, a in zip(kps, centroid_angles(gray, kps)):
            k.angle = a
            k.size = max(k.size, 7.0)
    extractor = det if desc == "self" else factory("SIFT_create")()
    kps, d = extractor.compute(gray, kps)
    kps = list(kps) if kps is not None else []
    norm = "hamming" if d is not None and d.dtype == np.uint8 and name in ("brisk", "orb", "akaze") else "l2"
    order = sorted(range(len(kps)), key=lambda i: -kps[i].response)
    return {
        "detector": name,
        "keypoints": [[kps[i].pt[0], kps[i].pt[1], float(kps[i].response), kps[i].size, kps[i].angle]
                      for i in order],
        "norm": norm,
        "descriptors": [] if d is None else [d[i].tolist() for i in order],
    }


def main():
    if len(sys.argv) >= 2 and sys.argv[1] == "list":
        ok = [n for n in ALL if make(n)[0] is not None]
        print(json.dumps({"available": ok, "missing": [n for n in ALL if n not in ok],
                          "opencv": cv2.__version__}))
        return
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    names = ALL if sys.argv[1] == "all" else sys.argv[1].split(",")
    for path in sys.argv[2:]:
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        if img is None:
            raise SystemExit(f"{path}: cannot read image")
        for name in names:
            out = detect(name, img)
            if out is None:
                continue
            out["image"] = path
            print(json.dumps(out, separators=(",", ":")))


if __name__ == "__main__":
    main()
