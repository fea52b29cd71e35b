#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Collusion study of meshmark's recipient copies (docs/fingerprinting.md).

For each mesh: issue N recipient copies in one `meshmark embed --recipient` call, then for
each number of colluders c and each post-processing, build T suspects from c copies chosen at
random, run `meshmark detect --json` with the family key and count the trials where at least
one colluder is accused and those where an innocent is. Also: the unmarked original after each
post-processing (nobody may be accused).

Colluder attacks (vertex for vertex; the copies share the original's connectivity):
  average   the c copies averaged vertex by vertex;
  splice    each vertex taken from one copy, the model cut into c slabs along its longest axis;
  splice-any  the same along a random direction (drawn per trial).
Post-processing after the attack: none, or any `meshmark attack` chain (e.g. noise=0.001,
simplify=0.3).

Usage: collusion.py --mesh M.ply [--mesh ...] [--recipients 100] [--colluders 2,3,4,8] [--embed-args "..."]
       [--trials 20] [--post "none;noise=0.001;simplify=0.3"] [--mode average,splice,splice-any]
       [--key-recipients 10000] [--meshmark build/bin/meshmark] [--json-file out.json]
Reads and writes meshes with Open3D (python3-open3d); PLY copies keep the vertex order.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time

import numpy as np
import open3d as o3d


def run(cmd):
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode not in (0, 1):
        sys.exit(f"collusion.py: {' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()}")
    return proc


def read_positions(path):
    mesh = o3d.io.read_triangle_mesh(path)
    return mesh, np.asarray(mesh.vertices, dtype=np.float64)


def write_positions(template, positions, path):
    out = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(positions), template.triangles)
    if not o3d.io.write_triangle_mesh(path, out):
        sys.exit(f"collusion.py: cannot write {path}")


REGIONS = 28  # Detector::kRegionCount


def rademacher(z):
    if z <= 0:
        return 1.0
    return min(1.0, math.exp(-z * z / 2), 2 * math.exp(3) / 9 * 0.5 * math.erfc(z / math.sqrt(2)))


def tail_bound(entry):
    """The accusation's per-recipient bound before the factor R (docs/fingerprinting.md), from the
    formula alone. Since 2026-11-27 the trace counts the whole-model statistics' tails for their
    weights (smaller, docs/statistics.md, "The tail counted for the weights at hand"), which the
    recorded scores cannot recompute: this null check is of the formula's bound, the looser one."""
    whole = 3 * rademacher(entry["score"])
    if "region_score" not in entry:
        return min(1.0, whole)
    return min(1.0, 2 * whole, 2 * REGIONS * rademacher(entry["region_score"]))


def collude(mode, copies, original, rng):
    if mode == "average":
        return sum(copies) / len(copies)
    # splice: slab s along the longest axis (or a random direction) comes from copy s
    if mode == "splice":
        direction = np.zeros(3)
        direction[int(np.argmax(original.max(0) - original.min(0)))] = 1.0
    else:
        direction = np.array([rng.gauss(0, 1) for _ in range(3)])
        direction /= np.linalg.norm(direction)
    height = original @ direction
    edges = np.quantile(height, np.linspace(0, 1, len(copies) + 1))
    slab = np.clip(np.searchsorted(edges, height, side="right") - 1, 0, len(copies) - 1)
    out = np.empty_like(original)
    for s, copy in enumerate(copies):
        out[slab == s] = copy[slab == s]
    return out


def detect(args, suspect, original, key):
    proc = run([args.meshmark, "detect", suspect, "--original", original, "--key", key, "--json", "-q", "-v",
                "--threads", str(args.threads)])
    return json.loads(proc.stdout)


