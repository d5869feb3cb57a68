"""Per-image time of OpenCV SIFT (keypoints and descriptors) on the images given, the peer of
`cargo run --release --example time_images -- cpu IMAGE...` (docs/BENCHMARKS.md, issue 20).

    .venv-peers/bin/python tools/time_sift.py [--keypoints 500] [--threads 2] IMAGE...

Prints one line per image: the median of 15 timed calls of `SIFT_create(N).detectAndCompute`
on the grey image after 3 warm-up calls, in ms, and the keypoint count.

    .venv-peers/bin/python tools/time_sift.py --batch [--workers 2] IMAGE...

is the peer of `steernav batch`: one process per worker, each reading its share of the images
(`imread`, then `detectAndCompute` with one OpenCV thread), and prints images per second over
the whole set, process start excluded.
"""
import argparse
import multiprocessing
import statistics
import sys
import time

import cv2


def _detect_all(job):
    paths, keypoints = job
    cv2.setNumThreads(1)
    sift = cv2.SIFT_create(keypoints)
    for path in paths:
        image = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise SystemExit(f"{path}: cannot be read as an image")
        sift.detectAndCompute(image, None)
    return len(paths)


def batch(paths, workers, keypoints):
    with multiprocessing.Pool(workers) as pool:
        pool.map(_detect_all, [([], keypoints)] * workers)  # start the workers
        t0 = time.perf_counter()
        done = sum(pool.map(_detect_all, [(paths[w::workers], keypoints) for w in range(workers)]))
        elapsed = time.perf_counter() - t0
    print(f"{done} images in {elapsed:.2f} s: {done / elapsed:.1f} images/s with {workers} workers")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("images", nargs="+")
    parser.add_argument("--keypoints", type=int, default=500)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--batch", action="store_true")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    if args.batch:
        batch(args.images, args.workers, args.keypoints)
        return 0
    cv2.setNumThreads(args.threads)
    sift = cv2.SIFT_create(args.keypoints)
    for path in args.images:
        image = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if image is None:
            print(f"{path}: cannot be read as an image", file=sys.stderr)
            return 1
        for _ in range(3):
            sift.detectAndCompute(image, None)
        times = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            keypoints, _ = sift.detectAndCompute(image, None)
            times.append((time.perf_counter() - t0) * 1e3)
        print(f"{path}: {statistics.median(times):.1f} ms, {len(keypoints)} keypoints")
    return 0


if __name__ == "__main__":
    sys.exit(main())
