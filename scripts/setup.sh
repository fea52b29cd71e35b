#!/usr/bin/env bash
# Install every build and test dependency of meshmark from Debian 12 packages.
# Safe to run again: apt-get skips what is already installed. Needs root (or sudo).
# --build-only: what building meshmark and its tests needs, without the interop tools (gltfpack,
# draco, PrusaSlicer, Node.js and the npm packages), for the demo.
set -euo pipefail
interop_tools=1
for arg in "$@"; do
  case $arg in
    --build-only) interop_tools=0 ;;
    *) echo "usage: scripts/setup.sh [--build-only]" >&2; exit 2 ;;
  esac
done

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev          # dense linear algebra (Gram matrix, eigen-decomposition)
  nlohmann-json3-dev     # key files and --json output
  libcli11-dev           # command-line parsing
  libnanoflann-dev       # kd-tree (welding, nearest neighbours)
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev  # simplification, remeshing, subdivision
  libmeshoptimizer-dev   # fast simplification
  libopenvdb-dev         # voxel remeshing attack: level set and surface extraction, as Blender's (pulls libtbb-dev)
  libtinygltf-dev libstb-dev libdraco-dev  # glTF/GLB (+ Draco) files; stb also writes the PNG heatmaps
  lib3mf-dev             # tests only: an independent reader of the 3MF packages meshmark writes
  libzip-dev libpugixml-dev  # 3MF packages: zip container and model XML, rewritten in place
  libspectra-dev         # Laplacian eigenbasis baseline: shift-invert Lanczos (header-only)
  libsuitesparse-dev     # CHOLMOD sparse Cholesky for the Laplacian eigenbasis
  libgtest-dev libgmock-dev googletest              # tests
  clang-format-14        # tests only: the formatting check (scripts/check_format.sh, test lint.format)
  libbenchmark-dev       # micro-benchmarks
  libhnswlib-dev         # the shape index's exact search against an HNSW graph (bench/perf only)
  libsqlite3-dev libsqlitecpp-dev  # the catalogue's database (SQLite, through SQLiteCpp)
  libpq-dev              # the catalogue on PostgreSQL (a `postgresql://` location, through libpq)
  postgresql             # tests only: a PostgreSQL server the `postgres` tests start (initdb, pg_ctl)
  libssl-dev             # SHA-256 of catalogue originals (OpenSSL's libcrypto)
  libcpp-httplib-dev     # the issuing service's HTTP server (`meshmark serve`)
  libcairo2-dev          # PDF evidence reports (`detect --report x.pdf`): cairo's PDF surface
  chromium               # tests only: the HTML evidence report opened, screenshot and printed headless
  curl wrk               # the service's tests (curl) and load benchmark (wrk: bench/service)
  pybind11-dev python3-dev python3-numpy python3-pytest  # the Python package (python/) and its tests
  python3-mypy           # tests only: the type stubs checked by mypy --strict (tests/python/test_stubs.py)
  python3-venv           # tests only: `pip install .` into a fresh virtual environment (python.pip_install)
  python3-distributed    # catalogue work on a Dask cluster (docs/cluster.md); tests start its scheduler and workers
)
if ((interop_tools)); then
  # Interop tests (label `interop`): the ecosystem's own tools write the inputs and check
  # the outputs. The npm ones are pinned in tests/interop/package.json (installed below).
  packages+=(gltfpack draco prusa-slicer xvfb xauth)
  # Blender 3.4 (Debian): the voxel remesh that `meshmark attack voxel=N` must reproduce, and
  # the add-on's headless test (python/blender); both label `interop`.
  packages+=(blender)
  # The re-work bench's other tools (bench/blender/rework.py): Open3D's decimation and
  # smoothing, MeshLab's quadric edge collapse and Taubin smoothing (meshlabserver).
  packages+=(python3-open3d meshlab)
  # Other people's models for the real-assets interop tests: Khronos' glTF samples (one
  # Draco-compressed) and game models in OBJ and DirectX (/usr/share/assimp/models), and
  # assimp's converter (`assimp export`), which turns game formats into glTF.
  packages+=(assimp-testmodels assimp-utils)
  # OpenCASCADE's sample CAD parts (/usr/share/opencascade/data/stl): held-out meshes for the
  # real-assets interop tests.
  packages+=(occt-misc)
  # Artists' furniture, vehicles and figures in OBJ (Sweet Home 3D's catalogues, zip files):
  # the artists'-models interop tests (Blender's re-work of models made of many objects).
  packages+=(sweethome3d-furniture)
  # Node.js for the npm tools: Debian's, unless the machine already has a node and npm.
  if ! command -v node >/dev/null || ! command -v npm >/dev/null; then packages+=(nodejs npm); fi
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# The pinned npm tools of the interop tests (glTF-Transform, the Khronos validator,
# gltf-pipeline), into tests/interop/node_modules; skipped when package-lock.json is unchanged
# since the last install.
interop="$(cd "$(dirname "$0")/.." && pwd)/tests/interop"
if ((interop_tools)) && { [[ ! -f $interop/node_modules/.package-lock.json ]] ||
   ! cmp -s "$interop/package-lock.json" "$interop/node_modules/.meshmark-lock"; }; then
  echo "setup: installing the interop tests' npm packages (tests/interop/package.json)" >&2
  (cd "$interop" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
  cp "$interop/package-lock.json" "$interop/node_modules/.meshmark-lock"
fi
echo "setup: all dependencies present" >&2
