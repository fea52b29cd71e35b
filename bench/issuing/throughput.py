#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Issuing N names on one family key: one call naming all N against N calls at once (issue 50).

Per repetition and mode, a fresh family key is made with `--recipient alice` (not timed), then
the N names are issued by one `meshmark embed --recipients names.txt` call; by N
`meshmark embed --recipient NAME` processes started together (each waits for the key's lock
only to record its name; the basis of the original is built by each process); and by the same
N calls one after another. The modes alternate, repetition after repetition, so that all see
the same machine. Prints the medians, the per-pair ratios (parallel / one call), and the
parallel calls' --json phases summed over the calls ("lock": time spent waiting for the key).

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


def separate_calls(cli, mesh, work, names, parallel):
    """One call per name, all started together (parallel) or one after another. Returns the
    wall time and the calls' --json phase seconds, summed over the calls."""
    key = fresh_key(cli, mesh, work)
    start = time.monotonic()
    words = [[cli, "embed", mesh, "--key", str(key), "-o", str(work / "copies" / "{recipient}.ply"),
              "--recipient", name, "--quiet", "--json"] for name in names]
    outputs = []
    if parallel:
        procs = [subprocess.Popen(w, stdout=subprocess.PIPE, text=True) for w in words]
        outputs = [(p.communicate()[0], p.returncode) for p in procs]
    else:
        for w in words:
            done = subprocess.run(w, stdout=subprocess.PIPE, text=True)
            outputs.append((done.stdout, done.returncode))
    seconds = time.monotonic() - start
    if any(code for _, code in outputs):
        raise SystemExit(f"a call failed: exit codes {[code for _, code in outputs]}")
    phases = {}
    for out, _ in outputs:
        for name, value in json.loads(out)["seconds"].items():
            phases[name] = phases.get(name, 0.0) + value
    return seconds, phases


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--mesh", default=default_mesh())
    parser.add_argument("--names", type=int, default=16)
    parser.add_argument("--repetitions", type=int, default=5)
    args = parser.parse_args()
    names = [f"buyer{i:03d}" for i in range(args.names)]
    work = Path(tempfile.mkdtemp(prefix="meshmark-throughput-"))
    one, many, serial = [], [], []
    phases = []
    try:
        for _ in range(args.repetitions):
            one.append(one_call(args.cli, args.mesh, work / "one", names))
            seconds, summed = separate_calls(args.cli, args.mesh, work / "many", names, parallel=True)
            many.append(seconds)
            phases.append(summed)
            serial.append(separate_calls(args.cli, args.mesh, work / "serial", names, parallel=False)[0])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    ratios = [m / o for m, o in zip(many, one)]
    median_phases = {name: round(statistics.median(p[name] for p in phases), 3) for name in phases[0]}
    report = {
        "mesh": args.mesh,
        "names": args.names,
        "cores": os.cpu_count(),
        "one_call_seconds": [round(s, 3) for s in one],
        "parallel_calls_seconds": [round(s, 3) for s in many],
        "calls_one_after_another_seconds": [round(s, 3) for s in serial],
        "parallel_calls_phase_seconds_summed_over_calls": median_phases,
        "one_call_median": round(statistics.median(one), 3),
        "parallel_calls_median": round(statistics.median(many), 3),
        "ratio_per_pair": [round(r, 2) for r in ratios],
        "ratio_median": round(statistics.median(ratios), 2),
        "one_after_another_median": round(statistics.median(serial), 3),
    }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
