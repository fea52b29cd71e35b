#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""`meshmark serve` as a shop would drive it (issue 54), with real clients on 127.0.0.1.

Builds a catalogue of two shared meshes (bunny.stl, and horse.ply as a GLB when gltfpack is
installed, else as PLY), starts the service on a free port with small limits, and checks with
curl (and Python's http.client for the concurrent part):
  - /healthz answers without a token; every other route answers 401 without the right token;
  - GET /v1/assets and /v1/assets/{id} list the assets and never a key's seed or payload;
  - a copy: 200, Content-Type, Content-Disposition, X-Meshmark-Record; the same name again gets
    the same bytes; the bytes equal `catalog issue`'s copy for that name; `detect` with the
    exported key accuses that name only; POST /v1/scan of another copy finds asset and buyer;
  - bad requests (unknown asset, bad JSON, unknown field, bad names, path-traversal ids, unknown
    format, oversized body, a slow client) each get their 4xx and record nothing, and the
    service keeps serving meanwhile;
  - 16 clients at once, 4 names each: every name one code, codes distinct;
  - /metrics counts the copies; SIGTERM stops it (exit 0); every log line is JSON; neither the
    token nor the key's seed or payload appears in any response or log line;
  - scans try --candidates, then --more-candidates more (0: none).
Exit 0 when every check held, 77 without the shared meshes or curl.
"""
import argparse
import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
from pathlib import Path


def default_cli():
    here = Path(__file__).resolve().parents[2]
    return os.environ.get("MESHMARK_CLI") or str(here / "build" / "bin" / "meshmark")


def mesh_dir():
    return Path(os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
                or Path(__file__).resolve().parents[3] / "shared" / "data" / "meshes")


class Checks:
    def __init__(self):
        self.failures = []
        self.count = 0

    def check(self, condition, what):
        self.count += 1
        if not condition:
            self.failures.append(what)
            print(f"FAIL: {what}", file=sys.stderr)


def run(cli, *args, check=True):
    p = subprocess.run([cli, *args], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise SystemExit(f"meshmark {' '.join(args)} exited {p.returncode}: {p.stderr.strip()}")
    return p


def curl(port, method, path, token=None, body=None, data_file=None, headers=(), out=None):
    """(status, headers dict, body bytes) of one request made by curl."""
    with tempfile.NamedTemporaryFile() as head, tempfile.NamedTemporaryFile() as payload:
        cmd = ["curl", "-s", "-X", method, "-D", head.name, "-o", out or payload.name,
               "--max-time", "60", f"http://127.0.0.1:{port}{path}"]
        if token:
            cmd += ["-H", f"Authorization: Bearer {token}"]
        for h in headers:
            cmd += ["-H", h]
        if body is not None:
            cmd += ["-H", "Content-Type: application/json", "--data-binary", body]
        if data_file is not None:
            cmd += ["-H", "Content-Type: application/octet-stream", "--data-binary", f"@{data_file}"]
        subprocess.run(cmd, check=False)
        lines = Path(head.name).read_text(errors="replace").splitlines()
        while len(lines) > 1 and " 100 " in lines[0]:  # "100 Continue", then the answer
            lines = lines[lines.index("") + 1:] if "" in lines else lines[1:]
        status = int(lines[0].split()[1]) if lines else 0
        hdrs = {}
        for line in lines[1:]:
            if ":" in line:
                k, v = line.split(":", 1)
                hdrs[k.strip().lower()] = v.strip()
        data = Path(out or payload.name).read_bytes()
        return status, hdrs, data


def start_service(cli, catalog, log_path, *extra):
    """`meshmark serve` on a free port of 127.0.0.1, its log in log_path: (process, port or None)."""
    with open(log_path, "w") as log:
        proc = subprocess.Popen([cli, "serve", "--catalog", catalog, "--listen", "127.0.0.1:0", *extra], stderr=log)
    for _ in range(200):
        text = Path(log_path).read_text()
        if "serving" in text:
            return proc, int(text.split("http://127.0.0.1:")[1].split()[0])
        time.sleep(0.05)
    return proc, None


def recipients(cli, catalog, asset):
    for a in json.loads(run(cli, "catalog", "list", catalog, "--json").stdout)["assets"]:
        if a["asset"] == asset:
            return sorted(r["name"] for r in a["recipients"])
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default=default_cli())
    args = parser.parse_args()
    cli = args.cli
    meshes = mesh_dir()
    if not (meshes / "bunny.stl").exists() or shutil.which("curl") is None:
        print("skipped: needs the shared meshes and curl", file=sys.stderr)
        return 77
    c = Checks()
    work = Path(tempfile.mkdtemp(prefix="meshmark-service-"))
    service = None
    try:
        assets = work / "assets"
        assets.mkdir()
        shutil.copy(meshes / "bunny.stl", assets / "bunny.stl")
        horse = "horse.ply"
        if shutil.which("gltfpack"):
            run(cli, "attack", str(meshes / "horse.ply"), "-o", str(work / "horse.obj"), "reorder", "-q")
            subprocess.run(["gltfpack", "-i", str(work / "horse.obj"), "-o", str(assets / "horse.glb"), "-noq"],
                           check=True, capture_output=True)
            horse = "horse.glb"
        else:
            shutil.copy(meshes / "horse.ply", assets / "horse.ply")
        catalog = str(work / "catalog.db")
        run(cli, "catalog", "add", catalog, str(assets), "-o", str(work / "published"), "-q")
        run(cli, "catalog", "export", catalog, "bunny.stl", "--key", str(work / "bunny.json"), "-q")
        key = json.loads((work / "bunny.json").read_text())
        secrets = [key["seed"], key["payload"]["bits"]]

        log_path = work / "serve.log"
        service, port = start_service(cli, catalog, log_path, "--max-upload", "4M", "--read-timeout", "1")
        c.check(port is not None, "the service announces its port")
        token_file = Path(catalog + ".token")
        token = token_file.read_text().strip()
        c.check(oct(token_file.stat().st_mode & 0o777) == "0o600", "the token file is mode 0600")
        secrets.append(token)
        responses = []

        status, _, body = curl(port, "GET", "/healthz")
        c.check(status == 200 and json.loads(body)["status"] == "ok", "/healthz answers without a token")
        before = recipients(cli, catalog, "bunny.stl")
        for method, path in [("GET", "/v1/assets"), ("GET", "/metrics"), ("GET", "/v1/assets/bunny.stl"),
                             ("POST", "/v1/assets/bunny.stl/copies"), ("POST", "/v1/scan?name=x.stl")]:
            for tok in [None, "wrong-token-of-the-same-length-" + "x" * 33]:
                status, hdrs, body = curl(port, method, path, token=tok, body='{"recipient":"mallory"}')
                c.check(status == 401 and "error" in json.loads(body), f"{method} {path} without the token: 401")
        c.check(recipients(cli, catalog, "bunny.stl") == before, "nothing recorded for unauthorized requests")

        status, _, body = curl(port, "GET", "/v1/assets", token)
        responses.append(body)
        listed = {a["asset"]: a for a in json.loads(body)["assets"]}
        c.check(status == 200 and set(listed) == {"bunny.stl", horse}, "GET /v1/assets lists both assets")
        c.check(listed["bunny.stl"]["vertices"] == 34834, "the listing gives the vertex count")
        status, _, body = curl(port, "GET", "/v1/assets/bunny.stl", token)
        responses.append(body)
        c.check(status == 200 and json.loads(body)["asset"] == "bunny.stl", "GET /v1/assets/{id}")

        # Copies.
        a1 = work / "alice1.stl"
        status, hdrs, body = curl(port, "POST", "/v1/assets/bunny.stl/copies", token, '{"recipient":"alice"}',
                                  out=str(a1))
        c.check(status == 200, "a copy for alice: 200")
        c.check(hdrs.get("content-type") == "model/stl", "Content-Type of an STL copy")
        c.check('filename="bunny-alice.stl"' in hdrs.get("content-disposition", ""), "Content-Disposition")
        c.check(hdrs.get("x-meshmark-record", "").isdigit(), "X-Meshmark-Record")
        c.check(hdrs.get("x-meshmark-recipient-new") == "true", "alice is new")
        status, hdrs, _ = curl(port, "POST", "/v1/assets/bunny.stl/copies", token, '{"recipient":"alice"}',
                               out=str(work / "alice2.stl"))
        c.check(status == 200 and hdrs.get("x-meshmark-recipient-new") == "false", "alice again: not new")
        c.check(a1.read_bytes() == (work / "alice2.stl").read_bytes(), "alice again gets the same bytes")
        run(cli, "catalog", "issue", catalog, "bunny.stl", "--recipient", "alice", "-o",
            str(work / "issued" / "{recipient}.stl"), "-q")
        c.check((work / "issued" / "alice.stl").read_bytes() == a1.read_bytes(),
                "the served copy equals catalog issue's copy of the same name")
        status, _, _ = curl(port, "POST", "/v1/assets/bunny.stl/copies", token, '{"recipient":"bob"}',
                            out=str(work / "bob.stl"))
        c.check(status == 200 and (work / "bob.stl").read_bytes() != a1.read_bytes(), "bob's copy differs")
        run(cli, "catalog", "export", catalog, "bunny.stl", "--key", str(work / "bunny2.json"), "--force", "-q")
        found = json.loads(run(cli, "detect", str(a1), "--original", str(assets / "bunny.stl"), "--key",
                               str(work / "bunny2.json"), "--json", check=False).stdout)
        c.check(found["detected"] and [r["name"] for r in found["recipients"]] == ["alice"],
                "detect accuses alice, and only her, in alice's copy")
        status, hdrs, body = curl(port, "POST", "/v1/assets/" + urllib.parse.quote(horse, safe="") + "/copies",
                                  token, '{"recipient":"carol","format":"ply"}', out=str(work / "carol.ply"))
        c.check(status == 200 and hdrs.get("content-disposition", "").endswith('.ply"'), "a copy in another format")
        status, _, body = curl(port, "POST", "/v1/scan?name=suspect.stl", token, data_file=str(work / "bob.stl"))
        responses.append(body)
        report = json.loads(body) if status == 200 else {}
        matches = report.get("suspects", [{}])[0].get("matches", []) if report else []
        c.check(status == 200 and matches and matches[0]["asset"] == "bunny.stl"
                and [r["name"] for r in matches[0]["recipients"]] == ["bob"], "POST /v1/scan finds bob's copy")

        # Bad requests: each its status, nothing recorded, the service still serving.
        before = recipients(cli, catalog, "bunny.stl")
        bad = [
            ("/v1/assets/nope.stl/copies", '{"recipient":"x"}', 404, "unknown asset"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":', 400, "bad JSON"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":"x","key":"y"}', 400, "unknown field"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":"../etc"}', 400, "a name with a path"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":"a\\u0007b"}', 400, "a name with a control character"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":""}', 400, "an empty name"),
            ("/v1/assets/bunny.stl/copies", '{"recipient":"x","format":"exe"}', 415, "unknown format"),
            ("/v1/assets/..%2F..%2Fetc%2Fpasswd/copies", '{"recipient":"x"}', 400, "a path-traversal asset id"),
            ("/v1/assets/%2Fetc%2Fpasswd/copies", '{"recipient":"x"}', 400, "an absolute asset id"),
            ("/v1/nothing", '{}', 404, "unknown route"),
        ]
        for path, body_text, expected, what in bad:
            status, _, body = curl(port, "POST", path, token, body_text)
            responses.append(body)
            ok = status == expected
            try:
                ok = ok and "error" in json.loads(body)
            except ValueError:
                ok = False
            c.check(ok, f"{what}: {expected} with a JSON error (got {status})")
        big = work / "big.bin"
        big.write_bytes(b"\0" * (5 << 20))
        status, _, _ = curl(port, "POST", "/v1/scan?name=big.stl", token, data_file=str(big))
        c.check(status == 413, f"an oversized body: 413 (got {status})")
        status, _, _ = curl(port, "POST", "/v1/scan?name=../x.stl", token, data_file=str(work / "bob.stl"))
        c.check(status == 400, "a scan named with a path: 400")
        (work / "junk.stl").write_bytes(b"solid nothing\nfacet normal 0 0 1\nouter loop\nvertex 1 2\n")
        status, _, _ = curl(port, "POST", "/v1/scan?name=junk.stl", token, data_file=str(work / "junk.stl"))
        c.check(status == 422, f"an unreadable suspect: 422 (got {status})")
        # A slow client: half a request line, then silence past --read-timeout (1 s).
        slow = socket.create_connection(("127.0.0.1", port))
        slow.sendall(b"POST /v1/assets/bunny.stl/cop")
        status, _, _ = curl(port, "GET", "/healthz")
        c.check(status == 200, "served while a slow client holds a connection")
        slow.settimeout(5)
        try:
            closed = slow.recv(1024) is not None  # b"" (closed) or an error response, within 5 s
        except (socket.timeout, OSError):
            closed = False
        slow.close()
        c.check(closed, "a silent client is cut off after the read timeout")
        c.check(recipients(cli, catalog, "bunny.stl") == before, "bad requests recorded nothing")

        # 16 clients at once, 4 names each.
        got = {}
        lock = threading.Lock()
        errors = []

        def client(t):
            try:
                conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
                for i in range(4):
                    name = f"c{t}n{i}"
                    conn.request("POST", "/v1/assets/bunny.stl/copies", json.dumps({"recipient": name}),
                                 {"Authorization": f"Bearer {token}"})
                    r = conn.getresponse()
                    r.read()
                    if r.status != 200:
                        raise RuntimeError(f"{name}: {r.status}")
                    with lock:
                        got[name] = int(r.getheader("X-Meshmark-Record"))
                conn.close()
            except Exception as e:  # noqa: BLE001 - reported as a failed check
                errors.append(str(e))

        threads = [threading.Thread(target=client, args=(t,)) for t in range(16)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        c.check(not errors, f"16 clients at once: every request 200 ({errors[:3]})")
        c.check(len(got) == 64 and len(set(got.values())) == 64, "64 names, 64 distinct codes")
        listed_names = set(recipients(cli, catalog, "bunny.stl"))
        c.check(all(n in listed_names for n in got), "every served name is recorded")

        status, _, body = curl(port, "GET", "/metrics", token)
        text = body.decode()
        copies = [line for line in text.splitlines() if line.startswith("meshmark_copies_issued_total ")]
        c.check(status == 200 and copies and int(copies[0].split()[1]) >= 67, "/metrics counts the copies")
        c.check("meshmark_cache_hits_total" in text and 'route="copies"' in text, "/metrics has cache and latency")

        service.send_signal(15)
        c.check(service.wait(timeout=30) == 0, "SIGTERM stops the service with exit 0")
        service = None
        lines = log_path.read_text().splitlines()
        parsed = 0
        for line in lines:
            try:
                json.loads(line)
                parsed += 1
            except ValueError:
                pass
        c.check(parsed == len(lines) and parsed > 90, f"one JSON line per request ({parsed} of {len(lines)})")
        refused = [json.loads(line) for line in lines if '"status":413' in line]
        c.check(refused and all("record" not in r for r in refused),
                "a refused request's log line carries nothing of the request before it")
        everything = log_path.read_text().encode() + b"".join(responses)
        c.check(not any(s.encode() in everything for s in secrets),
                "no token, seed or payload in any response or log line")

        # A budget smaller than one asset: each asset is dropped when the other is warmed, and
        # copies stay right (the same bytes as before the eviction).
        service, port = start_service(cli, catalog, work / "serve1m.log", "--memory-budget", "1M")
        c.check(port is not None, "the service starts with a 1M budget")
        if port is not None:
            horse_path = "/v1/assets/" + urllib.parse.quote(horse, safe="") + "/copies"
            for path in ["/v1/assets/bunny.stl/copies", horse_path, "/v1/assets/bunny.stl/copies"]:
                status, _, _ = curl(port, "POST", path, token, '{"recipient":"alice"}', out=str(work / "again.bin"))
                c.check(status == 200, f"{path} under a 1M budget: 200")
            c.check((work / "again.bin").read_bytes() == a1.read_bytes(), "the same bytes after an eviction")
            status, _, body = curl(port, "GET", "/metrics", token)
            values = {line.split()[0]: float(line.split()[1]) for line in body.decode().splitlines()
                      if line.startswith("meshmark_cache_") and " " in line}
            c.check(values.get("meshmark_cache_evictions_total", 0) >= 2 and values.get("meshmark_cache_assets") == 1,
                    f"a 1M budget keeps one asset warm ({values})")
            service.send_signal(15)
            c.check(service.wait(timeout=30) == 0, "SIGTERM again: exit 0")
            service = None

        # The time limit: one worker, busy with a scan of an unmarked mesh (every candidate tried:
        # seconds), and a queue timeout of 0.1 s: a copy asked meanwhile gets 503 with
        # Retry-After, and is not recorded.
        service, port = start_service(cli, catalog, work / "serve2.log", "--workers", "1", "--queue-timeout", "0.1")
        scan_done = []
        scanner = threading.Thread(target=lambda: scan_done.append(
            curl(port, "POST", "/v1/scan?name=suspect.stl", token, data_file=str(assets / "bunny.stl"))[0]))
        scanner.start()
        for _ in range(400):  # until the scan holds the only worker (it then computes for ~1 s)
            _, _, body = curl(port, "GET", "/metrics", token)
            if "meshmark_requests_in_flight 1" in body.decode():
                break
            time.sleep(0.005)
        before = recipients(cli, catalog, "bunny.stl")
        status, hdrs, body = curl(port, "POST", "/v1/assets/bunny.stl/copies", token, '{"recipient":"late"}')
        scanner.join()
        c.check(status == 503 and hdrs.get("retry-after") == "1" and "busy" in json.loads(body)["error"],
                f"a request past --queue-timeout: 503 with Retry-After (got {status})")
        c.check(scan_done == [200], "the scan holding the worker finished")
        c.check("late" not in recipients(cli, catalog, "bunny.stl") and before == recipients(cli, catalog, "bunny.stl"),
                "the refused request recorded nothing")
        service.send_signal(15)
        c.check(service.wait(timeout=30) == 0, "SIGTERM: exit 0")
        service = None

        # Scans' candidates: one tried, then the second round's best fits unless
        # --more-candidates 0 (an unmarked original: no candidate claims it).
        for more, expected in [("0", 1), ("4", 2)]:
            service, port = start_service(cli, catalog, work / f"serve-more{more}.log",
                                          "--candidates", "1", "--more-candidates", more)
            status, _, body = curl(port, "POST", "/v1/scan?name=suspect.stl", token, data_file=str(assets / "bunny.stl"))
            tried = json.loads(body)["suspects"][0]["tried"] if status == 200 else []
            c.check(len(tried) == expected, f"--candidates 1 --more-candidates {more}: {expected} tried (got {len(tried)})")
            service.send_signal(15)
            service.wait(timeout=30)
            service = None
    finally:
        if service is not None:
            service.kill()
            service.wait()
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps({"checks": c.count, "failures": c.failures}))
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main())
