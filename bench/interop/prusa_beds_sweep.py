#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Mark every STL that PrusaSlicer ships (its printer beds and sample shapes: CAD exports made by
printer vendors, nothing meshmark was tuned on) and read the mark back from the copies a print
workflow makes (docs/interop.md, "Printer beds and shapes from PrusaSlicer").

For each STL under /usr/share/PrusaSlicer/profiles and /usr/share/PrusaSlicer/shapes:
`meshmark embed` (seed 7, --json: the repetitions chosen and the modes the basis spans), then
`meshmark detect` of the marked copy as it is, of PrusaSlicer's own STL export of it
(`prusa-slicer --export-stl`, under xvfb-run), of `meshmark attack noise=0.001` and of
`meshmark attack reorder` (a random vertex and face order); the unmarked STL goes through the
same export and reorder, and must never be claimed.

    python3 bench/interop/prusa_beds_sweep.py --meshmark build/bin/meshmark --work /tmp/beds

Needs prusa-slicer and xvfb (scripts/setup.sh installs them). Prints one line per file and a
summary; --json-file keeps every row. Exit status 1 when an embed fails other than by refusing
a mesh with fewer usable vertices than the basis has functions (exit 3) or whose vertices span
too few modes for a mark (exit 4, "span only"), when a marked copy as
it is, after noise, or after PrusaSlicer's export is not claimed, or when an unmarked copy is.
"""
import argparse
import json
import pathlib
import shutil
import subprocess
import sys

ROOTS = [pathlib.Path("/usr/share/PrusaSlicer/profiles"), pathlib.Path("/usr/share/PrusaSlicer/shapes")]


def run(words, timeout=300):
    return subprocess.run(words, capture_output=True, text=True, timeout=timeout)


def detect(meshmark, suspect, original, key):
    """(exit code, report) of `meshmark detect --json`; report None when it printed none."""
    r = run([meshmark, "detect", str(suspect), "--original", str(original), "--key", str(key), "--json"])
    try:
        return r.returncode, json.loads(r.stdout)
    except json.JSONDecodeError:
        return r.returncode, None


def sweep_one(meshmark, stl, work):
    name = stl.parent.name + "_" + stl.stem
    scratch = work / name
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    row = {"file": str(stl), "name": name}
    marked, key = scratch / "marked.stl", scratch / "key.json"
    e = run([meshmark, "embed", str(stl), "-o", str(marked), "--key", str(key), "--seed", "7", "--json"])
    row["embed_exit"] = e.returncode
    if e.returncode != 0:
        row["embed_error"] = e.stderr.strip().splitlines()[-1] if e.stderr.strip() else ""
        return row
    embedded = json.loads(e.stdout)
    row.update({k: embedded.get(k) for k in ("analysed_vertices", "repetitions", "basis_span", "shortened_to_span")})
    suspects = {"intact": marked}
    for attack in ("noise=0.001", "reorder"):
        for source, tag in ((marked, "marked"), (stl, "unmarked")):
            out = scratch / f"{tag}-{attack.split('=')[0]}.stl"
            a = run([meshmark, "attack", str(source), "-o", str(out), "--seed", "3", attack, "-q"])
            if a.returncode == 0 and (tag == "marked" or attack == "reorder"):
                suspects[f"{tag} {attack}"] = out
    for source, tag in ((marked, "marked"), (stl, "unmarked")):
        out = scratch / f"{tag}-prusa.stl"
        p = run(["xvfb-run", "-a", "prusa-slicer", "--export-stl", "-o", str(out), str(source)])
        if p.returncode == 0 and out.exists():
            suspects[f"{tag} prusa-export"] = out
    row["reads"] = {}
    for label, suspect in suspects.items():
        code, report = detect(meshmark, suspect, stl, key)
        row["reads"][label] = {
            "exit": code,
            "z": round(report["score"], 2) if report else None,
            "method": report["registration"]["method"] if report else None,
        }
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshmark", default="build/bin/meshmark")
    parser.add_argument("--work", default="/tmp/prusa-beds")
    parser.add_argument("--json-file")
    args = parser.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    stls = sorted(p for root in ROOTS if root.exists() for p in root.rglob("*.stl"))
    if not stls:
        sys.exit("no STL under " + ", ".join(map(str, ROOTS)) + " (is prusa-slicer installed?)")
    rows, failures = [], []
    for stl in stls:
        row = sweep_one(args.meshmark, stl, work)
        rows.append(row)
        if row["embed_exit"] != 0:
            print(f"{row['name']}: embed exit {row['embed_exit']}: {row.get('embed_error', '')}")
            refused = row["embed_exit"] == 3 or (row["embed_exit"] == 4 and "span only" in row.get("embed_error", ""))
            if not refused:
                failures.append(row["name"] + ": embed")
            continue
        reads = " ".join(f"{k}={v['exit']}/{v['z']}" for k, v in row["reads"].items())
        print(f"{row['name']}: {row['analysed_vertices']} vertices, r {row['repetitions']}, span "
              f"{row['basis_span']}{' (shortened)' if row['shortened_to_span'] else ''}: {reads}")
        for label, read in row["reads"].items():
            must_claim = label.startswith("intact") or label in ("marked noise=0.001", "marked prusa-export")
            if (must_claim and read["exit"] != 0) or (label.startswith("unmarked") and read["exit"] == 0):
                failures.append(f"{row['name']}: {label} exit {read['exit']}")

    marked = [r for r in rows if r["embed_exit"] == 0]
    print(f"\n{len(rows)} files: {len(marked)} marked "
          f"({sum(1 for r in marked if r['shortened_to_span'])} with a mark shortened to the modes they span), "
          f"{sum(1 for r in rows if r['embed_exit'] == 3)} refused (too few usable vertices), "
          f"{sum(1 for r in rows if r['embed_exit'] == 4 and 'span only' in r.get('embed_error', ''))} refused "
          f"(vertices spanning too few modes), "
          f"{sum(1 for r in rows if r['embed_exit'] not in (0, 3) and 'span only' not in r.get('embed_error', ''))} "
          f"other embed errors")
    labels = sorted({label for r in marked for label in r["reads"]})
    for label in labels:
        reads = [r["reads"][label] for r in marked if label in r["reads"]]
        claimed = sum(1 for read in reads if read["exit"] == 0)
        zs = [read["z"] for read in reads if read["z"] is not None]
        low = f", smallest z {min(zs):.2f}" if zs else ""
        print(f"  {label}: {claimed}/{len(reads)} claimed{low}")
    if args.json_file:
        pathlib.Path(args.json_file).write_text(json.dumps(rows, indent=1))
    if failures:
        print("\nFAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()
