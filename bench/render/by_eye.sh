#!/bin/sh
# SPDX-License-Identifier: MIT
# The by-eye check of the default mark (bench/results/2026-11-25-by-eye.md): marks the smooth shared
# meshes with the defaults (seed 1) and renders each original and marked copy the same way in
# Blender (render_pair.py), plus a control marked at ten times the default strength, which must
# look different. Writes OUT_DIR/<mesh>-pair.png (original left) and prints the pixel
# differences.
#
#   bench/render/by_eye.sh OUT_DIR [MESH ...]
#
# Environment: MESHMARK_MESH_DIR (default ../shared/data/meshes), MESHMARK (default
# build/bin/meshmark), BLENDER (default blender). Blender cannot read OFF: such originals are
# rendered from a reordered PLY copy (`meshmark attack IN -o OUT reorder`: the same triangles).
set -eu
[ $# -ge 1 ] || { echo "usage: bench/render/by_eye.sh OUT_DIR [MESH ...]" >&2; exit 2; }
out=$1; shift
here=$(cd "$(dirname "$0")" && pwd)
dir=${MESHMARK_MESH_DIR:-$here/../../../shared/data/meshes}
meshmark=${MESHMARK:-$here/../../build/bin/meshmark}
blender=${BLENDER:-blender}
[ $# -gt 0 ] || set -- fandisk.obj rocker-arm.obj teapot.obj fertility.off spot.obj bunny.stl horse.ply \
    armadillo.obj nefertiti.obj
mkdir -p "$out"

render() {  # ORIGINAL MARKED PREFIX
    "$blender" -b --factory-startup --python-exit-code 2 --python "$here/render_pair.py" -- "$1" "$2" "$3" \
        --size 640 --samples 16 2>&1 | tr '\r' '\n' | grep -a "render_pair.py"
}

for mesh in "$@"; do
    name=${mesh%.*}
    original=$dir/$mesh
    case $mesh in
    *.off)
        "$meshmark" attack "$original" -o "$out/$name-original.ply" reorder -q --force
        original=$out/$name-original.ply
        ;;
    esac
    "$meshmark" embed "$original" -o "$out/$name-marked.ply" --key "$out/$name.key.json" --seed 1 -q --force
    render "$original" "$out/$name-marked.ply" "$out/$name"
done
"$meshmark" embed "$dir/fandisk.obj" -o "$out/control-marked.ply" --key "$out/control.key.json" --seed 1 \
    --strength 0.0059 -q --force
render "$dir/fandisk.obj" "$out/control-marked.ply" "$out/control-x10"
