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
# One clang-format process checks them all (--dry-run: names each file that differs); the diffs
# are then printed for those files only. A process per file took 80 s of the suite's time.
status=0
if ! report=$(xargs -d '\n' clang-format-14 --style=file --dry-run --Werror <<<"$files" 2>&1); then
    status=1
    while IFS= read -r file; do
        clang-format-14 --style=file "$file" | diff -u --label "$file" --label "$file (formatted)" "$file" - || true
    done < <(sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: error: code should be clang-formatted.*/\1/p' <<<"$report" | sort -u)
    # Any other error (a file clang-format cannot read) as clang-format gave it.
    grep -E '^[^ ]*: error' <<<"$report" | grep -v 'code should be clang-formatted' || true
fi
if ((status)); then
    echo "check_format.sh: the files above are not formatted as .clang-format says;" \
         "run: git ls-files '*.cpp' '*.h' | xargs clang-format-14 -i" >&2
    exit 1
fi
echo "check_format.sh: all $(wc -l <<<"$files") C++ files are formatted"
