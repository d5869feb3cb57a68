"""steernav on Ray Data: keypoints for image sets on many workers and machines.

``Detect`` is a callable class for ``Dataset.map_batches``: each actor builds one
``steernav.Detector`` (one GPU context with ``num_gpus=1``) and reuses it for every batch, whose
images go through ``Detector.detect_batch`` (two frames in flight on a GPU, every core busy on
the CPU)::

    import ray, steernav.ray
    ds = ray.data.read_images("photos/", include_paths=True, mode="RGB")
    ds = ds.map_batches(steernav.ray.Detect, fn_constructor_kwargs={"max_keypoints": 500},
                        concurrency=8, num_gpus=1, batch_size=16, batch_format="numpy")
    ds.write_parquet("keypoints/")

``detect_images`` does the same from paths, decoding each file with steernav's own decoder (the
one ``steernav batch`` uses), so a file that fails to decode keeps its row with ``count = 0`` and
an ``error`` instead of failing the whole read.

The keypoint columns are ragged (a count per image), as Ray's variable-shaped tensor columns,
the same type in every batch, which ``write_parquet``, ``to_pandas`` and ``read_parquet`` take:
``count`` (int32), ``xy`` (K×2 float32), ``scale``, ``angle``, ``response`` (K float32),
``descriptor`` (K×L float32) and ``error`` (a string, empty when the image was detected).

Ray is imported here only, so the rest of steernav never needs it (``pip install
./python[ray]``).
"""

from typing import Any, Dict, Iterable, Optional, Union

import numpy as np

from . import Detector, Keypoints

#: The columns every output row carries, besides the columns passed through.
COLUMNS = ("count", "xy", "scale", "angle", "response", "descriptor", "error")

_DESCRIPTOR_LENGTH = {"steered": 128, "entropy": 5}


def _ray():
    try:
        import ray  # noqa: F401
        import ray.data  # noqa: F401
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "steernav.ray needs Ray Data: pip install './python[ray]' (or 'ray[data]')"
        ) from e
    return ray


def _threads_from_ray() -> None:
    """In a Ray worker, as many detector threads as CPUs the worker was given, so N actors on
    N cores do not each start a thread per core (the pool starts on the first detection)."""
    import os

    if "RAYON_NUM_THREADS" in os.environ:
        return
    try:
        import ray

        if not ray.is_initialized():
            return
        cpus = ray.get_runtime_context().get_assigned_resources().get("CPU", 0)
    except Exception:  # not in a Ray worker, or an older Ray without the call
        return
    if cpus > 0:
        os.environ["RAYON_NUM_THREADS"] = str(max(1, round(cpus)))


