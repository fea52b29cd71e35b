#!/usr/bin/env bash
# A sample of the robustness grid (not the full benchmark of issue 4): for each mesh and seed,
# embed with the defaults, apply each attack to the marked copy and to the unmarked original,
# detect both, and print one line per (mesh, seed, attack): R marked, R unmarked, exit codes.
# Usage: bench/robustness/sample.sh MESH... (env SEEDS="1 2", ATTACKS="...", M=path/to/meshmark)
set -euo pipefail
M=${M:-build/bin/meshmark}
SEEDS=${SEEDS:-1}
ATTACKS=${ATTACKS:-"similarity reorder noise=0.005 noise=0.01 quantize=8 smooth=10 smooth=30 smooth=50 simplify=0.1 simplify=0.02 remesh=0.25 remesh=0.05 subdivide=loop subdivide=sqrt3 crop=0.7 crop=0.5 similarity,simplify=0.1,noise=0.001"}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
r_of() { "$M" detect "$1" --original "$2" --key "$3" --json -q | sed -n 's/.*"correlation":\([0-9.e-]*\).*/\1/p'; }
printf "%-22s %5s %-40s %8s %8s\n" mesh seed attack R_marked R_clean
for mesh in "$@"; do
  ext=${mesh##*.}
  for seed in $SEEDS; do
    "$M" embed "$mesh" -o "$work/marked.$ext" --key "$work/key.json" --seed "$seed" --force -q
    for attack in $ATTACKS; do
      "$M" attack "$work/marked.$ext" -o "$work/a.ply" --seed "$seed" -q "$attack"
      "$M" attack "$mesh" -o "$work/c.ply" --seed "$seed" -q "$attack"
      printf "%-22s %5s %-40s %8.3f %8.3f\n" "$(basename "$mesh")" "$seed" "$attack" \
        "$(r_of "$work/a.ply" "$mesh" "$work/key.json")" "$(r_of "$work/c.ply" "$mesh" "$work/key.json")"
    done
  done
done
