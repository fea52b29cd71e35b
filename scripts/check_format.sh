#!/usr/bin/env bash
# Formatting check (CI runs it as the test lint.format): every C++ source of the repository must
# be as clang-format 14 writes it with the repository's .clang-format. Prints each file that
# differs with the changes clang-format would make, and exits 1 if there is any; exits 77
# (skipped) without clang-format-14 or outside a git clone.
# Fix: git ls-files '*.cpp' '*.h' | xargs clang-format-14 -i   (review, commit)
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v clang-format-14 >/dev/null; then
    echo "check_format.sh: clang-format-14 is not installed (scripts/setup.sh installs it); skipped"
    exit 77
fi
if ! files=$(git ls-files -- '*.cpp' '*.h' 2>/dev/null) || [[ -z $files ]]; then
    echo "check_format.sh: not a git clone; skipped"
    exit 77
fi
status=0
while IFS= read -r file; do
    if ! clang-format-14 --style=file "$file" | diff -u --label "$file" --label "$file (formatted)" "$file" -; then
        status=1
    fi
done <<<"$files"
if ((status)); then
    echo "check_format.sh: the files above are not formatted as .clang-format says;" \
         "run: git ls-files '*.cpp' '*.h' | xargs clang-format-14 -i" >&2
    exit 1
fi
echo "check_format.sh: all $(wc -l <<<"$files") C++ files are formatted"
