#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Identification and speed of `meshmark catalog scan` on a catalogue (issue 53).

Given a catalogue made by `catalog add` (its published copies under PUBLISHED), makes suspects:
  - marked: --marked published copies chosen at random, each attacked by one chain of the
    attack suite (cycled: similarity, noise, simplification, remeshing, smoothing, crops to 75%
    and 50%), and --issued recipient copies (`catalog issue`, then attacked the same way);
  - made by Blender (--blender OP...): --blender-assets other published copies, each re-worked
    by every OP of bench/blender/attacks.py (Blender's importers, modifiers and writers: no
    meshmark code touches them);
  - unmarked: --unmarked meshes never marked, given as files or folders (--lookalikes: e.g.
    near-duplicate variants of the catalogue's sources that were not added);
then scans them all in one `catalog scan --json` call and reports, as JSON: for marked suspects
the share found with the right asset (and recipient), per attack; for unmarked ones the number
claimed (must be 0); the median and quartiles of the seconds per suspect.

  python3 bench/catalog/scan_bench.py CATALOG PUBLISHED --marked 60 --issued 20 \\
      --lookalikes /tmp/lookalikes --unmarked 40
"""
import argparse
import json
import random
import shutil
import sqlite3
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ATTACKS = ["similarity", "similarity,noise=0.0005", "simplify=0.5,similarity", "remesh=0.8",
           "smooth=5", "crop=0.75,similarity", "crop=0.5,similarity"]


def default_cli():
    return str(Path(__file__).resolve().parents[2] / "build" / "bin" / "meshmark")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("catalog")
    parser.add_argument("published")
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--compare-cli", metavar="CLI",
                        help="also scan the same suspects with this other build (its figures under \"compare\")")
    parser.add_argument("--marked", type=int, default=40)
    parser.add_argument("--issued", type=int, default=10)
    parser.add_argument("--lookalikes", nargs="*", default=[])
    parser.add_argument("--unmarked", type=int, default=20)
    parser.add_argument("--blender", nargs="*", default=[], metavar="OP",
                        help="bench/blender/attacks.py operations, e.g. obj transform decimate=0.5 smooth "
                             "bisect voxel=300")
    parser.add_argument("--blender-assets", type=int, default=12)
    parser.add_argument("--blender-cli", default="blender")
    parser.add_argument("--candidates", type=int, default=8)
    parser.add_argument("--attacks", nargs="+", default=ATTACKS, metavar="SPEC",
                        help="the attack chains cycled over the marked suspects (default: the suite above)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--work", help="folder for the suspects (default: a temporary one)")
    parser.add_argument("--reuse", action="store_true",
                        help="keep the suspects an earlier run with the same --work and --seed made there "
                             "(scan them again, e.g. with another build)")
    parser.add_argument("--without-points", action="store_true",
                        help="also scan the same suspects against a copy of the (SQLite) catalogue whose "
                             "signatures lack the points' section: the shape index's ranking alone")
    parser.add_argument("--claimable", action="store_true",
                        help="for every marked suspect missed, run `meshmark detect` told the right original "
                             "at the scan's level: is it claimable at all?")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    cli = args.cli
    assets = [a for a in json.loads(subprocess.run([cli, "catalog", "list", args.catalog, "--json"], check=True,
                                                   capture_output=True, text=True).stdout)["assets"] if a["complete"]]
    work = Path(args.work or tempfile.mkdtemp(prefix="meshmark-scan-"))
    work.mkdir(parents=True, exist_ok=True)
    truth = {}  # suspect path -> (asset, recipient, attack) or None
    chosen = rng.sample(assets, min(len(assets), args.marked + args.issued))
    for n, asset in enumerate(chosen):
        attack = args.attacks[n % len(args.attacks)]
        source = Path(asset["published"])
        recipient = "published" if n < args.marked else f"buyer{n}"
        suspect = work / f"suspect{n}.ply"
        if args.reuse and suspect.exists():
            truth[str(suspect)] = (asset["asset"], recipient, attack)
            continue
        if n >= args.marked:
            pattern = str(work / f"issued{n}-{{recipient}}{source.suffix}")
            subprocess.run([cli, "catalog", "issue", args.catalog, asset["asset"], "--recipient", recipient,
                            "-o", pattern, "-q"], check=True)
            source = Path(pattern.replace("{recipient}", recipient))
        done = subprocess.run([cli, "attack", str(source), attack, "-o", str(suspect), "--seed", str(n), "-q"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            print(f"scan_bench: {attack} on {source}: {done.stderr.strip()}", file=sys.stderr)
            continue
        truth[str(suspect)] = (asset["asset"], recipient, attack)
    if args.blender:
        attacks_py = Path(__file__).resolve().parents[1] / "blender" / "attacks.py"
        sys.path.insert(0, str(attacks_py.parent))
        from rework import blender_environment  # Blender's Python then finds the system's numpy
        others = [a for a in assets if a not in chosen]
        for n, asset in enumerate(rng.sample(others, min(len(others), args.blender_assets))):
            out = work / f"blender{n}"
            out.mkdir(parents=True, exist_ok=True)
            done = subprocess.run([args.blender_cli, "-b", "--factory-startup", "--python-exit-code", "2",
                                   "--python", str(attacks_py), "--", asset["published"], str(out),
                                   "--seed", str(n), *args.blender], capture_output=True, text=True,
                                  env=blender_environment())
            if done.returncode != 0:
                print(f"scan_bench: Blender on {asset['published']}: {done.stderr.strip()[-300:]}",
                      file=sys.stderr)
                continue
            for made in json.loads((out / "attacks.json").read_text()):
                truth[str(out / Path(made["output"]).name)] = (asset["asset"], "published",
                                                                "blender " + made["op"])
    lookalikes = []
    for item in args.lookalikes:
        p = Path(item)
        lookalikes += sorted(p.rglob("*.ply")) if p.is_dir() else [p]
    for p in rng.sample(lookalikes, min(len(lookalikes), args.unmarked)):
        truth[str(p)] = None
    results = {"catalog": summary(cli, args, args.catalog, truth, work)}
    if args.compare_cli:
        results["compare"] = summary(args.compare_cli, args, args.catalog, truth, work)
    if args.without_points:
        stripped = work / "without-points.db"
        shutil.copyfile(args.catalog, stripped)
        with sqlite3.connect(stripped) as db:
            # the views alone: 257 views of 30 bytes (ShapeSignature::to_bytes)
            db.execute("UPDATE assets SET shape = substr(shape, 1, 7710) WHERE length(shape) > 7710")
        results["without_points"] = summary(cli, args, str(stripped), truth, work)
    print(json.dumps(results if len(results) > 1 else results["catalog"], indent=1))
    return 0


def claimable(cli, catalog, assets, suspect, asset, work):
    """Whether `meshmark detect` told the right original claims \p suspect at the scan's level."""
    key = work / f"key-{abs(hash(asset))}.json"
    subprocess.run([cli, "catalog", "export", catalog, asset, "--key", str(key), "--force", "-q"], check=True)
    original = next(a["original"] for a in assets if a["asset"] == asset)
    done = subprocess.run([cli, "detect", suspect, "--original", original, "--key", str(key), "--max-fpp",
                           str(1e-6 / len(assets)), "-q"], capture_output=True, text=True)
    return done.returncode == 0


def summary(cli, args, catalog, truth, work):
    scan = subprocess.run([cli, "catalog", "scan", catalog, *truth, "--json", "--candidates",
                           str(args.candidates), "-q"], capture_output=True, text=True)
    report = json.loads(scan.stdout)
    assets = json.loads(subprocess.run([cli, "catalog", "list", catalog, "--json"], check=True,
                                       capture_output=True, text=True).stdout)["assets"]
    per_attack, claimed, times, misses = {}, 0, [], []
    for s in report["suspects"]:
        times.append(s["seconds"]["total"])
        expected = truth[s["path"]]
        got = s["matches"][0] if s["matches"] else None
        if expected is None:
            claimed += 1 if got else 0
            continue
        asset, recipient, attack = expected
        ok = bool(got) and got["asset"] == asset and [r["name"] for r in got["recipients"]][:1] == [recipient]
        row = per_attack.setdefault(attack, [0, 0])
        row[0] += ok
        row[1] += 1
        if not ok:
            ranks = [t["asset"] for t in s["tried"]]
            miss = {"suspect": s["path"], "asset": asset, "attack": attack,
                    "found": got["asset"] if got else None,
                    "tried_rank": ranks.index(asset) if asset in ranks else None}
            if args.claimable:
                miss["claimable"] = claimable(cli, catalog, assets, s["path"], asset, work)
            misses.append(miss)
    times.sort()
    q = statistics.quantiles(times, n=4) if len(times) > 1 else times * 3
    marked = sum(v[1] for v in per_attack.values())
    found = sum(v[0] for v in per_attack.values())
    out = {"assets": report["assets"], "suspects": len(times), "marked": marked, "found": found,
           "per_attack": {k: f"{v[0]}/{v[1]}" for k, v in per_attack.items()},
           "unmarked": len(times) - marked, "unmarked_claimed": claimed,
           "seconds_per_suspect": {"median": round(statistics.median(times), 3), "q1": round(q[0], 3),
                                   "q3": round(q[2], 3), "max": round(times[-1], 3)},
           "misses": misses}
    if args.claimable:
        out["missed_claimable"] = sum(1 for m in misses if m["claimable"])
    return out


if __name__ == "__main__":
    sys.exit(main())
