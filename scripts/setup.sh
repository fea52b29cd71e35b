#!/usr/bin/env bash
# Install every build and test dependency of meshmark from Debian 12 packages.
# Safe to run again: apt-get skips what is already installed. Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev          # dense linear algebra (Gram matrix, eigen-decomposition)
  nlohmann-json3-dev     # key files and --json output
  libcli11-dev           # command-line parsing
  libnanoflann-dev       # kd-tree (welding, nearest neighbours)
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev  # simplification, remeshing, subdivision
  libmeshoptimizer-dev   # fast simplification
  libtinygltf-dev libstb-dev libdraco-dev lib3mf-dev  # glTF/GLB (+ Draco) and 3MF files
  libspectra-dev         # Laplacian eigenbasis baseline: shift-invert Lanczos (header-only)
  libsuitesparse-dev     # CHOLMOD sparse Cholesky for the Laplacian eigenbasis
  libgtest-dev libgmock-dev googletest              # tests
  libbenchmark-dev       # micro-benchmarks
)

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
echo "setup: all dependencies present" >&2
