"""steernav.ray on a local Ray cluster (one for every test here): read_images → Detect →
write_parquet gives the CLI's keypoints, one Parquet row per image; detect_images keeps a row
for a file that does not decode.

Skipped when Ray is not installed, unless STEERNAV_REQUIRE_RAY=1 (as in CI), where a missing
Ray fails."""

import json
import os
import subprocess

import numpy as np
import pytest

import steernav

if os.environ.get("STEERNAV_REQUIRE_RAY") == "1":
    import ray  # noqa: F401  (fails loudly where Ray must be)
else:
    ray = pytest.importorskip("ray")
pytest.importorskip("PIL")

import steernav.ray  # noqa: E402

SETTINGS = {"backend": "cpu", "max_keypoints": 300}


@pytest.fixture(scope="module")
def cluster():
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """Seven PNGs of different sizes (ragged across rows), one of them grey."""
    from PIL import Image

    folder = tmp_path_factory.mktemp("photos")
    for i in range(7):
        rgb = steernav.textured_scene(256 + 32 * i, 192 + 8 * i, i + 1)
        image = Image.fromarray(rgb).convert("L") if i == 3 else Image.fromarray(rgb)
        image.save(folder / f"p{i}.png")
    return folder


@pytest.fixture(scope="module")
def cli_keypoints(photos, cli_exe, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli")
    subprocess.run(
        [cli_exe, "batch", str(photos), "--out", str(out), "--backend", "cpu",
         "--max-keypoints", str(SETTINGS["max_keypoints"])],
        check=True, capture_output=True,
    )
    found = {}
    for name in sorted(os.listdir(photos)):
        record = json.loads((out / f"{name}.json").read_text())
        found[name] = np.array([[k["x"], k["y"]] for k in record["keypoints"]], np.float32)
    return found


def rows_by_name(frame):
    return {os.path.basename(p): row for p, (_, row) in zip(frame["path"], frame.iterrows())}


def test_read_images_detect_write_parquet_gives_the_cli_keypoints(
    cluster, photos, cli_keypoints, tmp_path
):
    import pyarrow.parquet as pq

    ds = cluster.data.read_images(str(photos), include_paths=True, mode="RGB")
    ds = ds.map_batches(
        steernav.ray.Detect,
        fn_constructor_kwargs=SETTINGS,
        concurrency=2,
        # The two actors share one CPU, so the read tasks keep the other.
        num_cpus=0.5,
        batch_size=3,
        batch_format="numpy",
    )
    ds.write_parquet(str(tmp_path / "kp"))
    assert pq.read_table(str(tmp_path / "kp")).num_rows == len(cli_keypoints)
    frame = cluster.data.read_parquet(str(tmp_path / "kp")).to_pandas()
    assert "image" not in frame.columns
    assert set(steernav.ray.COLUMNS) <= set(frame.columns)
    rows = rows_by_name(frame)
    assert sorted(rows) == sorted(cli_keypoints)
    for name, xy in cli_keypoints.items():
        row = rows[name]
        assert row["error"] == ""
        assert row["count"] == len(xy) == len(row["xy"]) > 20, name
        assert np.abs(np.asarray(row["xy"]) - xy).max() <= 1e-3, name
        assert np.asarray(row["descriptor"]).shape == (len(xy), 128)
        for column in ("scale", "angle", "response"):
            assert np.asarray(row[column]).shape == (len(xy),)


def test_detect_images_keeps_a_row_for_a_file_that_does_not_decode(
    cluster, photos, cli_keypoints, tmp_path
):
    import shutil

    folder = tmp_path / "mixed"
    shutil.copytree(photos, folder)
    (folder / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n not really")
    frame = steernav.ray.detect_images(str(folder), concurrency=2, batch_size=2, **SETTINGS)
    frame = frame.to_pandas()
    rows = rows_by_name(frame)
    assert len(frame) == len(cli_keypoints) + 1
    broken = rows["broken.png"]
    assert broken["count"] == 0 and len(broken["xy"]) == 0
    assert "broken.png" in broken["error"]
    # The others decode with steernav's own decoder, as the CLI's batch does: the same points.
    for name, xy in cli_keypoints.items():
        assert rows[name]["count"] == len(xy) and rows[name]["error"] == ""
        assert np.abs(np.asarray(rows[name]["xy"]) - xy).max() <= 1e-3


def test_detect_names_a_missing_input_column(cluster):
    stage = steernav.ray.Detect(**SETTINGS)
    with pytest.raises(KeyError, match="neither an 'image' column"):
        stage({"path": np.array(["a"])})
