#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The catalogue through the command line, as a marketplace would drive it (issue 53).

1. `catalog add` of a folder of real meshes, timed; then --kills times an add of the same folder
   into a catalogue of its own, killed with SIGKILL at a random moment of that time and run to
   the end; after each kill and each run to the end:
     - the catalogue loads (`catalog list --json`);
     - every asset listed complete has its published copy on disk, and every visible file
       under the output folder is the published copy of an asset listed (nothing written
       unrecorded, nothing recorded complete unwritten); a visible copy of an asset not yet
       complete (killed between the copy's rename and the `complete` mark) is the copy the
       run to the end leaves, byte for byte;
   each run to the end reports every file marked or present, and a further add of the first
   catalogue only "present"; `catalog reindex --all` writes every signature again, byte for byte.
2. --issuers `catalog issue` processes at once on one asset, each a name of its own and one
   shared name: every call exits 0 and the catalogue holds every name once, codes distinct.
   Then an issue and a scan are killed with SIGKILL: every visible copy's name is recorded, and
   the issue run again delivers every name.
3. `catalog scan` of an attacked recipient copy (exit 0, its asset and recipient), of an
   attacked published copy (exit 0, "published") and of an unmarked mesh (exit 1).
Prints a JSON summary; exit 0 when every check held, 77 without the shared meshes.

Full run:  python3 bench/catalog/catalog_check.py --kills 20 --issuers 16
The test suite runs a short version (tests/integration/CMakeLists.txt, catalog_smoke).
"""
import argparse
import hashlib
import json
import os
import random
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MESHES = ["bunny.off", "spot.obj", "fandisk.obj", "beetle.obj", "rocker-arm.obj", "teapot.obj",
          "decimated-max.obj", "horse.ply"]


def default_cli():
    here = Path(__file__).resolve().parents[2]
    return os.environ.get("MESHMARK_CLI") or str(here / "build" / "bin" / "meshmark")


def mesh_dir():
    return Path(os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
                or Path(__file__).resolve().parents[3] / "shared" / "data" / "meshes")


def run(cli, *args, check=True):
    p = subprocess.run([cli, *args], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise SystemExit(f"meshmark {' '.join(args)} exited {p.returncode}: {p.stderr.strip()}")
    return p


def listed(cli, catalog):
    return json.loads(run(cli, "catalog", "list", catalog, "--json").stdout)["assets"]


def consistent(cli, catalog, out):
    """Problems (strings) between the catalogue and the output folder."""
    problems = []
    assets = listed(cli, catalog)
    complete = {Path(a["published"]).resolve() for a in assets if a["complete"]}
    recorded = {Path(a["published"]).resolve() for a in assets}
    for p in complete:
        if not p.exists():
            problems.append(f"recorded complete but missing: {p}")
    interrupted = {}  # visible copies of assets not yet complete: path -> sha256
    if out.exists():
        for f in out.rglob("*"):
            if not f.is_file() or f.name.startswith(".") or f.suffix.lower() == ".mtl":
                continue
            if f.resolve() not in recorded:
                problems.append(f"written but not recorded: {f}")
            elif f.resolve() not in complete:
                interrupted[f.resolve()] = sha256(f)
    return problems, len(assets), len(complete), interrupted


def sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--kills", type=int, default=3)
    parser.add_argument("--issuers", type=int, default=4)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    src = mesh_dir()
    if not all((src / m).exists() for m in MESHES):
        print(f"catalog_check: skipped, the shared meshes are not in {src}", file=sys.stderr)
        return 77
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="meshmark-catalog-"))
    summary = {"kills": [], "problems": []}
    try:
        originals = work / "originals"
        originals.mkdir()
        for m in MESHES:
            shutil.copy(src / m, originals / m)
        catalog, out = str(work / "cat.db"), work / "published"

        def add_command(catalog, out):
            return [args.cli, "catalog", "add", catalog, str(originals), "-o", str(out), "--json", "-q"]

        # 1. The whole add, timed; then --kills adds of their own catalogues, each killed at a
        # random moment of that time and run to the end.
        started = time.monotonic()
        final = json.loads(subprocess.run(add_command(catalog, out), capture_output=True, text=True,
                                          check=True).stdout)
        whole = time.monotonic() - started
        summary["add_seconds"] = round(whole, 2)
        outcomes = {f["asset"]: f["outcome"] for f in final["files"]}
        if sorted(outcomes) != sorted(MESHES) or any(o != "marked" for o in outcomes.values()):
            summary["problems"].append(f"add: {outcomes}")
        for k in range(args.kills):
            killed_catalog, killed_out = str(work / f"kill{k}" / "cat.db"), work / f"kill{k}" / "published"
            add = add_command(killed_catalog, killed_out)
            started = time.monotonic()
            proc = subprocess.Popen(add, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            time.sleep(rng.uniform(0.02, 1.0) * whole)
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            problems, total, complete, interrupted = consistent(args.cli, killed_catalog, killed_out) \
                if Path(killed_catalog).exists() else ([], 0, 0, {})
            summary["kills"].append({"after_seconds": round(time.monotonic() - started, 2), "assets": total,
                                     "complete": complete, "interrupted_visible": len(interrupted),
                                     "problems": len(problems)})
            summary["problems"] += problems
            finished = json.loads(subprocess.run(add, capture_output=True, text=True, check=True).stdout)
            outcomes = {f["asset"]: f["outcome"] for f in finished["files"]}
            if sorted(outcomes) != sorted(MESHES) or any(o not in ("marked", "present") for o in outcomes.values()):
                summary["problems"].append(f"add after kill {k}: {outcomes}")
            problems, total, complete, left = consistent(args.cli, killed_catalog, killed_out)
            summary["problems"] += problems
            summary["problems"] += [f"left not complete after kill {k}: {p}" for p in left]
            summary["problems"] += [f"an interrupted add's visible copy was not the final one: {p}"
                                    for p, digest in interrupted.items() if sha256(p) != digest]
        again = json.loads(subprocess.run(add_command(catalog, out), capture_output=True, text=True,
                                          check=True).stdout)
        if any(f["outcome"] != "present" for f in again["files"]):
            summary["problems"].append(f"a further add did something: {again['counts']}")
        problems, total, complete, interrupted = consistent(args.cli, catalog, out)
        summary["problems"] += problems
        summary["problems"] += [f"left not complete: {p}" for p in interrupted]
        summary["assets"] = total
        # `catalog reindex --all` recomputes every signature from the originals: the same bytes.
        with sqlite3.connect(catalog) as db:
            before = dict(db.execute("SELECT id, shape FROM assets"))
        reindexed = json.loads(run(args.cli, "catalog", "reindex", catalog, "--all", "--json", "-q").stdout)
        with sqlite3.connect(catalog) as db:
            after = dict(db.execute("SELECT id, shape FROM assets"))
        if reindexed["counts"] != {"current": 0, "failed": 0, "updated": len(MESHES)} or before != after:
            summary["problems"].append(f"reindex --all: {reindexed['counts']}, same signatures: {before == after}")
        # 2. Issuers at once on one asset.
        procs = [subprocess.Popen([args.cli, "catalog", "issue", catalog, "spot.obj", "--recipient", f"buyer{i}",
                                   "--recipient", "everyone", "-o", str(work / "copies" / "{recipient}.obj"), "-q"],
                                  stderr=subprocess.PIPE, text=True) for i in range(args.issuers)]
        for i, p in enumerate(procs):
            _, err = p.communicate()
            if p.returncode != 0:
                summary["problems"].append(f"issuer {i} exited {p.returncode}: {err.strip()}")
        spot = next(a for a in listed(args.cli, catalog) if a["asset"] == "spot.obj")
        names = [r["name"] for r in spot["recipients"]]
        expected = {"published", "everyone", *(f"buyer{i}" for i in range(args.issuers))}
        if sorted(names) != sorted(expected) or not all(r["delivered"] for r in spot["recipients"]):
            summary["problems"].append(f"spot.obj recipients: {spot['recipients']}")
        # An issue killed at a random moment, and a scan: afterwards every visible copy's name is
        # recorded, and the same issue run again delivers what the killed one had not.
        kill_copies = work / "killed"
        issue = [args.cli, "catalog", "issue", catalog, "bunny.off", "-o", str(kill_copies / "{recipient}.ply"), "-q",
                 *sum((["--recipient", f"late{i}"] for i in range(6)), [])]
        for command in (issue, [args.cli, "catalog", "scan", catalog, str(out / "spot.obj"), "-q"]):
            proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            time.sleep(rng.uniform(0.05, 0.6))
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        bunny = next(a for a in listed(args.cli, catalog) if a["asset"] == "bunny.off")
        recorded = {r["name"] for r in bunny["recipients"]}
        visible = {f.stem for f in kill_copies.glob("*.ply")} if kill_copies.exists() else set()
        if not visible <= recorded:
            summary["problems"].append(f"copies without a recorded name after a kill: {sorted(visible - recorded)}")
        subprocess.run(issue, check=True)
        bunny = next(a for a in listed(args.cli, catalog) if a["asset"] == "bunny.off")
        late = [r for r in bunny["recipients"] if r["name"].startswith("late")]
        if len(late) != 6 or not all(r["delivered"] for r in late) or len({r["name"] for r in late}) != 6:
            summary["problems"].append(f"the killed issue run again: {late}")
        summary["killed_issue"] = {"visible_after_kill": len(visible), "recorded_after_kill": len(recorded)}
        # 3. Scans.
        run(args.cli, "attack", str(work / "copies" / "buyer1.obj"), "similarity,simplify=0.5",
            "-o", str(work / "leak1.ply"), "-q")
        run(args.cli, "attack", str(out / "fandisk.obj"), "crop=0.8,similarity", "-o", str(work / "leak2.ply"), "-q")
        run(args.cli, "attack", str(src / "igea.ply"), "similarity", "-o", str(work / "unrelated.ply"), "-q")
        scans = {}
        for suspect, expect in (("leak1.ply", ("spot.obj", "buyer1")), ("leak2.ply", ("fandisk.obj", "published")),
                                ("unrelated.ply", None)):
            p = run(args.cli, "catalog", "scan", catalog, str(work / suspect), "--json", "--candidates", "3",
                    check=False)
            report = json.loads(p.stdout)["suspects"][0]
            got = None
            if report["matches"]:
                m = report["matches"][0]
                got = (m["asset"], m["recipients"][0]["name"] if m["recipients"] else None)
            scans[suspect] = {"exit": p.returncode, "match": got, "seconds": round(report["seconds"]["total"], 2)}
            if got != expect or p.returncode != (0 if expect else 1):
                summary["problems"].append(f"scan {suspect}: exit {p.returncode}, {got}, expected {expect}")
        summary["scans"] = scans
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(summary, indent=1))
    return 0 if not summary["problems"] else 1


if __name__ == "__main__":
    sys.exit(main())
