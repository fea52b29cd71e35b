#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Short version of bench/service/crash.py for the test suite: the held-out GLB (make_assets.py),
# 3 rounds of 4 clients each killed with SIGKILL at a random moment, then every received name
# recorded and 20 received copies (the last ones before each kill first) traced to their own
# buyer only. Full run: bench/service/crash.py --rounds 20 --clients 8 (docs/performance.md).
# Usage: service_crash_smoke.sh MESHMARK_BINARY. Exit 77 (skipped) without gltfpack or the meshes.
set -euo pipefail
cli=$1
here=$(cd "$(dirname "$0")/../.." && pwd)
meshes=${MESHMARK_MESH_DIR:-${MESHMARK_DEFAULT_MESH_DIR:-$here/../shared/data/meshes}}
if ! command -v gltfpack >/dev/null || [[ ! -f $meshes/horse.ply ]]; then
  echo "skipped: needs gltfpack and the shared meshes" >&2
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3=${PYTHON:-python3}
"$python3" "$here/bench/service/make_assets.py" --out "$work/bench" --meshmark "$cli" --data "$meshes" >/dev/null
"$python3" "$here/bench/service/crash.py" --meshmark "$cli" --catalog "$work/bench/catalog.db" --asset horse.glb \
  --rounds 3 --clients 4 --seed 7 --detect-sample 20 --workdir "$work/crash" --out "$work/crash.json" >/dev/null
"$python3" -c 'import json,sys; d=json.load(open(sys.argv[1])); print(json.dumps({k: d[k] for k in d if not isinstance(d[k], (list, dict))}))' "$work/crash.json"
