#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Catalogue work on a real Dask cluster (issue 56, docs/cluster.md): a scheduler and two
worker processes on 127.0.0.1 (tests/support/dask_cluster.py), the command line and the Python
package driving them, on copies of the shared meshes (an OBJ among them names a material library
outside its folder, so its copy links back to it):

1. `catalog add --scheduler` with a seed: every file marked; every output file and every asset's
   key (`catalog export`) byte for byte those of a local `catalog add` with the same seed; the
   OBJ's `mtllib` line the local one's, reaching the library from the output folder. Run again:
   every file "present".
2. `catalog scan --scheduler` of an attacked marked copy and an unmarked original: the same
   verdicts, assets and recipients as a local scan, exit code 0.
3. `catalog issue --scheduler` of 12 recipients' copies: the local issue's codes and bytes.
4. On PostgreSQL (tests/support/postgres_server.py, when one can be started): `catalog add
   --scheduler` into a `postgresql://` catalogue leaves the local run's files and keys, and a
   `catalog scan --scheduler` through it (every worker opening the database) finds the suspect.
5. Python: Catalog.add(client=...) makes the bytes of Catalog.add() (local) with the same seed.
6. A worker killed (kill -9) while an add runs: the add completes, every asset recorded once,
   the outputs byte for byte the local run's.
7. The coordinator killed (kill -9, the command and its Python child) midway: the same call run
   again finishes, every asset complete once, outputs byte for byte the local run's.

