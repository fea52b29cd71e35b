#!/usr/bin/env bash
# Regenerate docs/cli.md from the built program's --help texts.
set -euo pipefail
cd "$(dirname "$0")/.."
m=build/bin/meshmark
{
  echo "# Command-line reference"
  echo
  echo "Generated from \`meshmark ... --help\` (regenerate with \`scripts/cli_docs.sh\`). The contract other programs rely on (exit codes, \`--json\` fields, the attack grammar) is the exit codes below, the \`--json\` fields each command lists, and the attack grammar of docs/algorithms/attacks.md. \`embed\`, \`detect\`, \`attack\` and \`compare\` show their phases (with times, and the running phase's clock) on stderr when stderr is a terminal and the command has run for more than a second, never with \`--quiet\`; their \`--json\` output has the per-phase timings under \`seconds\`."
  echo
  for c in "" demo embed detect attack compare catalog "catalog add" "catalog list" "catalog issue" "catalog scan" \
           "catalog export" serve bench "bench speed" "bench robustness" "bench approximation"; do
    echo "## meshmark $c"; echo; echo '```'; $m $c --help; echo '```'; echo
  done
} > docs/cli.md
