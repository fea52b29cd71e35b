#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""N names issued on one key from N parallel calls to the issuing service, against one call
naming all N (issue 50's throughput target, with issue 54's service).

A catalogue of one asset (the shared bunny.stl by default) is made once; `meshmark serve` is
started on it and the asset warmed with one request. Then, repetition after repetition,
alternating:
  one call:  `meshmark catalog issue CAT ASSET --recipients names.txt -o out/{recipient}.EXT`
             (N new names; a process that reads the original, builds its basis, records the
             names in one transaction and writes N files, each fsync'ed);
  parallel:  N HTTP clients started together (threads, one connection each), each asking the
             service for a copy for a new name; the wall time until the last copy is received.
Each name's record is committed before its copy is made, in both. The service returns bytes
and writes no file: that, the warm basis and no process start are what make it faster.
Prints the medians and the per-pair ratios (parallel / one call).

  python3 bench/issuing/service_throughput.py --names 16 --repetitions 7
"""
import argparse
import http.client
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from concurrent_issue import default_cli, default_mesh  # noqa: E402


def start_service(cli, catalog, log):
    proc = subprocess.Popen([cli, "serve", "--catalog", str(catalog), "--listen", "127.0.0.1:0"],
                            stderr=open(log, "w"))
    for _ in range(400):
        text = Path(log).read_text()
        if "serving" in text:
            return proc, int(text.split("http://127.0.0.1:")[1].split()[0])
        if proc.poll() is not None:
            raise SystemExit(f"meshmark serve exited {proc.returncode}: {text}")
        time.sleep(0.025)
    raise SystemExit("meshmark serve did not start")


def request(port, token, asset, name, sizes, errors):
    try:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
        conn.request("POST", f"/v1/assets/{asset}/copies", json.dumps({"recipient": name}),
                     {"Authorization": f"Bearer {token}"})
        r = conn.getresponse()
        body = r.read()
        if r.status != 200:
            errors.append(f"{name}: {r.status} {body[:200]!r}")
        sizes.append(len(body))
        conn.close()
    except OSError as e:
        errors.append(f"{name}: {e}")


def parallel(port, token, asset, names):
    sizes, errors = [], []
    threads = [threading.Thread(target=request, args=(port, token, asset, n, sizes, errors)) for n in names]
    start = time.monotonic()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    elapsed = time.monotonic() - start
    if errors:
        raise SystemExit(f"parallel requests failed: {errors[:3]}")
    return elapsed


def one_call(cli, catalog, asset, names, work, ext):
    listed = work / "names.txt"
    listed.write_text("\n".join(names) + "\n")
    out = work / "out"
    shutil.rmtree(out, ignore_errors=True)
    start = time.monotonic()
    subprocess.run([cli, "catalog", "issue", str(catalog), asset, "--recipients", str(listed), "-o",
                    str(out / ("{recipient}" + ext)), "-q"], check=True)
    return time.monotonic() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--mesh", default=str(default_mesh()))
    parser.add_argument("--names", type=int, default=16)
    parser.add_argument("--repetitions", type=int, default=7)
    args = parser.parse_args()
    mesh = Path(args.mesh)
    work = Path(tempfile.mkdtemp(prefix="meshmark-service-throughput-"))
    proc = None
    try:
        (work / "assets").mkdir()
        shutil.copy(mesh, work / "assets" / mesh.name)
        catalog = work / "catalog.db"
        subprocess.run([args.cli, "catalog", "add", str(catalog), str(work / "assets"), "-o",
                        str(work / "published"), "-q"], check=True)
        proc, port = start_service(args.cli, catalog, work / "serve.log")
        token = Path(str(catalog) + ".token").read_text().strip()
        asset = mesh.name
        parallel(port, token, asset, ["warm"])
        ones, pars, ratios = [], [], []
        for rep in range(args.repetitions):
            a = one_call(args.cli, catalog, asset, [f"one{rep}-{i}" for i in range(args.names)], work, mesh.suffix)
            b = parallel(port, token, asset, [f"par{rep}-{i}" for i in range(args.names)])
            ones.append(a)
            pars.append(b)
            ratios.append(b / a)
        proc.send_signal(15)
        if proc.wait(timeout=60) != 0:
            raise SystemExit("meshmark serve did not stop with exit code 0")
        proc = None
        result = {"mesh": mesh.name, "names": args.names, "repetitions": args.repetitions,
                  "one_call_s_median": round(statistics.median(ones), 4),
                  "parallel_service_s_median": round(statistics.median(pars), 4),
                  "ratio_per_pair_min": round(min(ratios), 3), "ratio_per_pair_max": round(max(ratios), 3),
                  "one_call_s": [round(x, 4) for x in ones], "parallel_service_s": [round(x, 4) for x in pars]}
        print(json.dumps(result, indent=2))
        return 0
    finally:
        if proc is not None:
            proc.kill()
            proc.wait()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
