#!/usr/bin/env bash
# Quick start 2: install dependencies, build, and run the test suite (everything but the `slow`
# label), then the installed-package check (scripts/test_install.sh). The real meshes are read
# from ../shared/data/meshes, or from $MESHMARK_MESH_DIR.
# Pass --all to include the slow tests. Last comes the sanitizer job (scripts/test_sanitizers.sh:
# ASan + UBSan build of the core modules' unit tests into ./build-asan, ~15 min on 2 cores from
# cold); --no-sanitizers or MESHMARK_SANITIZERS=0 skips it.
set -euo pipefail
cd "$(dirname "$0")/.."
labels=(-LE slow)
sanitizers=${MESHMARK_SANITIZERS:-1}
for arg in "$@"; do
    case $arg in
        --all) labels=() ;;
        --no-sanitizers) sanitizers=0 ;;
        *) echo "usage: scripts/test.sh [--all] [--no-sanitizers]" >&2; exit 2 ;;
    esac
done
bash scripts/setup.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" "${labels[@]}"
# The installed package: cmake --install into build/install-test, then examples/library built
# against it with find_package(meshmark) and run (issue 7).
bash scripts/test_install.sh build
if [[ $sanitizers != 0 ]]; then
    bash scripts/test_sanitizers.sh
fi
