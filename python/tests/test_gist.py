"""gist(): the CLI's descriptors for the same pixels."""

import json
import subprocess

import numpy as np

import steernav


def test_gist_matches_the_cli(sample, sample_file, cli_exe):
    ours = steernav.gist(sample, backend="cpu")
    cli = subprocess.run(
        [cli_exe, "gist", "--backend", "cpu", str(sample_file)],
        check=True,
        capture_output=True,
        text=True,
    )
    theirs = np.array(json.loads(cli.stdout)["gist"], np.float32)
    assert ours.shape == (512,)
    assert np.abs(ours - theirs).max() <= 1e-4 * np.abs(theirs).max()
    both = steernav.gist([sample, sample[::2, ::2].copy()], backend="cpu")
    assert both.shape == (2, 512) and np.allclose(both[0], ours)


def test_an_empty_list_has_the_descriptor_width(sample):
    assert steernav.gist([], backend="cpu").shape == (0, 512)
    assert steernav.gist([sample, sample], backend="cpu").shape == (2, 512)
