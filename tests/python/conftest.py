# SPDX-License-Identifier: MIT
"""Shared fixtures of the Python package's tests: a generated mesh, the program, the meshes."""
import os
import pathlib
import shutil

import numpy as np
import pytest


def make_bumpy_torus(nu=48, nv=24):
    """A closed, irregular torus (no symmetry a registration could confuse): (V, F)."""
    u = np.linspace(0.0, 2.0 * np.pi, nu, endpoint=False)
    v = np.linspace(0.0, 2.0 * np.pi, nv, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    r = 0.35 + 0.05 * np.sin(3.0 * uu) * np.cos(2.0 * vv)
    x = 1.3 * (1.0 + r * np.cos(vv)) * np.cos(uu)
    y = 0.8 * (1.0 + r * np.cos(vv)) * np.sin(uu)
    z = r * np.sin(vv) + 0.15 * np.sin(2.0 * uu + 0.5)
    V = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * nv + j).ravel()
    b = (((i + 1) % nu) * nv + j).ravel()
    c = (((i + 1) % nu) * nv + (j + 1) % nv).ravel()
    d = (i * nv + (j + 1) % nv).ravel()
    F = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])
    return V, F


@pytest.fixture(scope="session")
def torus():
    return make_bumpy_torus()


@pytest.fixture(scope="session")
def cli():
    """The meshmark program of this build, or a skip when it was not built."""
    path = os.environ.get("MESHMARK_CLI") or shutil.which("meshmark")
    if not path or not os.path.exists(path):
        pytest.skip("the meshmark program is not available (MESHMARK_CLI)")
    return path


@pytest.fixture(scope="session")
def mesh_dir():
    """The shared real meshes: $MESHMARK_MESH_DIR, else the build's default folder; a skip without."""
    folder = os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR") or "../shared/data/meshes"
    folder = pathlib.Path(folder)
    if not folder.is_dir():
        pytest.skip(f"shared meshes not found in {folder} (set MESHMARK_MESH_DIR)")
    return folder
