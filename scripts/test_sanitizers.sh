#!/usr/bin/env bash
# Sanitizer job: build meshmark in Debug with AddressSanitizer and UndefinedBehaviorSanitizer
# into ./build-asan and run the quick unit tests under them (labels `unit`, minus `slow`).
# Any sanitizer report aborts the test (-fno-sanitize-recover=all) and fails the job.
# Extra arguments go to ctest (e.g. -E <regex> to leave out more tests).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
start=$(date +%s)
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug \
    -DMESHMARK_SANITIZE="address;undefined" -DMESHMARK_BUILD_CLI=ON >/dev/null
cmake --build build-asan -j "$jobs"
built=$(date +%s)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# CGAL in Debug under ASan is 10-50x slower: the real-mesh attack tests and the biggest
# simplification case (each > 2 min here) are left out; override with MESHMARK_ASAN_EXCLUDE.
exclude=${MESHMARK_ASAN_EXCLUDE-'SharedMeshAttackTest|SimplificationTest\.closed_sphere'}
ctest --test-dir build-asan --output-on-failure -j "$jobs" -L unit -LE slow \
    ${exclude:+-E "$exclude"} "$@"
end=$(date +%s)
echo "test_sanitizers.sh: build $((built - start)) s, tests $((end - built)) s, total $((end - start)) s"
