"""Images per second for the same image set through the four ways steernav runs a batch.

    python python/benches/ray_scaling.py [DIR] [--limit N] [--max-keypoints K]

DIR is searched recursively for images (PNG, JPEG, PPM, PGM); without it, 240 generated
640×480 scenes are written to a temporary folder. On the CPU backend, each way reads and
decodes the files itself:

1. `steernav batch DIR --out OUT` (the CLI, one JSON per image);
2. `Detector.detect_batch` on the files' bytes in batches of 16, with 1 thread and with every
   core (each in its own process, since the thread pool is set once per process);
3. Ray Data, `steernav.ray.detect_images` → `materialize()`, with 1 actor and with 2 actors on a
   local cluster of 2 CPUs (the actors leave one CPU to the read tasks, see detect_images).

The Ray overhead per image is Ray's time per image less detect_batch's, at the same number of
detector threads (1 actor of 1 thread against detect_batch with 1 thread, and 2 actors against
detect_batch on 2 threads). Ray's start-up (`ray.init`) is timed apart; it is paid once per
cluster, not per dataset.
"""

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = os.environ.get("STEERNAV_BIN", str(ROOT / "target" / "release" / "steernav"))
EXTENSIONS = {".png", ".jpg", ".jpeg", ".ppm", ".pgm"}


def image_set(folder, limit, tmp):
    if folder is None:
        import steernav
        from PIL import Image

        folder = pathlib.Path(tmp) / "scenes"
        folder.mkdir()
        for seed in range(1, limit + 1):
            Image.fromarray(steernav.textured_scene(640, 480, seed)).save(folder / f"{seed:03d}.png")
    paths = sorted(p for p in pathlib.Path(folder).rglob("*") if p.suffix.lower() in EXTENSIONS)
    paths = paths[:limit]
    # One flat folder of links, so the CLI's batch sees exactly these files.
    flat = pathlib.Path(tmp) / "set"
    flat.mkdir()
    for k, p in enumerate(paths):
        (flat / f"{k:04d}{p.suffix.lower()}").symlink_to(p.resolve())
    return flat, sorted(flat.iterdir())


def cli_batch(flat, tmp, keypoints):
    out = pathlib.Path(tmp) / "cli-out"
    t0 = time.perf_counter()
    subprocess.run(
        [EXE, "batch", str(flat), "--out", str(out), "--backend", "cpu",
         "--max-keypoints", str(keypoints), "--force"],
        check=True, capture_output=True,
    )
    return time.perf_counter() - t0


DETECT_BATCH = r"""
import sys, time, steernav
paths, keypoints = sys.argv[1:-1], int(sys.argv[-1])
d = steernav.Detector("cpu", max_keypoints=keypoints)
t0 = time.perf_counter()
for i in range(0, len(paths), 16):
    chunk = paths[i:i + 16]
    found = d.detect_batch([open(p, "rb").read() for p in chunk], names=chunk)
print(time.perf_counter() - t0)
"""


def detect_batch(paths, threads, keypoints):
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run(
        [sys.executable, "-c", DETECT_BATCH, *map(str, paths), str(keypoints)],
        check=True, capture_output=True, text=True, env=env,
    )
    return float(out.stdout.strip().splitlines()[-1])


def ray_runs(paths, keypoints):
    import ray

    import steernav.ray

    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    start = time.perf_counter() - t0
    ray.data.DataContext.get_current().enable_progress_bars = False
    times = {}
    for actors in (1, 2):
        ds = steernav.ray.detect_images(
            [str(p) for p in paths], concurrency=actors, backend="cpu",
            max_keypoints=keypoints, batch_size=16,
        )
        t0 = time.perf_counter()
        rows = ds.materialize()
        times[actors] = time.perf_counter() - t0
        assert rows.count() == len(paths)
    ray.shutdown()
    return start, times


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", nargs="?", help="images, searched recursively")
    parser.add_argument("--limit", type=int, default=240, help="at most this many images")
    parser.add_argument("--max-keypoints", type=int, default=500)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        flat, paths = image_set(args.folder, args.limit, tmp)
        n, k = len(paths), args.max_keypoints
        print(f"{n} images from {args.folder or 'generated 640x480 scenes'}, {k} keypoints, CPU")
        results = {"steernav batch (CLI, 2 threads)": cli_batch(flat, tmp, k)}
        one = detect_batch(paths, 1, k)
        two = detect_batch(paths, 2, k)
        results["detect_batch, 1 thread"] = one
        results["detect_batch, 2 threads"] = two
        start, ray_times = ray_runs(paths, k)
        results["Ray Data, 1 actor (1 thread)"] = ray_times[1]
        results["Ray Data, 2 actors (1 thread each)"] = ray_times[2]
        for name, seconds in results.items():
            print(f"  {name:38s} {n / seconds:7.1f} images/s  ({seconds:6.2f} s)")
        print(f"  Ray start-up (ray.init, once per cluster): {start:.1f} s")
        for actors, base in ((1, one), (2, two)):
            overhead = 1e3 * (ray_times[actors] - base) / n
            print(f"  Ray overhead, {actors} actor(s) against detect_batch: {overhead:+.1f} ms/image")


if __name__ == "__main__":
    main()
