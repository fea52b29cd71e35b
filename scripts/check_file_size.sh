#!/usr/bin/env bash
# Size check (CI runs it as the test lint.file_size): no C++ file of the repository (sources,
# headers, tests, benchmarks, examples) is over 600 lines, so each holds one algorithm or one
# subject and a reader can take it in. Exits 1 naming every file over, 77 outside a git clone.
set -euo pipefail
cd "$(dirname "$0")/.."
limit=600
if ! files=$(git ls-files -- '*.cpp' '*.h' 2>/dev/null) || [[ -z $files ]]; then
    echo "check_file_size.sh: not a git clone; skipped"
    exit 77
fi
over=$(xargs wc -l <<<"$files" | awk -v limit=$limit '$2 != "total" && $1 > limit {print "  " $2 ": " $1 " lines"}')
if [[ -n $over ]]; then
    echo "check_file_size.sh: files over $limit lines (split them along their subjects):" >&2
    echo "$over" >&2
    exit 1
fi
echo "check_file_size.sh: all $(wc -l <<<"$files") C++ files are at most $limit lines"
