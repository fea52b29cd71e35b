#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Issuing N names on one family key: one call naming all N against N calls at once (issue 50).

Per repetition and mode, a fresh family key is made with `--recipient alice` (not timed), then
the N names are issued either by one `meshmark embed --recipients names.txt` call, or by N
`meshmark embed --recipient NAME` processes started together (each waits for the key's lock
only to record its name; the basis of the original is built by each process). The two modes
alternate, repetition after repetition, so that both see the same machine. Prints the
medians, the per-pair ratios (parallel / one call) and the JSON of every run.

  python3 bench/issuing/throughput.py --names 16 --repetitions 5              # the shared bunny.stl
  python3 bench/issuing/throughput.py --names 16 --mesh ../shared/data/meshes/dragon_vrip_res3.ply
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from concurrent_issue import default_cli, default_mesh  # noqa: E402


def fresh_key(cli, mesh, work):
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    key = work / "fam.json"
    subprocess.run([cli, "embed", mesh, "--key", str(key), "-o", str(work / "first-{recipient}.ply"),
                    "--recipient", "alice", "--quiet"], check=True)
    return key


def one_call(cli, mesh, work, names):
    key = fresh_key(cli, mesh, work)
    listed = work / "names.txt"
    listed.write_text("\n".join(names) + "\n")
    start = time.monotonic()
    subprocess.run([cli, "embed", mesh, "--key", str(key), "-o", str(work / "copies" / "{recipient}.ply"),
                    "--recipients", str(listed), "--quiet"], check=True)
    return time.monotonic() - start


def parallel_calls(cli, mesh, work, names):
    key = fresh_key(cli, mesh, work)
    start = time.monotonic()
    procs = [subprocess.Popen([cli, "embed", mesh, "--key", str(key), "-o", str(work / "copies" / "{recipient}.ply"),
                               "--recipient", name, "--quiet"]) for name in names]
    codes = [p.wait() for p in procs]
    seconds = time.monotonic() - start
    if any(codes):
        raise SystemExit(f"a parallel call failed: exit codes {codes}")
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--mesh", default=default_mesh())
    parser.add_argument("--names", type=int, default=16)
    parser.add_argument("--repetitions", type=int, default=5)
    args = parser.parse_args()
    names = [f"buyer{i:03d}" for i in range(args.names)]
    work = Path(tempfile.mkdtemp(prefix="meshmark-throughput-"))
    one, many = [], []
    try:
        for _ in range(args.repetitions):
            one.append(one_call(args.cli, args.mesh, work / "one", names))
            many.append(parallel_calls(args.cli, args.mesh, work / "many", names))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    ratios = [m / o for m, o in zip(many, one)]
    report = {
        "mesh": args.mesh,
        "names": args.names,
        "cores": os.cpu_count(),
        "one_call_seconds": [round(s, 3) for s in one],
        "parallel_calls_seconds": [round(s, 3) for s in many],
        "one_call_median": round(statistics.median(one), 3),
        "parallel_calls_median": round(statistics.median(many), 3),
        "ratio_per_pair": [round(r, 2) for r in ratios],
        "ratio_median": round(statistics.median(ratios), 2),
    }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
