#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""embed --max-displacement on the shared meshes: is the cap honoured in the written file,
and what does the lower strength do to the verdict?

Per mesh (its coordinates taken as millimetres with --unit mm: the shared meshes state no
unit), with one seed:
  1. embed at the default strength; its largest displacement D (compare --json, in_unit);
  2. embed with --max-displacement D/2 (in mm);
  3. compare original vs the capped copy: max_displacement in mm, which must be <= the cap;
  4. detect the undamaged copies and two attacked copies of each (noise=0.001, simplify=0.5,
     attack seed 1): z-scores (detect --json "score") and verdicts, default vs capped.

Usage: bench/evidence/max_displacement.py [--meshes DIR] [--bin build/bin/meshmark]
       [--max-vertices N] [--out FILE.md]   (prints a markdown table; --out also writes it)
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

MESH_EXTENSIONS = {".ply", ".obj", ".off", ".stl", ".gltf", ".glb", ".3mf"}
ATTACKS = ["noise=0.001", "simplify=0.5"]
SEED = 11


def run(binary, args, expect=(0,)):
    result = subprocess.run([binary] + args, capture_output=True, text=True)
    if result.returncode not in expect:
        raise RuntimeError(f"meshmark {' '.join(args)} -> {result.returncode}: {result.stderr.strip()}")
    return result


def json_of(binary, args, expect=(0,)):
    return json.loads(run(binary, args + ["--json", "-q"], expect).stdout)


def vertex_count(path):
    """Vertices from the header (PLY, OFF) or 'v ' lines (OBJ); None if unknown."""
    try:
        if path.suffix == ".obj":
            with open(path, "rb") as f:
                return sum(1 for line in f if line.startswith(b"v "))
        if path.suffix == ".ply":
            with open(path, "rb") as f:
                for line in f:
                    if line.startswith(b"element vertex"):
                        return int(line.split()[2])
                    if line.startswith(b"end_header"):
                        break
        if path.suffix == ".off":
            with open(path) as f:
                words = f.read(4096).split()
                return int(words[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def verdict(binary, suspect, original, key):
    report = json_of(binary, ["detect", str(suspect), "--original", str(original), "--key", str(key)], (0, 1))
    return report["score"], report["detected"]


def measure(binary, mesh, work):
    row = {"mesh": mesh.name}
    out = work / mesh.name  # bunny.off and bunny.stl: one folder each
    out.mkdir()
    ext = mesh.suffix
    t0 = time.perf_counter()
    default = json_of(binary, ["embed", str(mesh), "-o", str(out / f"default{ext}"), "--key", str(out / "default.json"),
                               "--seed", str(SEED), "--unit", "mm"])
    row["embed_s"] = time.perf_counter() - t0
    row["default_max_mm"] = default["in_unit"]["max_displacement"]
    row["vertices"] = default["vertices"]
    cap = 0.5 * row["default_max_mm"]
    row["cap_mm"] = cap
    t0 = time.perf_counter()
    capped = json_of(binary, ["embed", str(mesh), "-o", str(out / f"capped{ext}"), "--key", str(out / "capped.json"),
                              "--seed", str(SEED), "--unit", "mm", "--max-displacement", f"{cap!r}mm"])
    row["capped_embed_s"] = time.perf_counter() - t0
    row["factor"] = capped["max_displacement_cap"]["strength_factor"]
    compared = json_of(binary, ["compare", str(mesh), str(out / f"capped{ext}"), "--unit", "mm"])
    row["written_max_mm"] = compared["in_unit"]["max_displacement"]
    row["honoured"] = row["written_max_mm"] <= cap
    for name in ("default", "capped"):
        marked = out / f"{name}{ext}"
        key = out / f"{name}.json"
        row[f"{name}_intact"] = verdict(binary, marked, mesh, key)
        for attack in ATTACKS:
            attacked = out / f"{name}-{attack.replace('=', '-').replace(',', '_')}.ply"
            run(binary, ["attack", str(marked), attack, "-o", str(attacked), "--seed", "1", "-q"])
            row[f"{name}_{attack}"] = verdict(binary, attacked, mesh, key)
    return row


def cell(reading):
    z, found = reading
    return f"{z:.2f}{'' if found else ' (not found)'}"


def table(rows):
    head = ("| mesh | vertices | default max (mm) | cap (mm) | written max (mm) | honoured | strength factor | "
            "z intact: default / capped |" + "".join(f" z {a}: default / capped |" for a in ATTACKS))
    lines = [head, "|---|---:|---:|---:|---:|:-:|---:|---|" + "---|" * len(ATTACKS)]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['mesh']} | | | | | | | {r['error']} |" + " |" * len(ATTACKS))
            continue
        lines.append(
            f"| {r['mesh']} | {r['vertices']} | {r['default_max_mm']:.4g} | {r['cap_mm']:.4g} | "
            f"{r['written_max_mm']:.4g} | {'yes' if r['honoured'] else '**no**'} | {r['factor']:.3f} | "
            f"{cell(r['default_intact'])} / {cell(r['capped_intact'])} |" +
            "".join(f" {cell(r[f'default_{a}'])} / {cell(r[f'capped_{a}'])} |" for a in ATTACKS))
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--meshes", default="../shared/data/meshes")
    parser.add_argument("--bin", default="build/bin/meshmark")
    parser.add_argument("--max-vertices", type=int, default=0, help="skip larger meshes (0: none)")
    parser.add_argument("--only", nargs="*", help="only these mesh file names")
    parser.add_argument("--attacks", nargs="*", help=f"attack chains (default: {' '.join(ATTACKS)})")
    parser.add_argument("--out", help="also write the table (markdown) here")
    args = parser.parse_args()
    if args.attacks:
        ATTACKS[:] = args.attacks
    meshes = sorted(p for p in pathlib.Path(args.meshes).iterdir() if p.suffix.lower() in MESH_EXTENSIONS)
    rows = []
    with tempfile.TemporaryDirectory(prefix="max-displacement-") as tmp:
        # A copy of the program: a rebuild during the run must not swap it.
        binary = pathlib.Path(tmp) / "meshmark"
        shutil.copy2(args.bin, binary)
        for mesh in meshes:
            if args.only and mesh.name not in args.only:
                continue
            count = vertex_count(mesh)
            if args.max_vertices and count is not None and count > args.max_vertices:
                print(f"skip {mesh.name} ({count} vertices)", file=sys.stderr)
                continue
            t0 = time.perf_counter()
            try:
                rows.append(measure(str(binary), mesh, pathlib.Path(tmp)))
            except RuntimeError as e:
                rows.append({"mesh": mesh.name, "error": str(e).replace("|", "/")[:200]})
            print(f"{mesh.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
            text = table(rows)
            if args.out:
                pathlib.Path(args.out).write_text(text + "\n")
    print(text)
    honoured = [r for r in rows if "error" not in r]
    print(f"\n{sum(r['honoured'] for r in honoured)} of {len(honoured)} honoured; "
          f"{len(rows) - len(honoured)} errors", file=sys.stderr)


if __name__ == "__main__":
    main()
