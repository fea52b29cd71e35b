# SPDX-License-Identifier: MIT
"""Real scans from the shared mesh folder (skipped without it): embed and detect in numpy."""
import numpy as np
import pytest

import meshmark


@pytest.mark.parametrize("name", ["bunny.off", "fandisk.obj"])
def test_real_mesh_round_trip(mesh_dir, name):
    path = mesh_dir / name
    if not path.exists():
        pytest.skip(f"{path} not found")
    V, F = meshmark.read_mesh(path)
    key, marked = meshmark.embed(V, F, seed=101, message="scan")
    assert meshmark.detect(marked, F, V, F, key).detected
    assert not meshmark.detect(V, F, V, F, key).detected
    # A simplified copy (new vertices: registration and resampling) still carries the mark.
    small_V, small_F = meshmark.attack_mesh(marked, F, "simplify=0.5", seed=1)
    assert len(small_V) < len(V)
    result = meshmark.detect(small_V, small_F, V, F, key)
    assert result.detected, result.to_dict()


def test_real_point_cloud(mesh_dir):
    path = mesh_dir / "bunny.off"
    if not path.exists():
        pytest.skip(f"{path} not found")
    V, _ = meshmark.read_mesh(path)
    key, marked = meshmark.embed(V, None, seed=5)
    assert meshmark.detect(marked, None, V, None, key).detected
    rng = np.random.default_rng(0)
    shuffled = marked[rng.permutation(len(marked))]
    assert meshmark.detect(shuffled, None, V, None, key).detected