def study_mesh(args, mesh_path, work):
    name = os.path.basename(mesh_path)
    original_ply = os.path.join(work, "original.ply")
    template, original = read_positions(mesh_path)
    write_positions(template, original, original_ply)  # the copies and the suspects share this layout
    key = os.path.join(work, "family.json")
    names = [f"r{i:05d}" for i in range(args.recipients)]
    listing = os.path.join(work, "recipients.txt")
    with open(listing, "w") as f:
        f.write("\n".join(names) + "\n")
    start = time.time()
    proc = run([args.meshmark, "embed", original_ply, "-o", os.path.join(work, "{recipient}.ply"), "--key", key,
                "--recipients", listing, "--seed", str(args.seed), "--json", "-q", "--threads", str(args.threads)]
               + args.embed_args.split())
    issued = json.loads(proc.stdout)
    issue_seconds = time.time() - start
    rms = max(c["rms_displacement"] for c in issued["copies"])
    print(f"{name}: {len(original)} vertices, {args.recipients} copies issued in {issue_seconds:.2f} s "
          f"(wall, one call), RMS displacement at most {100 * rms:.4f}% of the diagonal", flush=True)
    if args.key_recipients > args.recipients:
        # Never-issued recipients join the key: every one of them is an innocent of every trial.
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from grow_key import grow
        total = grow(key, key, args.key_recipients, prefix="x")
        print(f"  key grown to {total} recipients ({total - args.recipients} never issued)", flush=True)
    copies = {}

    def copy_of(r):
        if r not in copies:
            copies[r] = read_positions(os.path.join(work, f"{r}.ply"))[1]
        return copies[r]

    rng = random.Random(args.seed)
    rows = []
    innocent_scores = []  # every innocent recipient's score in every trial (the null study)
    suspect = os.path.join(work, "suspect.ply")
    attacked = os.path.join(work, "attacked.ply")
    for post in args.post:
        # The unmarked original: nobody may be accused.
        target = original_ply
        if post != "none":
            run([args.meshmark, "attack", original_ply, "-o", attacked, "--seed", "1", "-q", post])
            target = attacked
        report = detect(args, target, original_ply, key)
        rows.append({"mesh": name, "mode": "unmarked", "post": post, "colluders": 0, "trials": 1,
                     "caught": 0, "innocents_accused": len(report["recipients"])})
        innocent_scores += report["recipient_scores"]
        for mode in args.mode:
            for c in args.colluders:
                caught = framed = 0
                colluder_best = []
                innocent_max = -1e9
                for t in range(args.trials):
                    chosen = rng.sample(names, c)
                    write_positions(template, collude(mode, [copy_of(r) for r in chosen], original, rng), suspect)
                    target = suspect
                    if post != "none":
                        run([args.meshmark, "attack", suspect, "-o", attacked, "--seed", str(t + 1), "-q", post])
                        target = attacked
                    report = detect(args, target, original_ply, key)
                    accused = {r["name"] for r in report["recipients"]}
                    caught += bool(accused & set(chosen))
                    framed += bool(accused - set(chosen))
                    scores = {r["name"]: r for r in report["recipient_scores"]}
                    colluder_best.append(max(scores[r]["score"] for r in chosen))
                    innocent_scores += [e for r, e in scores.items() if r not in chosen]
                row = {"mesh": name, "mode": mode, "post": post, "colluders": c, "trials": args.trials,
                       "caught": caught, "innocents_accused": framed,
                       "median_best_colluder_score": float(np.median(colluder_best))}
                rows.append(row)
                print(f"  {mode:10s} c={c} post={post:14s} at least one colluder accused {caught}/{args.trials}, "
                      f"trials with an innocent accused {framed}, median best colluder z "
                      f"{row['median_best_colluder_score']:.2f}", flush=True)
    # The null study: innocents' per-recipient bounds against their levels.
    null = {"innocent_scores": len(innocent_scores),
            "largest_innocent_score": max(e["score"] for e in innocent_scores),
            "largest_innocent_region_score": max(e.get("region_score", 0.0) for e in innocent_scores),
            "share_with_bound_at_most": {}}
    for alpha in (0.5, 0.1, 0.01, 0.001, 1e-4):
        share = sum(tail_bound(e) <= alpha for e in innocent_scores) / len(innocent_scores)
        null["share_with_bound_at_most"][str(alpha)] = share
    print(f"  null: {len(innocent_scores)} innocent scores, largest z {null['largest_innocent_score']:.2f} "
          f"(regions {null['largest_innocent_region_score']:.2f}), "
          f"share with per-recipient bound <= alpha: " +
          ", ".join(f"{a}: {v:.4f}" for a, v in null["share_with_bound_at_most"].items()), flush=True)
    return {"mesh": name, "vertices": len(original), "recipients": args.recipients,
            "key_recipients": max(args.recipients, args.key_recipients),
            "issue_seconds": issue_seconds, "max_rms_displacement": rms, "rows": rows, "null": null}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mesh", action="append", required=True)
    parser.add_argument("--recipients", type=int, default=100)
    parser.add_argument("--colluders", default="2,3,4,8")
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--post", default="none;noise=0.001;simplify=0.3",
                        help="post-processings separated by ;, each none or a meshmark attack chain")
    parser.add_argument("--mode", default="average,splice")
    parser.add_argument("--seed", type=int, default=17)
    parser.add_argument("--embed-args", default="",
                        help="more options of meshmark embed, e.g. \"--basis-size 160 --recipient-modes 120\"")
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--key-recipients", type=int, default=0,
                        help="grow the key to this many recipients after issuing (bench/fingerprint/grow_key.py): "
                             "tracing and the bound then cover them all, the colluders coming from the issued ones")
    parser.add_argument("--meshmark", default=os.path.join(os.path.dirname(__file__), "../../build/bin/meshmark"))
    parser.add_argument("--json-file")
    args = parser.parse_args()
    args.colluders = [int(c) for c in args.colluders.split(",")]
    args.post = args.post.split(";")
    args.mode = args.mode.split(",")
    results = []
    for mesh in args.mesh:
        with tempfile.TemporaryDirectory(prefix="meshmark-collusion-") as work:
            results.append(study_mesh(args, mesh, work))
    if args.json_file:
        with open(args.json_file, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
