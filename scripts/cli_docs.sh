#!/usr/bin/env bash
# Refresh the `--help` blocks of docs/cli.md from the built program. Each command's section holds
# its --help text between `<!-- help: meshmark CMD -->` and `<!-- /help -->` (rewritten here) and,
# after it, the details --help leaves out (written by hand, kept as they are). A command with no
# section yet gets one at the end. `--check` changes nothing and fails when a block is stale.
set -euo pipefail
cd "$(dirname "$0")/.."
m=${MESHMARK:-build/bin/meshmark}
check=0
[[ ${1:-} == --check ]] && check=1
help_dir=$(mktemp -d)
trap 'rm -rf "$help_dir"' EXIT
commands=("" demo embed detect attack compare catalog "catalog add" "catalog list" "catalog issue"
          "catalog scan" "catalog reindex" "catalog export" "catalog migrate" serve bench "bench speed" "bench robustness" "bench approximation")
for c in "${commands[@]}"; do
    # shellcheck disable=SC2086
    $m $c --help > "$help_dir/${c// /_}.txt"
done
python3 - "$help_dir" "$check" "${commands[@]}" <<'PY'
import re, sys
help_dir, check, commands = sys.argv[1], sys.argv[2] == "1", sys.argv[3:]
path = "docs/cli.md"
text = open(path).read()
new = text
for c in commands:
    name = ("meshmark " + c).strip()
    body = open(f"{help_dir}/{c.replace(' ', '_')}.txt").read()
    block = f"<!-- help: {name} -->\n```\n{body}```\n<!-- /help -->"
    pattern = re.compile(r"<!-- help: " + re.escape(name) + r" -->\n.*?<!-- /help -->", re.S)
    if pattern.search(new):
        new = pattern.sub(lambda _: block, new, count=1)
    else:
        new = new.rstrip("\n") + f"\n\n## {name}\n\n{block}\n"
if check:
    if new != text:
        sys.exit("docs/cli.md: a --help block is stale; run scripts/cli_docs.sh")
else:
    open(path, "w").write(new)
PY
