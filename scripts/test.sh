#!/usr/bin/env bash
# Quick start 2: install dependencies, build, and run the test suite (everything but the `slow`
# label), then the installed-package check (scripts/test_install.sh). The real meshes are read
# from ../shared/data/meshes, or from $MESHMARK_MESH_DIR.
# Pass --all to include the slow tests.
set -euo pipefail
cd "$(dirname "$0")/.."
labels=(-LE slow)
if [[ ${1:-} == --all ]]; then labels=(); fi
bash scripts/setup.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" "${labels[@]}"
# The installed package: cmake --install into build/install-test, then examples/library built
# against it with find_package(meshmark) and run (issue 7).
bash scripts/test_install.sh build
