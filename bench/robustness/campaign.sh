#!/usr/bin/env bash
# The full robustness grid of issue 4, resumable: one `meshmark bench robustness` process per
# mesh (smallest first), each writing OUT_DIR/<mesh>.json when it finishes; meshes whose JSON
# already exists are skipped, so an interrupted campaign continues where it stopped. At the end
# (or with MERGE_ONLY=1) every finished mesh is merged into OUT_DIR/robustness.md.
#
#   bench/robustness/campaign.sh OUT_DIR [extra `bench robustness` options...]
#
# Environment: MESHMARK (binary, default build/bin/meshmark), MESH_DIR (default
# $MESHMARK_MESH_DIR or ../shared/data/meshes), KEYS (10), WRONG_KEYS (10), UNMARKED_KEYS (2),
# LARGE_BYTES (20000000) and LARGE_KEYS (3): mesh files above LARGE_BYTES (of the shared meshes,
# only the 437K dragon_vrip.ply, 34 MB) get LARGE_KEYS keys,
# THREADS (1), MERGE_ONLY (0).
set -euo pipefail
cd "$(dirname "$0")/../.."
if [[ $# -lt 1 ]]; then
    echo "usage: bench/robustness/campaign.sh OUT_DIR [bench robustness options...]" >&2
    exit 2
fi
out=$1
shift
meshmark=${MESHMARK:-build/bin/meshmark}
mesh_dir=${MESH_DIR:-${MESHMARK_MESH_DIR:-../shared/data/meshes}}
keys=${KEYS:-10}
wrong=${WRONG_KEYS:-10}
unmarked=${UNMARKED_KEYS:-2}
large=${LARGE_BYTES:-20000000}
large_keys=${LARGE_KEYS:-3}
threads=${THREADS:-1}
mkdir -p "$out"

# Meshes by file size (a proxy for vertex count), smallest first.
mapfile -t meshes < <(find -L "$mesh_dir" -maxdepth 1 -type f \
    \( -name '*.ply' -o -name '*.obj' -o -name '*.off' -o -name '*.stl' \) -printf '%s %p\n' | sort -n | cut -d' ' -f2-)

if [[ ${MERGE_ONLY:-0} == 0 ]]; then
    for mesh in "${meshes[@]}"; do
        name=$(basename "$mesh")
        [[ -f $out/$name.json ]] && continue
        n=$(stat -L -c %s "$mesh")
        k=$keys
        if [[ $n -gt $large ]]; then k=$large_keys; fi
        echo "campaign: $name ($n bytes, $k keys) started $(date -u +%H:%M:%S)" >&2
        start=$SECONDS
        "$meshmark" bench robustness --mesh "$mesh" --keys "$k" --wrong-keys "$wrong" \
            --unmarked-keys "$unmarked" --max-vertices 100000000 --threads "$threads" -q \
            --json-file "$out/$name.json" "$@" > "$out/$name.md"
        echo "campaign: $name done in $((SECONDS - start)) s" >&2
    done
fi

files=()
for mesh in "${meshes[@]}"; do
    name=$(basename "$mesh")
    [[ -f $out/$name.json ]] && files+=(--from-json "$out/$name.json")
done
if ((${#files[@]})); then
    "$meshmark" bench robustness "${files[@]}" --markdown "$out/robustness.md" > /dev/null
    echo "campaign: merged $((${#files[@]} / 2)) meshes into $out/robustness.md" >&2
fi
