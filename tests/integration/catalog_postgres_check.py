#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The catalogue on PostgreSQL through the command line (issue 56), against one throwaway server
(tests/support/postgres_server.py), on two generated meshes (no shared data needed):

1. migration: an SQLite catalogue (`catalog add`, `catalog issue` alice and bob) migrated into a
   PostgreSQL database with a password in its URL (`catalog migrate cat.db postgresql://...`):
   `catalog list --json` of both identical but for the "catalog" field, which names the database
   without the password (nor is it in any output); a second migration into it refused; a scan
   through the PostgreSQL catalogue finds an attacked published copy (asset, "published") and
   an attacked copy of bob's; the PostgreSQL catalogue migrated back into a new SQLite file
   lists the same again.
2. --issuers `catalog issue` processes at once (default 16) on one asset of a catalogue made in
   PostgreSQL by `catalog add`, each a name of its own and one shared name: every call exits 0,
   and the catalogue holds every name once, with codes all distinct, every copy delivered.
3. Two `meshmark serve` processes on that catalogue (the issuing service on two hosts; a
   password in its URL) serve at once 6 names each and 4 names asked of both: every answer a
   copy, a name asked of both served the same bytes by both and recorded once, no code given
   twice; after the database server restarts (pg_ctl restart) each serves a new name; their
   logs never hold the password.

