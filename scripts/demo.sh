#!/usr/bin/env bash
# Quick start 1: install the build dependencies, build the meshmark program only (not the tests,
# benchmarks or interop tools), and run the demo (make a mesh -> embed -> attack -> detect).
# Needs no external data. Extra arguments go to `meshmark demo` (see --help).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --build-only
bash scripts/build.sh --target meshmark_cli
exec build/bin/meshmark demo "$@"
