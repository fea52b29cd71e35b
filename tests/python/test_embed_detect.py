# SPDX-License-Identifier: MIT
"""embed -> detect on numpy arrays: the mark is found where it is and not where it is not."""
import numpy as np
import pytest

import meshmark


def diagonal(V):
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))


def test_round_trip(torus):
    V, F = torus
    key, marked = meshmark.embed(V, F, message="hello", seed=7)
    assert isinstance(key, meshmark.Key)
    assert marked.shape == V.shape and marked.dtype == np.float64
    assert marked.flags.c_contiguous and marked.flags.owndata is False  # handed over, not copied
    moved = np.linalg.norm(marked - V, axis=1)
    assert moved.max() > 0.0
    # Default strength: an RMS surface distance of 0.059% of the diagonal, so well under 1%.
    assert np.sqrt(np.mean(moved**2)) < 0.01 * diagonal(V)
    assert key.seed == 7 and key.message == "hello" and key.original_vertices == len(V)

    found = meshmark.detect(marked, F, V, F, key)
    assert found.detected
    assert found.score > 5.0
    assert found.false_positive_probability <= 1e-6
    assert found.bits_found == found.bits_expected
    assert found.transform.shape == (4, 4)
    report = found.to_dict()
    assert report["detected"] is True
    assert report["score"] == found.score
    assert report["registration"]["method"] == found.alignment
    # The unit of registration_rms for "how far from the original": the default strength.
    assert found.mark_strength == pytest.approx(0.00059) and report["mark_strength"] == found.mark_strength
    # Read vertex for vertex: no voxel remesh of the original was needed.
    assert found.voxel_resolution == 0.0 and report["voxel_resolution"] == 0.0

    clean = meshmark.detect(V, F, V, F, key)
    assert not clean.detected
    assert clean.false_positive_probability > 1e-6


def test_wrong_key_does_not_detect(torus):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=7)
    other, _ = meshmark.embed(V, F, seed=8)
    assert not meshmark.detect(marked, F, V, F, other).detected


def test_deterministic_for_a_seed(torus):
    V, F = torus
    key1, marked1 = meshmark.embed(V, F, bits="a5f00f", seed=11, threads=1)
    key2, marked2 = meshmark.embed(V, F, bits="a5f00f", seed=11, threads=2)
    assert np.array_equal(marked1, marked2)
    assert key1 == key2 and key1.to_json() == key2.to_json()
    assert key1.bits == "a5f00f"


def test_report_and_options(torus):
    V, F = torus
    key, marked, report = meshmark.embed(V, F, seed=3, strength=0.002, repetitions=3, report=True)
    assert report["strength"] == pytest.approx(0.002)
    assert report["repetitions"] == 3 and key.repetitions == 3
    auto_key, _ = meshmark.embed(V, F, seed=3)  # repetitions='auto': chosen on the mesh, recorded
    assert len(V) < 5000 and auto_key.repetitions == 4
    assert meshmark.embed(V, F, seed=3, repetitions="auto")[0].repetitions == 4
    for bad in ("four", 2.5, True, -1):
        with pytest.raises(meshmark.InvalidOption):
            meshmark.embed(V, F, seed=3, repetitions=bad)
    assert report["vertices"] == len(V) and report["faces"] == len(F)
    assert 0.0 < report["rms_displacement"] < report["max_displacement"] < 0.05
    assert "total" in report["seconds"]
    paper_key, _ = meshmark.embed(V, F, seed=3, rule="paper")
    assert paper_key.rule == "paper" and paper_key.strength == pytest.approx(0.01)
    # The strength is the surface distance by default; the vertex measure on request.
    assert key.strength_measure == "surface" and report["strength_measure"] == "surface"
    assert report["surface_rms_displacement"] == pytest.approx(0.002, rel=1e-9)
    vertex_key, _, vertex = meshmark.embed(V, F, seed=3, strength=0.002, strength_measure="vertex", report=True)
    assert vertex_key.strength_measure == "vertex" and vertex_key.vertex_strength == pytest.approx(0.002)
    assert vertex["surface_rms_displacement"] != pytest.approx(0.002, rel=1e-3)
    with pytest.raises(meshmark.InvalidOption, match="strength measure"):
        meshmark.embed(V, F, seed=3, strength_measure="area")


def test_key_json_round_trip_and_file(torus, tmp_path):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=5)
    assert meshmark.Key.from_json(key.to_json()) == key
    path = tmp_path / "k.json"
    key.save(path)
    assert (path.stat().st_mode & 0o777) == 0o600
    assert meshmark.Key.load(str(path)) == key
    with pytest.raises(meshmark.InvalidOption, match="already exists"):
        key.save(path)
    other, _ = meshmark.embed(V, F, seed=6)
    other.save(path, force=True)
    assert meshmark.Key.load(path) == other
    tampered = key.to_json().replace("0000000000000005", "0000000000000006")
    assert tampered != key.to_json()
    with pytest.raises(meshmark.IoError):
        meshmark.Key.from_json(tampered)


def test_point_cloud(torus):
    V, _ = torus
    key, marked = meshmark.embed(V, None, seed=9)
    assert key.original_faces == 0
    assert meshmark.detect(marked, None, V, None, key).detected
    assert not meshmark.detect(V, None, V, None, key).detected


def test_attacked_and_reordered_suspect(torus):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=12)
    noisy_V, noisy_F = meshmark.attack_mesh(marked, F, "noise=0.0005", seed=1)
    assert np.array_equal(noisy_F, F)
    assert meshmark.detect(noisy_V, noisy_F, V, F, key).detected
    # A reordered, moved copy goes through registration.
    moved_V, moved_F = meshmark.attack_mesh(marked, F, "similarity,reorder", seed=2)
    result = meshmark.detect(moved_V, moved_F, V, F, key)
    assert result.detected
    assert result.alignment != "none"
    # A reordered copy of the whole surface: no row is far from it, none is left out.
    assert result.outlier_fraction == 0.0 and result.cropped_fraction == 0.0
    assert result.to_dict()["outlier_fraction"] == 0.0
    with pytest.raises(meshmark.InvalidOption):
        meshmark.detect(moved_V, moved_F, V, F, key, register=False)
    # Close to the original: not a far copy. Simplified to a few dozen vertices, it lies
    # several times the mark's strength away, which is_far_copy says (and why it is not found).
    assert not result.is_far_copy
    coarse_V, coarse_F = meshmark.attack_mesh(marked, F, "simplify=0.01", seed=3)
    coarse = meshmark.detect(coarse_V, coarse_F, V, F, key)
    assert coarse.registration_rms >= 3 * coarse.mark_strength
    assert coarse.is_far_copy and not coarse.detected


def test_help_shows_the_docstrings():
    assert "message" in meshmark.embed.__doc__ and "point" in meshmark.embed.__doc__
    assert "V_suspect" in meshmark.detect.__doc__
    assert "--json" in meshmark.detect_file.__doc__
    assert meshmark.Key.load.__doc__
