"""Detector and Keypoints: the CLI's keypoints for the same pixels, every input layout, and
bad input as clear exceptions."""

import json
import subprocess

import numpy as np
import pytest

import steernav


def test_detect_matches_the_cli(sample, sample_file, cli_exe):
    ours = steernav.Detector(backend="cpu").detect(sample)
    cli = subprocess.run(
        [cli_exe, "detect", "--backend", "cpu", str(sample_file)],
        check=True,
        capture_output=True,
        text=True,
    )
    theirs = json.loads(cli.stdout)["keypoints"]
    assert len(ours) == len(theirs) > 100
    xy = np.array([[k["x"], k["y"]] for k in theirs], np.float32)
    assert np.abs(ours.xy - xy).max() <= 1e-4
    assert np.allclose(ours.scale, [k["scale"] for k in theirs], atol=1e-4)
    assert np.allclose(ours.angle, [k["angle"] for k in theirs], atol=1e-4)
    assert np.allclose(ours.descriptor, [k["descriptor"] for k in theirs], atol=1e-4)
    assert ours.xy.dtype == np.float32 and ours.descriptor.shape == (len(ours), 128)
    assert ours.descriptor_kind == "steered"
    paper = steernav.Detector(backend="cpu", descriptor="entropy").detect(sample)
    assert paper.descriptor.shape == (len(paper), 5) and paper.descriptor_kind == "entropy"
    # Both orientation frames: the same keypoints, the first frame the plain descriptor.
    twin = steernav.Detector(backend="cpu", descriptor="steered-twin").detect(sample)
    assert twin.descriptor.shape == (len(ours), 256) and twin.descriptor_kind == "steered-twin"
    assert np.array_equal(twin.xy, ours.xy)
    assert np.array_equal(twin.descriptor[:, :128], ours.descriptor)


def test_grey_float_and_batch_inputs(sample):
    det = steernav.Detector(backend="cpu", orientations=8, max_keypoints=100)
    grey = sample.mean(axis=2).astype(np.float32) / 255.0
    found = det.detect(grey)
    assert 0 < len(found) <= 100
    batch = det.detect_batch([sample, sample[:240, :320].copy(), grey])
    assert [len(k) for k in batch][0] == len(det.detect(sample))
    assert len(batch) == 3


def test_bad_input_raises_clear_exceptions(sample):
    with pytest.raises(ValueError, match="orientatons"):
        steernav.Detector(backend="cpu", orientatons=8)
    with pytest.raises(ValueError, match="scales"):
        steernav.Detector(backend="cpu", scales=0)
    with pytest.raises(ValueError, match="backend"):
        steernav.Detector(backend="tpu")
    det = steernav.Detector(backend="cpu")
    with pytest.raises(TypeError, match="uint8 or float32"):
        det.detect(sample.astype(np.float64))
    with pytest.raises(ValueError, match="shape"):
        det.detect(np.zeros((10, 10, 4), np.uint8))
    nan = np.full((64, 64), np.nan, np.float32)
    with pytest.raises(ValueError, match="not finite"):
        det.detect(nan)
    with pytest.raises(TypeError):
        det.detect("not an array")


def test_detector_and_keypoints_pickle(sample):
    import pickle

    det = steernav.Detector(backend="cpu", orientations=8, max_keypoints=150, harris_k=0.05)
    copy = pickle.loads(pickle.dumps(det))
    assert copy.settings == det.settings
    assert copy.settings["orientations"] == 8 and copy.settings["harris_k"] == 0.05
    ours, theirs = det.detect(sample), copy.detect(sample)
    assert len(ours) == len(theirs) > 50
    for name in ("xy", "scale", "angle", "response", "descriptor"):
        assert np.array_equal(getattr(ours, name), getattr(theirs, name)), name
    # Settings round-trip through the constructor too: the same detector again.
    again = steernav.Detector("cpu", **det.settings).detect(sample)
    assert np.array_equal(again.xy, ours.xy)
    kp = pickle.loads(pickle.dumps(ours))
    assert len(kp) == len(ours) and kp.backend == "cpu" and kp.descriptor_kind == "steered"
    assert np.array_equal(kp.descriptor, ours.descriptor) and np.array_equal(kp.xy, ours.xy)
    with pytest.raises(ValueError, match="scale: 3 rows for 150"):
        steernav.Keypoints(ours.xy, ours.scale[:3], ours.angle, ours.response, ours.descriptor)
    with pytest.raises(ValueError, match="backend"):
        steernav.Keypoints(
            ours.xy, ours.scale, ours.angle, ours.response, ours.descriptor, backend="tpu"
        )