Exit 0 when every check held (a JSON summary on stdout), 1 otherwise, 77 when no Dask cluster
can be started or the shared meshes are missing.
"""
import argparse
import filecmp
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
import dask_cluster  # noqa: E402
import postgres_server  # noqa: E402

MESHES = ["fandisk.obj", "spot.obj", "beetle.obj", "rocker-arm.obj", "teapot.obj", "bunny.off",
          "horse.ply"]
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAILED: " + message, file=sys.stderr, flush=True)
    return condition


def run(cli, *args, expect=0, cwd=None):
    done = subprocess.run([cli, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True, cwd=cwd)
    if expect is not None and done.returncode != expect:
        raise RuntimeError(f"{' '.join(map(str, args))}: exit {done.returncode}, expected "
                           f"{expect}\n{done.stderr}")
    return done


STAGING = re.compile(r"^\..+\.tmp-[A-Za-z0-9]{6}$")


def tree(folder):
    """The files under \p folder, less the hidden staging files an atomic write killed midway
    leaves (`.<name>.tmp-XXXXXX`: never read, documented in docs/reliability.md)."""
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*")
                  if p.is_file() and not STAGING.match(p.name))


def staging(folder):
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*")
                  if p.is_file() and STAGING.match(p.name))


def same_tree(a, b, what):
    files = tree(a)
    if not check(files == tree(b), f"{what}: other files than the local run's: "
                                   f"{sorted(set(files) ^ set(tree(b)))}"):
        return False
    different = [f for f in files if not filecmp.cmp(Path(a) / f, Path(b) / f, shallow=False)]
    return check(not different, f"{what}: files differ from the local run's: {different}")


def keys(cli, catalog, assets, folder):
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for asset in assets:
        path = folder / (asset.replace("/", "_") + ".key.json")
        run(cli, "catalog", "export", catalog, asset, "--key", path, "-q")
        out[asset] = path.read_bytes()
    return out


def listing(cli, catalog):
    return json.loads(run(cli, "catalog", "list", catalog, "--json").stdout)["assets"]


def make_corpus(meshes, corpus):
    for sub in ("a", "b", "c"):
        for name in MESHES:
            (corpus / sub).mkdir(parents=True, exist_ok=True)
            shutil.copy(meshes / name, corpus / sub / name)
    # An OBJ whose material library is outside its own folder: not copied beside the marked
    # copy, linked back to from the output folder.
    (corpus / "mat").mkdir()
    (corpus / "shared.mtl").write_text("newmtl skin\nKd 0.8 0.6 0.5\n")
    text = (meshes / "spot.obj").read_text()
    (corpus / "mat" / "spot_shared.obj").write_text("mtllib ../shared.mtl\nusemtl skin\n" + text)


def wait_for_copies(folder, count, process, timeout=120):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            return False
        if len([p for p in Path(folder).rglob("*") if p.is_file() and
                p.suffix in (".obj", ".ply", ".off")]) >= count:
            return True
        time.sleep(0.02)
    return False


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cli", required=True, help="the meshmark program")
    parser.add_argument("--python-path", required=True, help="folder holding the package meshmark")
    parser.add_argument("--meshes", default=os.environ.get("MESHMARK_DEFAULT_MESH_DIR",
                                                          "../shared/data/meshes"))
    args = parser.parse_args()
    meshes = Path(args.meshes)
    if not all((meshes / m).is_file() for m in MESHES):
        print(f"skipped: the shared meshes are not in {meshes}", file=sys.stderr)
        return dask_cluster.SKIP
    cli = str(Path(args.cli).resolve())
    work = Path(tempfile.mkdtemp(prefix="meshmark-cluster-check-"))
    summary = {}
    try:
        cluster = dask_cluster.DaskCluster(workers=2, pythonpath=Path(args.python_path).resolve())
    except dask_cluster.Unavailable as e:
        print(f"skipped: {e}", file=sys.stderr)
        return dask_cluster.SKIP
    try:
        os.chdir(work)
        corpus = work / "corpus"
        make_corpus(meshes, corpus)
        started = time.monotonic()
        with cluster:
            summary["cluster_start_seconds"] = round(time.monotonic() - started, 2)
            address = cluster.address
            # 1. Local and cluster adds with one seed.
            local = json.loads(run(cli, "catalog", "add", "local.db", "corpus", "-o", "out_local",
                                   "--seed", 5, "--json", "-q").stdout)
            t = time.monotonic()
            remote = json.loads(run(cli, "catalog", "add", "cluster.db", "corpus", "-o",
                                    "out_cluster", "--seed", 5, "--scheduler", address, "--json",
                                    "-q").stdout)
            summary["cluster_add_seconds"] = round(time.monotonic() - t, 2)
            n = len(local["files"])
            summary["files"] = n
            check(local["counts"]["marked"] == n, f"local add: {local['counts']}")
            check(remote["counts"] == local["counts"], f"cluster add counts {remote['counts']}")
            outcomes = {f["asset"]: f["outcome"] for f in remote["files"]}
            check(outcomes == {f["asset"]: f["outcome"] for f in local["files"]},
                  "cluster add: other outcomes than the local run's")
            same_tree("out_local", "out_cluster", "cluster add")
            assets = sorted(outcomes)
            check(keys(cli, "cluster.db", assets, work / "k_cluster") ==
                  keys(cli, "local.db", assets, work / "k_local"),
                  "cluster add: keys differ from the local run's")
            line = (work / "out_cluster/mat/spot_shared.obj").read_text().splitlines()[0]
            check(line == "mtllib ../../corpus/shared.mtl",
                  f"the OBJ's library outside its folder linked as {line!r}")
            again = json.loads(run(cli, "catalog", "add", "cluster.db", "corpus", "-o",
                                   "out_cluster", "--seed", 5, "--scheduler", address, "--json",
                                   "-q").stdout)
            check(again["counts"]["present"] == n, f"cluster add again: {again['counts']}")

            # 2. Scans: cluster and local agree.
            run(cli, "attack", "out_cluster/a/fandisk.obj", "similarity,noise=0.0005", "-o",
                "suspect.ply", "--seed", 3, "-q")
            suspects = ["suspect.ply", "corpus/b/spot.obj"]
            scans = []
            for extra in ([], ["--scheduler", address]):
                done = run(cli, "catalog", "scan", "cluster.db", *suspects, "--json", "-q",
                           *extra, expect=0)
                report = json.loads(done.stdout)
                scans.append([(s["path"], s["detected"],
                               [(m["asset"], [r["name"] for r in m["recipients"]],
                                 m["false_positive_probability"]) for m in s["matches"]])
                              for s in report["suspects"]])
            check(scans[0] == scans[1], f"cluster scan {scans[1]} != local scan {scans[0]}")
            check(scans[1][0][1] and scans[1][0][2][0][0] == "a/fandisk.obj" and
                  not scans[1][1][1], f"cluster scan: {scans[1]}")
            summary["scan"] = scans[1]

            # 3. Recipients' copies: `catalog issue --scheduler` against a local issue.
            names = [f"--recipient=buyer-{i}" for i in range(12)]
            issued = []
            for catalog, out, extra in (("local.db", "issued_local", []),
                                        ("cluster.db", "issued_cluster", ["--scheduler",
                                                                          address])):
                report = json.loads(run(cli, "catalog", "issue", catalog, "a/fandisk.obj",
                                        *names, "-o", f"{out}/{{recipient}}.obj", "--json",
                                        "-q", *extra).stdout)
                issued.append([(c["name"], c["index"], c["new"]) for c in report["copies"]])
            check(issued[0] == issued[1] and len(issued[1]) == 12,
                  f"cluster issue's copies {issued[1]} != local {issued[0]}")
            same_tree("issued_local", "issued_cluster", "cluster issue")
            recorded = [a for a in listing(cli, "cluster.db") if a["asset"] == "a/fandisk.obj"]
            check(len(recorded[0]["recipients"]) == 13,
                  f"cluster issue: {len(recorded[0]['recipients'])} names recorded, not 13")
            summary["issued"] = len(issued[1])

            # 4. The catalogue on PostgreSQL: the coordinator records there, the scan's workers
            # read it.
            try:
                with postgres_server.PostgresServer() as pg:
                    url = pg.create_database("cluster")
                    report = json.loads(run(cli, "catalog", "add", url, "corpus", "-o",
                                            "out_pg", "--seed", 5, "--scheduler", address,
                                            "--json", "-q").stdout)
                    check(report["counts"]["marked"] == n, f"add into PostgreSQL: {report}")
                    same_tree("out_local", "out_pg", "cluster add into PostgreSQL")
                    unissued = [a for a in assets if not a.startswith("a/")][:3]  # (3. issued)
                    pg_keys = keys(cli, url, unissued, work / "k_pg")
                    local_keys = keys(cli, "local.db", unissued, work / "k_local_pg")
                    check(pg_keys == local_keys,
                          "cluster add into PostgreSQL: keys differ from the local run's: " +
                          str([(a, pg_keys[a][:300], local_keys[a][:300]) for a in pg_keys
                               if pg_keys[a] != local_keys[a]][:1]))
                    done = run(cli, "catalog", "scan", url, "suspect.ply", "--json", "-q",
                               "--scheduler", address, expect=0)
                    found = json.loads(done.stdout)["suspects"][0]
                    check(found["detected"] and found["matches"][0]["asset"] == "a/fandisk.obj",
                          f"cluster scan through PostgreSQL: {found['matches']}")
                    summary["postgres"] = "checked"
            except postgres_server.Unavailable as e:
                summary["postgres"] = f"skipped: {e}"

            # 5. Python: Catalog.add(client=...) against Catalog.add().
            code = f"""
