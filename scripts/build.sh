#!/usr/bin/env bash
# Configure and build meshmark (Release) into ./build. `--target NAME` (repeatable) builds only
# those targets (the demo builds only `meshmark`); other arguments go to CMake's configure step.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
targets=()
configure=()
while (($#)); do
    case $1 in
        --target) targets+=(--target "$2"); shift 2 ;;
        *) configure+=("$1"); shift ;;
    esac
done
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${configure[@]}" >/dev/null
cmake --build build -j "$jobs" "${targets[@]}"
