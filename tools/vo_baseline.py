#!/usr/bin/env python3
"""The visual odometry a user could write in 40 lines of OpenCV, as a baseline for `steernav slam`.

Shi-Tomasi corners, pyramidal KLT, the 5-point essential matrix (RANSAC) and recoverPose; every
step has unit length, there is no map and no filter. Reads the same sequences as `steernav slam`
(KITTI odometry, TUM RGB-D, EuRoC, or a plain folder with --fps) and writes a TUM trajectory.

    .venv-peers/bin/python tools/vo_baseline.py SEQUENCE --out vo.txt [--calib F] [--fps HZ]
"""
import argparse
import csv
import re
import sys
import tomllib
from pathlib import Path

import cv2
import numpy as np

IMAGES = {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".bmp", ".tif"}


def frames_of(seq: Path, fps):
    """(timestamps, paths) in the layouts `steernav slam` reads."""
    if (seq / "rgb.txt").is_file():
        rows = [l.split() for l in (seq / "rgb.txt").read_text().splitlines() if l.strip() and not l.startswith("#")]
        return [float(r[0]) for r in rows], [seq / r[1] for r in rows]
    for cam in ("cam0", "mav0/cam0"):
        if (seq / cam / "data.csv").is_file():
            rows = [r for r in csv.reader(open(seq / cam / "data.csv")) if r and not r[0].startswith("#")]
            return [int(r[0]) * 1e-9 for r in rows], [seq / cam / "data" / r[1].strip() for r in rows]
    folder = next((seq / d for d in ("image_0", "image_l") if (seq / d).is_dir()), seq)
    paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGES)
    if (seq / "times.txt").is_file():
        times = [float(l) for l in (seq / "times.txt").read_text().split()]
    else:
        rate = fps or (10.0 if folder != seq else 30.0)
        times = [i / rate for i in range(len(paths))]
    return times[: len(paths)], paths


def calibration(seq: Path, calib):
    """Camera matrix and distortion (k1, k2, p1, p2, k3) from calib.txt, calib.toml or sensor.yaml."""
    path = Path(calib) if calib else next(
        (p for p in (seq / "calib.txt", seq / "calib.toml", seq / "cam0/sensor.yaml", seq / "mav0/cam0/sensor.yaml") if p.is_file()), None)
    if path is None:
        sys.exit(f"{seq}: no calibration; pass --calib")
    text = path.read_text()
    if path.suffix == ".txt":
        p = [float(v) for v in text.splitlines()[0].split(":")[-1].split()]
        return np.array([[p[0], 0, p[2]], [0, p[5], p[6]], [0, 0, 1]]), np.zeros(5)
    if path.suffix == ".toml":
        c = tomllib.loads(text)["camera"]
        k = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]])
        return k, np.array([c.get(n, 0.0) for n in ("k1", "k2", "p1", "p2", "k3")])
    numbers = lambda key: [float(v) for v in re.search(key + r":\s*\[([^\]]*)\]", text).group(1).split(",")]
    fu, fv, cu, cv = numbers("intrinsics")
    d = numbers("distortion_coefficients") + [0.0]
    return np.array([[fu, 0, cu], [0, fv, cv], [0, 0, 1]]), np.array(d[:5])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sequence", type=Path)
    ap.add_argument("--out", type=Path, default=Path("vo.txt"), help="TUM trajectory to write")
    ap.add_argument("--calib", help="calib.txt, calib.toml or sensor.yaml (default: the sequence's own)")
    ap.add_argument("--fps", type=float, help="frame rate of a folder without timestamps")
    a = ap.parse_args()
    times, paths = frames_of(a.sequence, a.fps)
    k, dist = calibration(a.sequence, a.calib)
    f = 0.5 * (k[0, 0] + k[1, 1])
    rot, centre = np.eye(3), np.zeros(3)
    prev, points = None, None
    with open(a.out, "w") as out:
        out.write("# timestamp tx ty tz qx qy qz qw (tools/vo_baseline.py)\n")
        for t, path in zip(times, paths):
            img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            if prev is not None and points is not None and len(points) >= 8:
                moved, ok, _ = cv2.calcOpticalFlowPyrLK(prev, img, points, None, winSize=(21, 21), maxLevel=3)
                ok = ok.ravel() == 1
                p0 = cv2.undistortPoints(points[ok], k, dist)
                p1 = cv2.undistortPoints(moved[ok], k, dist)
                if len(p0) >= 8:
                    e, mask = cv2.findEssentialMat(p0, p1, np.eye(3), cv2.RANSAC, 0.999, 1.0 / f)
                    if e is not None and e.shape == (3, 3):
                        _, r, tr, _ = cv2.recoverPose(e, p0, p1, np.eye(3), mask=mask)
                        rot = rot @ r.T                  # camera k+1 → world
                        centre = centre - rot @ tr.ravel()  # unit step along the direction of travel
                points = moved[ok].reshape(-1, 1, 2)
            if points is None or len(points) < 1000:
                points = cv2.goodFeaturesToTrack(img, 2000, 0.01, 7)
            prev = img
            w, x, y, z = quaternion(rot)
            out.write(f"{t:.6f} {centre[0]:.9f} {centre[1]:.9f} {centre[2]:.9f} {x:.9f} {y:.9f} {z:.9f} {w:.9f}\n")
    print(f"{a.out}: {len(paths)} poses")


def quaternion(m):
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    return w, x, y, z


if __name__ == "__main__":
    main()
