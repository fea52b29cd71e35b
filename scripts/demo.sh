#!/usr/bin/env bash
# Quick start 1: install dependencies, build, and run the demo (make a mesh -> embed -> attack ->
# detect). Needs no external data. Extra arguments go to `meshmark demo` (see --help).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
exec build/bin/meshmark demo "$@"