import meshmark
from dask.distributed import Client
with Client({address!r}) as client:
    r = meshmark.Catalog("py_cluster.db", create=True).add(["corpus/a"], "py_cluster", seed=9,
                                                           client=client)
l = meshmark.Catalog("py_local.db", create=True).add(["corpus/a"], "py_local", seed=9)
assert r["counts"] == l["counts"] and r["counts"]["marked"] == {len(MESHES)}, (r, l)
"""
            done = subprocess.run([sys.executable, "-c", code], env=cluster.env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            if check(done.returncode == 0, "Python Catalog.add(client=): " + done.stderr[-1500:]):
                same_tree("py_local", "py_cluster", "Python Catalog.add(client=)")

            # 6. A worker killed while the add runs.
            add = subprocess.Popen([cli, "catalog", "add", "killed.db", "corpus", "-o",
                                    "out_killed", "--seed", "5", "--scheduler", address, "--json",
                                    "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True)
            running = wait_for_copies("out_killed", 2, add)
            check(running, "the worker kill came after the add had ended (nothing tested)")
            cluster.kill_worker(0)
            summary["worker_killed_after_copies"] = len(tree("out_killed"))
            out, err = add.communicate(timeout=600)
            if check(add.returncode == 0, f"add with a worker killed: exit {add.returncode} {err}"):
                report = json.loads(out)
                check(report["counts"]["marked"] == n,
                      f"add with a worker killed: {report['counts']}")
                same_tree("out_local", "out_killed", "add with a worker killed")
                listed = listing(cli, "killed.db")
                check(sorted(a["asset"] for a in listed) == assets and
                      all(a["complete"] for a in listed),
                      "add with a worker killed: not every asset recorded once and complete")
            cluster.start_worker()
            cluster.wait_for_workers(2)

            # 7. The coordinator killed midway, then the same call again.
            add = subprocess.Popen([cli, "catalog", "add", "resumed.db", "corpus", "-o",
                                    "out_resumed", "--seed", "5", "--scheduler", address, "-q"],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                   start_new_session=True)
            running = wait_for_copies("out_resumed", 3, add)
            os.killpg(add.pid, signal.SIGKILL)
            add.wait()
            check(running, "the coordinator kill came after the add had ended (nothing tested)")
            before = len(tree("out_resumed"))
            summary["coordinator_killed_after_files"] = before
            summary["coordinator_killed_staging_files"] = staging("out_resumed")
            rerun = json.loads(run(cli, "catalog", "add", "resumed.db", "corpus", "-o",
                                   "out_resumed", "--seed", 5, "--scheduler", address, "--json",
                                   "-q").stdout)
            summary["resumed_counts"] = rerun["counts"]
            check(rerun["counts"]["failed"] == 0 and
                  rerun["counts"]["marked"] + rerun["counts"]["present"] == n,
                  f"resumed add: {rerun['counts']}")
            same_tree("out_local", "out_resumed", "resumed add")
            listed = listing(cli, "resumed.db")
            check(sorted(a["asset"] for a in listed) == assets and
                  all(a["complete"] for a in listed),
                  "resumed add: not every asset recorded once and complete")
    finally:
        os.chdir("/")
        shutil.rmtree(work, ignore_errors=True)
    summary["failures"] = failures
    print(json.dumps(summary, indent=1))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