class Detect:
    """A ``map_batches`` stage: images in, keypoints out, one row per image.

    Keyword arguments are ``backend`` ("auto", "gpu" or "cpu") and the keys of the settings
    file's ``[detector]`` table, as for ``steernav.Detector``; pass them through
    ``fn_constructor_kwargs``. ``column`` names the input column: by default ``image`` (H×W or
    H×W×3 uint8 arrays, as ``read_images`` gives, ragged across rows allowed) or, when there is
    no ``image`` column, ``bytes`` (encoded files, as ``read_binary_files`` gives). The input
    column is dropped from the output unless ``keep_input=True``; every other column (``path``,
    labels) is passed through unchanged.

    An image that fails to decode or that the detector refuses keeps its row, with
    ``count = 0``, empty keypoint arrays and the reason in ``error``; the stage goes on.
    """

    def __init__(
        self,
        backend: str = "auto",
        column: Optional[str] = None,
        keep_input: bool = False,
        **settings: Any,
    ) -> None:
        _threads_from_ray()
        self.detector = Detector(backend, **settings)
        self.column = column
        self.keep_input = keep_input
        self.length = _DESCRIPTOR_LENGTH[self.detector.settings["descriptor"]]

    def _input_column(self, batch: Dict[str, Any]) -> str:
        if self.column is not None:
            if self.column not in batch:
                raise KeyError(
                    f"steernav.ray.Detect: no column {self.column!r} in the batch "
                    f"(columns: {sorted(batch)})"
                )
            return self.column
        for name in ("image", "bytes"):
            if name in batch:
                return name
        raise KeyError(
            "steernav.ray.Detect: the batch has neither an 'image' column (arrays) nor a "
            f"'bytes' column (encoded files); its columns are {sorted(batch)}: "
            "pass column=... in fn_constructor_kwargs"
        )

    @staticmethod
    def _item(value: Any) -> Any:
        if isinstance(value, (bytes, bytearray, memoryview, np.bytes_)):
            return bytes(value)
        return np.ascontiguousarray(value)

    def __call__(self, batch: Dict[str, Any]):
        _ray()
        from ray.data.block import BlockAccessor
        from ray.data.extensions import ArrowVariableShapedTensorArray

        column = self._input_column(batch)
        items = [self._item(v) for v in batch[column]]
        names = [str(p) for p in batch["path"]] if "path" in batch else None
        found = self.detector.detect_batch(items, return_exceptions=True, names=names)
        passed = {k: v for k, v in batch.items() if k != column or self.keep_input}
        counts = np.zeros(len(found), np.int32)
        errors = np.empty(len(found), dtype=object)
        ragged = {name: np.empty(len(found), dtype=object) for name in COLUMNS[1:6]}
        for i, result in enumerate(found):
            if isinstance(result, Keypoints):
                counts[i], errors[i] = len(result), ""
                for name in ragged:
                    ragged[name][i] = np.asarray(getattr(result, name), np.float32)
            else:
                errors[i] = str(result)
                ragged["xy"][i] = np.zeros((0, 2), np.float32)
                ragged["descriptor"][i] = np.zeros((0, self.length), np.float32)
                for name in ("scale", "angle", "response"):
                    ragged[name][i] = np.zeros(0, np.float32)
        table = BlockAccessor.batch_to_block({**passed, "count": counts, "error": errors})
        # Variable-shaped in every batch, even one whose images all hit max_keypoints, so
        # every block and Parquet file has one schema.
        for name, arrays in ragged.items():
            table = table.append_column(name, ArrowVariableShapedTensorArray.from_numpy(arrays))
        return table


def detect_images(
    paths_or_dataset: Union[str, Iterable[str], Any],
    *,
    concurrency: Optional[int] = None,
    num_gpus: float = 0,
    batch_size: int = 16,
    **settings: Any,
):
    """Keypoints of image files (a folder, a list of paths or globs, as
    ``ray.data.read_binary_files`` takes) or of a dataset with an ``image`` or ``bytes`` column.
    Files are read as bytes and decoded by steernav, so an undecodable file keeps its row with
    an ``error``. Returns the lazy dataset, with a ``path`` column for files.

    ``concurrency`` is the number of actors (one ``Detector`` each; by default one per CPU of
    the cluster with ``num_gpus=0``, one per GPU with ``num_gpus=1``). The actors share all
    but one of the cluster's CPUs, so the read tasks always have one; each actor detects with
    as many threads as CPUs it holds (at least one). The other keyword arguments are
    ``backend`` and the ``[detector]`` keys."""
    ray = _ray()
    if isinstance(paths_or_dataset, ray.data.Dataset):
        dataset = paths_or_dataset
    else:
        paths = paths_or_dataset if isinstance(paths_or_dataset, str) else list(paths_or_dataset)
        dataset = ray.data.read_binary_files(paths, include_paths=True)
    resources = ray.cluster_resources()
    cpus = resources.get("CPU", 1.0)
    if concurrency is None:
        if num_gpus:
            concurrency = max(1, int(resources.get("GPU", 0) // num_gpus))
        else:
            # One actor per core, each detecting with one thread (see _threads_from_ray).
            concurrency = max(1, int(cpus))
    # The actors must leave a CPU to the read tasks that feed them: actors holding every CPU
    # wait forever for blocks no task can be scheduled to read.
    num_cpus = min(1.0, max(cpus - 1.0, 0.25) / concurrency)
    return dataset.map_batches(
        Detect,
        fn_constructor_kwargs=settings,
        concurrency=concurrency,
        num_cpus=num_cpus,
        num_gpus=num_gpus,
        batch_size=batch_size,
        batch_format="numpy",
    )
