# SPDX-License-Identifier: MIT
"""Bad arrays and options raise meshmark.Error subclasses with one sentence, never crash."""
import numpy as np
import pytest

import meshmark


def test_error_hierarchy():
    for cls in (meshmark.IoError, meshmark.InvalidMesh, meshmark.InvalidOption, meshmark.NumericalError):
        assert issubclass(cls, meshmark.Error)
    assert issubclass(meshmark.Error, Exception)


@pytest.mark.parametrize(
    "make_v, make_f, needle",
    [
        (lambda V: V[:, :2], lambda F: F, "shape (1152, 2)"),
        (lambda V: V.reshape(-1), lambda F: F, "shape (3456,)"),
        (lambda V: None, lambda F: F, "got None"),
        (lambda V: V.astype(str), lambda F: F, "dtype"),
        (lambda V: V.astype(complex), lambda F: F, "dtype"),
        (lambda V: "not an array", lambda F: F, "shape"),
        (lambda V: V, lambda F: F[:, :2], "F: expected an (m, 3) array"),
        (lambda V: V, lambda F: F.astype(np.float64), "integer vertex indices"),
        (lambda V: V, lambda F: np.where(F == 5, 5000, F), "uses vertex 5000"),
        (lambda V: V, lambda F: np.where(F == 5, -1, F), "uses vertex -1"),
        (lambda V: V, lambda F: F.astype(np.uint64) + np.uint64(2**63), "F: face 0 uses vertex"),
    ],
)
def test_bad_arrays_raise_invalid_mesh(torus, make_v, make_f, needle):
    V, F = torus
    with pytest.raises(meshmark.InvalidMesh) as error:
        meshmark.embed(make_v(V), make_f(F), seed=1)
    assert needle in str(error.value)
    assert str(error.value).endswith(".")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_coordinates_raise(torus, bad):
    V, F = torus
    V = V.copy()
    V[17, 1] = bad
    with pytest.raises(meshmark.InvalidMesh, match="vertex 17"):
        meshmark.embed(V, F, seed=1)
    with pytest.raises(meshmark.InvalidMesh, match="V_suspect"):
        meshmark.detect(V, F, torus[0], F, meshmark.embed(torus[0], F, seed=1)[0])


def test_too_few_vertices(torus):
    V = torus[0][:20]
    with pytest.raises(meshmark.InvalidMesh):
        meshmark.embed(V, None, seed=1)


@pytest.mark.parametrize(
    "options, needle",
    [
        ({"rule": "nope"}, "nope"),
        ({"basis": "wavelet"}, "wavelet"),
        ({"message": "a", "bits": "ffffff"}, "one of them"),
        ({"bits": "xyz"}, "bits"),
        ({"seed": -1}, "seed"),
        ({"seed": 2**64}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"strength": -0.1}, "strength"),
        ({"coefficients": 0}, "coefficients"),
        ({"message": 3}, "message"),
    ],
)
def test_bad_options_raise_invalid_option(torus, options, needle):
    V, F = torus
    with pytest.raises(meshmark.InvalidOption) as error:
        meshmark.embed(V, F, **options)
    assert needle in str(error.value)


def test_laplacian_basis_needs_faces(torus):
    with pytest.raises(meshmark.InvalidMesh):
        meshmark.embed(torus[0], None, seed=1, basis="laplacian")


def test_detect_bad_options(torus):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=2)
    with pytest.raises(meshmark.InvalidOption):
        meshmark.detect(marked, F, V, F, key, verdict="maybe")
    with pytest.raises(meshmark.InvalidOption):
        meshmark.detect(marked, F, V, F, key, threshold=2.0)
    with pytest.raises(meshmark.InvalidOption, match="pairs"):
        meshmark.detect(marked, F, V, F, key, pairs=np.zeros((2, 6)))


def test_detect_wrong_original_is_io_error(torus):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=2)
    other = V * 1.01
    with pytest.raises(meshmark.IoError, match="not the original"):
        meshmark.detect(marked, F, other, F, key)


def test_inputs_are_not_modified_and_other_dtypes_work(torus):
    V, F = torus
    V32 = V.astype(np.float32)
    before = V32.copy()
    key, marked = meshmark.embed(V32, F.astype(np.uint32), seed=4)
    assert np.array_equal(V32, before)
    assert marked.dtype == np.float64 and marked.shape == V.shape
    # A Fortran-ordered view is read the same as the C-ordered array.
    key_c, marked_c = meshmark.embed(np.asfortranarray(V), F, seed=4)
    key_f, marked_f = meshmark.embed(V, F, seed=4)
    assert np.array_equal(marked_c, marked_f)