def test_detect_batch_takes_encoded_files_and_keeps_going(sample):
    import io

    from PIL import Image

    det = steernav.Detector(backend="cpu", max_keypoints=200)
    png = io.BytesIO()
    Image.fromarray(sample).save(png, format="PNG")
    items = [sample, png.getvalue(), b"not an image", sample.astype(np.float64), sample[:100]]
    found = det.detect_batch(items, return_exceptions=True, names=list("abcde"))
    one = det.detect(sample)
    assert np.array_equal(found[0].xy, one.xy) and np.array_equal(found[1].xy, one.xy)
    assert isinstance(found[2], ValueError) and str(found[2]).startswith("c: ")
    assert isinstance(found[3], TypeError) and "uint8 or float32" in str(found[3])
    assert len(found[4]) == len(det.detect(sample[:100]))
    # Without return_exceptions the first failure is raised, of its own type, named.
    with pytest.raises(ValueError, match="^image 2: "):
        det.detect_batch(items)
    with pytest.raises(ValueError, match="names: 1 names for 5 images"):
        det.detect_batch(items, names=["x"])


def test_a_long_batch_stops_on_ctrl_c():
    import _thread
    import signal
    import threading
    import time

    det = steernav.Detector(backend="cpu", max_keypoints=50)
    image = steernav.textured_scene(96, 72, 3)
    # The pace of a warm detector (the first batch also builds the plan for this size).
    det.detect_batch([image] * 200)
    t0 = time.perf_counter()
    det.detect_batch([image] * 200)
    per_200 = time.perf_counter() - t0
    # Interrupt the main thread as Ctrl-C would, once a batch is under way. Batches follow one
    # another until it lands, so a machine that finishes one before the timer cannot make the
    # interrupt miss; what is checked is how soon after it the batch stops.
    fired = []

    def interrupt():
        fired.append(time.perf_counter())
        _thread.interrupt_main()

    # A process started in the background by a non-interactive shell inherits SIGINT ignored,
    # and interrupt_main then does nothing: give the test Python's own handler.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Timer(max(0.05, 3 * per_200), interrupt).start()
        deadline = time.perf_counter() + 120
        with pytest.raises(KeyboardInterrupt):
            while time.perf_counter() < deadline:
                det.detect_batch([image] * 8000)
    finally:
        signal.signal(signal.SIGINT, previous)
    # Stopped after the chunk in progress: well before the rest of the 40 × 200 images.
    assert time.perf_counter() - fired[0] < 10 * per_200


def test_one_gpu_detector_shared_by_a_thread_pool(sample):
    """Four threads on one GPU detector (the GIL is released during detection): each frame
    gets its own keypoints, and the pool finishes (it used to hang once in 15-60 runs)."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    try:
        det = steernav.Detector(backend="gpu", max_keypoints=200)
    except Exception:
        if os.environ.get("STEERNAV_REQUIRE_GPU") == "1":
            raise
        pytest.skip("no GPU adapter")
    corners = [(0, 0), (100, 200), (300, 400), (200, 50)]
    frames = [sample[y : y + 144, x : x + 192].copy() for y, x in corners]
    alone = [det.detect(f).xy for f in frames]
    jobs = [i % len(frames) for i in range(24)]
    with ThreadPoolExecutor(4) as pool:
        found = list(pool.map(lambda i: det.detect(frames[i]).xy, jobs))
    for i, xy in zip(jobs, found):
        assert np.array_equal(xy, alone[i]), i