Exit 0 when every check held (a JSON summary on stdout), 1 otherwise, 77 when no PostgreSQL
server can be started here.
"""
import argparse
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile
import re
import signal
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
import postgres_server  # noqa: E402


def lumpy_sphere(path, seed, stretch=(1.0, 1.0, 1.0), level=4):
    """An icosphere of \\p level subdivisions, radially perturbed, stretched: an OFF file."""
    t = (1 + 5 ** 0.5) / 2
    vs = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
          (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    vs = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in vs]
    fs = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
          (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
          (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        mid = {}

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = [(vs[a][k] + vs[b][k]) / 2 for k in range(3)]
                n = math.sqrt(sum(x * x for x in m))
                vs.append(tuple(x / n for x in m))
                mid[key] = len(vs) - 1
            return mid[key]

        new = []
        for a, b, c in fs:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        fs = new
    rng = random.Random(seed)
    bumps = [(tuple(rng.gauss(0, 1) for _ in range(3)), rng.uniform(0.05, 0.15)) for _ in range(6)]
    out = []
    for v in vs:
        r = 1.0
        for d, h in bumps:
            n = math.sqrt(sum(x * x for x in d))
            r += h * max(0.0, sum(v[k] * d[k] / n for k in range(3))) ** 4
        out.append(tuple(v[k] * r * stretch[k] for k in range(3)))
    with open(path, "w") as f:
        f.write(f"OFF\n{len(out)} {len(fs)} 0\n")
        f.writelines(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in out)
        f.writelines(f"3 {a} {b} {c}\n" for a, b, c in fs)


class Check:
    def __init__(self, cli, secret):
        self.cli = cli
        self.secret = secret
        self.problems = []

    def run(self, *args, expect=0):
        p = subprocess.run([self.cli, *map(str, args)], capture_output=True, text=True,
                           env=dict(os.environ, OMP_NUM_THREADS="1"))
        if self.secret in p.stdout or self.secret in p.stderr:
            self.problems.append(f"meshmark {args[:2]} printed the password")
        if expect is not None and p.returncode != expect:
            self.problems.append(f"meshmark {' '.join(map(str, args))} exited {p.returncode} "
                                 f"(expected {expect}): {p.stderr.strip()[-500:]}")
        return p

    def listing(self, catalog):
        listed = json.loads(self.run("catalog", "list", catalog, "--json").stdout)
        return listed.pop("catalog"), listed

    def expect(self, condition, what):
        if not condition:
            self.problems.append(what)


def migration(c, pg, work):
    work.mkdir()
    (work / "in").mkdir()
    lumpy_sphere(work / "in" / "a.off", 1)
    lumpy_sphere(work / "in" / "b.off", 2, stretch=(1.0, 0.7, 1.6))
    cat = work / "cat.db"
    c.run("catalog", "add", cat, work / "in", "-o", work / "out", "--seed", "7", "-q")
    c.run("catalog", "issue", cat, "a.off", "--recipient", "alice", "--recipient", "bob",
          "-o", work / "copies" / "{recipient}.off", "-q")
    url = pg.create_database("migrated")
    with_password = url.replace("postgres@", f"postgres:{c.secret}@")
    migrated = c.run("catalog", "migrate", cat, with_password, "--json")
    if migrated.returncode == 0:
        summary = json.loads(migrated.stdout)
        c.expect(summary["assets"] == 2 and summary["recipients"] == 4, f"migrate: {summary}")
        c.expect(summary["destination"] == url, f"migrate's destination: {summary['destination']}")
    name, pg_list = c.listing(with_password)
    c.expect(name == url, f"list's catalog field: {name}")
    _, file_list = c.listing(cat)
    c.expect(pg_list == file_list and len(file_list["assets"]) == 2,
             "catalog list --json differs between the SQLite file and PostgreSQL")
    for where, key in ((cat, "file.key"), (url, "pg.key")):
        c.run("catalog", "export", where, "a.off", "--key", work / key)
    c.expect((work / "file.key").read_bytes() == (work / "pg.key").read_bytes(),
             "catalog export writes another key from PostgreSQL")
    again = c.run("catalog", "migrate", cat, with_password, expect=None)
    c.expect(again.returncode != 0 and "already holds assets" in again.stderr,
             f"a second migration: exit {again.returncode}, {again.stderr.strip()}")
    c.run("attack", work / "out" / "b.off", "similarity", "-o", work / "leak_b.ply", "-q")
    c.run("attack", work / "copies" / "bob.off", "similarity,noise=0.0002", "-o",
          work / "leak_bob.ply", "-q")
    scans = {}
    for suspect, expected in (("leak_b.ply", ["b.off", "published"]),
                              ("leak_bob.ply", ["a.off", "bob"])):
        p = c.run("catalog", "scan", with_password, work / suspect, "--json")
        match = None
        if p.returncode == 0:
            found = json.loads(p.stdout)["suspects"][0]["matches"]
            match = [found[0]["asset"], found[0]["recipients"][0]["name"]] if found else None
        scans[suspect] = match
        c.expect(match == expected, f"scan {suspect}: {match}, expected {expected}")
    back = work / "back.db"
    c.run("catalog", "migrate", url, back, "-q")
    _, back_list = c.listing(back)
    c.expect(back_list == file_list, "PostgreSQL migrated back into SQLite lists otherwise")
    return scans


def issuers(c, pg, work, count):
    url = pg.create_database("issuers")
    work.mkdir()
    (work / "in").mkdir()
    lumpy_sphere(work / "in" / "a.off", 3)
    c.run("catalog", "add", url, work / "in", "-o", work / "out", "-q")
    start = time.monotonic()
    procs = [subprocess.Popen([c.cli, "catalog", "issue", url, "a.off", "--recipient", f"buyer{i}",
                               "--recipient", "everyone", "-o", str(work / "copies" / "{recipient}.off"),
                               "-q"], stderr=subprocess.PIPE, text=True,
                              env=dict(os.environ, OMP_NUM_THREADS="1")) for i in range(count)]
    for i, p in enumerate(procs):
        _, err = p.communicate()
        c.expect(p.returncode == 0, f"issuer {i} exited {p.returncode}: {err.strip()}")
    seconds = time.monotonic() - start
    _, listed = c.listing(url)
    recipients = listed["assets"][0]["recipients"]
    names = [r["name"] for r in recipients]
    expected = {"published", "everyone", *(f"buyer{i}" for i in range(count))}
    # The codes: the family key as `catalog export` writes it, and the table itself.
    c.run("catalog", "export", url, "a.off", "--key", work / "a.key")
    key = json.loads((work / "a.key").read_text())
    codes = {r["name"]: r["index"] for r in key["recipients"]["issued"]}
    c.expect(sorted(codes) == sorted(names), f"the key's names: {sorted(codes)}")
    rows = subprocess.run([os.path.join(pg.bindir, "psql"), url, "-At", "-c",
                           "SELECT count(*), count(DISTINCT name), count(DISTINCT code) "
                           "FROM recipients"], capture_output=True, text=True).stdout.strip()
    c.expect(rows == f"{len(expected)}|{len(expected)}|{len(expected)}", f"recipients table: {rows}")
    codes = list(codes.values())
    c.expect(sorted(names) == sorted(expected), f"names recorded: {sorted(names)}")
    c.expect(len(set(codes)) == len(codes), f"a code given twice: {sorted(codes)}")
    c.expect(all(r["delivered"] for r in recipients), "a copy not delivered")
    return {"issuers": count, "names": len(names), "distinct_codes": len(set(codes)),
            "seconds": round(seconds, 2)}


def start_serve(c, url, work, name):
    """`meshmark serve` on the catalogue at \p url (its password given): (process, port, token, log)."""
    token_file = work / f"{name}.token"
    log = open(work / f"{name}.log", "w+")
    proc = subprocess.Popen([c.cli, "serve", "--catalog", url, "--listen", "127.0.0.1:0",
                             "--token-file", str(token_file)], stdout=log, stderr=log)
    port = None
    for _ in range(100):
        log.seek(0)
        found = re.search(r"on http://127\.0\.0\.1:(\d+)", log.read())
        if found:
            port = int(found.group(1))
            break
        time.sleep(0.1)
    token = token_file.read_text().strip() if port is not None else ""
    return proc, port, token, log


def serve_copy(port, token, recipient):
    """POST a copy of a.off for \p recipient: (status, bytes)."""
    request = urllib.request.Request(
        f"http://127.0.0.1:{port}/v1/assets/a.off/copies",
        data=json.dumps({"recipient": recipient}).encode(),
        headers={"Authorization": "Bearer " + token, "Content-Type": "application/json"},
        method="POST")
    try:
        with urllib.request.urlopen(request, timeout=120) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def serve(c, url, work, restart):
    """Two `meshmark serve` processes on one PostgreSQL catalogue (the issuing service on two
    hosts), a password in its URL: requests to both at once, some names asked of both."""
    with_password = url.replace("postgres@", f"postgres:{c.secret}@")
    servers = [start_serve(c, with_password, work, f"serve{n}") for n in range(2)]
    results = {}
    try:
        c.expect(all(port is not None for _, port, _, _ in servers), "serve did not start")
        if any(port is None for _, port, _, _ in servers):
            return None
        # Each server its own names, and four names asked of both at once.
        jobs = [(n, f"web{n}-{i}") for n in range(2) for i in range(6)]
        jobs += [(n, f"both-{i}") for i in range(4) for n in range(2)]
        with ThreadPoolExecutor(max_workers=8) as pool:
            answers = list(pool.map(
                lambda job: (job, serve_copy(servers[job[0]][1], servers[job[0]][2], job[1])),
                jobs))
        for (n, name), (status, body) in answers:
            c.expect(status == 200 and len(body) > 1000,
                     f"serve{n}'s copy for {name}: {status}, {len(body)} bytes")
            results.setdefault(name, []).append(body)
        for name, bodies in results.items():
            c.expect(len(set(bodies)) == 1, f"{name}: two servers served different bytes")
        # The database server restarted under the services: each connects again and serves.
        restart()
        for n, (_, port, token, _) in enumerate(servers):
            status, body = serve_copy(port, token, f"after-restart-{n}")
            c.expect(status == 200 and len(body) > 1000,
                     f"serve{n} after the database restarted: {status} {body[:200]!r}")
            results[f"after-restart-{n}"] = [body]
    finally:
        texts = []
        for proc, _, _, log in servers:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
            log.seek(0)
            texts.append(log.read())
            log.close()
    c.expect(all(c.secret not in text for text in texts), "serve logged the password")
    _, listed = c.listing(url)
    names = [r["name"] for r in listed["assets"][0]["recipients"]]
    counts = {name: names.count(name) for name in results if names.count(name) != 1}
    c.expect(not counts, f"names not recorded exactly once: {counts}")
    c.run("catalog", "export", url, "a.off", "--key", work / "served.key")
    key = json.loads((work / "served.key").read_text())
    codes = [r["index"] for r in key["recipients"]["issued"]]
    c.expect(len(set(codes)) == len(codes), f"a code given twice by the two servers: {codes}")
    return {"servers": 2, "requests": len(jobs), "names": len(results)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=str(Path(__file__).resolve().parents[2] / "build" / "bin" / "meshmark"))
    parser.add_argument("--issuers", type=int, default=16)
    args = parser.parse_args()
    try:
        server = postgres_server.PostgresServer()
    except postgres_server.Unavailable as e:
        print(f"skipped: {e}", file=sys.stderr)
        return 77
    c = Check(args.cli, "s3cr3t-pw")
    work = Path(tempfile.mkdtemp(prefix="meshmark-pg-check-"))
    summary = {}
    try:
        with server as pg:
            summary["migration_scans"] = migration(c, pg, work / "migration")
            summary["issuers"] = issuers(c, pg, work / "issuers", args.issuers)
            summary["serve"] = serve(c, f"{pg.url}/issuers", work / "issuers", pg.restart)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    summary["problems"] = c.problems
    print(json.dumps(summary, indent=1))
    return 1 if c.problems else 0


if __name__ == "__main__":
    sys.exit(main())
