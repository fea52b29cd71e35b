#!/usr/bin/env bash
# Formatting check (CI runs it as the test lint.format): every C++ line changed since $base must
# be as clang-format 14 writes it with the repository's .clang-format. Lines older than $base
# are formatted when they are next touched (at $base, 349 of 382 files differed from the style).
# Prints the changes clang-format would make and exits 1 if there are any; exits 77 (skipped)
# outside a git clone or without clang-format-14 / git-clang-format-14.
# Fix: git clang-format-14 --binary clang-format-14 --extensions cpp,h 3525cbd   (review, commit)
set -euo pipefail
cd "$(dirname "$0")/.."
base=3525cbd
if ! git rev-parse --verify -q "$base^{commit}" >/dev/null 2>&1; then
    echo "check_format.sh: not a git clone with commit $base; skipped"
    exit 77
fi
if ! command -v clang-format-14 >/dev/null || ! command -v git-clang-format-14 >/dev/null; then
    echo "check_format.sh: clang-format-14 is not installed (scripts/setup.sh installs it); skipped"
    exit 77
fi
diff=$(git-clang-format-14 --binary "$(command -v clang-format-14)" --diff --extensions cpp,h "$base" \
    -- src include apps tests python bench fuzz examples 2>&1) || true
case $diff in
    "no modified files to format" | "clang-format did not modify any files" | "")
        echo "check_format.sh: every C++ line changed since $base is formatted"
        exit 0 ;;
esac
echo "$diff"
echo "check_format.sh: the lines above are not formatted as .clang-format says;" \
     "run: git clang-format-14 --binary clang-format-14 --extensions cpp,h $base" >&2
exit 1
