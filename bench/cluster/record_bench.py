#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The coordinator's cap (docs/cluster.md, "How far it scales"): how many marked assets a second
meshmark.cluster's coordinator records, one at a time against several recorder threads.

    PYTHONPATH=build/python /usr/bin/python3 bench/cluster/record_bench.py CORPUS [--recorders 1 4]

Plans a `catalog add` of CORPUS (a folder of mesh files), marks every task once in this process
(_catalog_mark, as a worker would; not timed), then records the same marked results into a
fresh catalogue and output folder per configuration (_catalog_record, as catalog_add(client=)
does: N threads at once), alternating the configurations --repeats times. Prints assets/s per
run and checks that every configuration's output folder is the same, byte for byte.
"""
import argparse
import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from meshmark import _meshmark


def tree_digest(folder):
    digest = hashlib.sha256()
    for path in sorted(p for p in Path(folder).rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def retarget(text, output):
    """A task planned for one output folder, made to write into \\p output instead."""
    task = json.loads(text)
    old = task["output_folder"]
    task["output_folder"] = str(output)
    task["published"] = str(output) + task["published"][len(old):]
    return json.dumps(task)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("corpus")
    parser.add_argument("--recorders", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--work-dir", default=None)
    args = parser.parse_args()
    work = Path(args.work_dir or tempfile.mkdtemp(prefix="meshmark-record-bench-"))
    work.mkdir(parents=True, exist_ok=True)
    plan_catalog = _meshmark.Catalog(str(work / "plan.db"), create=True)
    _, tasks = _meshmark._catalog_plan_add(plan_catalog, [args.corpus], str(work / "planned"),
                                           seed=7)
    started = time.monotonic()
    marked = [(text, _meshmark._catalog_mark(text, 2)) for text, _ in tasks]
    print(f"{len(marked)} tasks marked in {time.monotonic() - started:.1f} s (not timed below)",
          flush=True)
    rows, digests = [], {}
    for repeat in range(args.repeats):
        for recorders in args.recorders:
            name = f"r{repeat}-{recorders}"
            output = work / f"out-{name}"
            catalog = _meshmark.Catalog(str(work / f"{name}.db"), create=True)
            jobs = [(retarget(text, output), result) for text, result in marked]
            start = time.monotonic()
            with ThreadPoolExecutor(max_workers=recorders) as pool:
                outcomes = list(pool.map(
                    lambda job: _meshmark._catalog_record(catalog, job[0], *job[1]), jobs))
            seconds = time.monotonic() - start
            counts = {}
            for o in outcomes:
                status = json.loads(o)["outcome"]
                counts[status] = counts.get(status, 0) + 1
            digests[name] = tree_digest(output)
            rows.append((name, recorders, seconds, len(jobs) / seconds, counts))
            print(f"{name}: {recorders} recorder(s), {seconds:.2f} s, "
                  f"{len(jobs) / seconds:.1f} assets/s, {counts}", flush=True)
    same = len(set(digests.values())) == 1
    print("every output folder identical" if same else f"OUTPUT FOLDERS DIFFER: {digests}")
    for recorders in args.recorders:
        rates = sorted(r[3] for r in rows if r[1] == recorders)
        print(f"{recorders} recorder(s): median {rates[len(rates) // 2]:.1f} assets/s")
    if not args.work_dir:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
