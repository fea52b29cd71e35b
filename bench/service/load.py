#!/usr/bin/env python3
"""Load test of `meshmark serve`: copies under sustained load, their tracing, and the memory held.

    load.py --catalog CAT --asset ID [--clients 32] [--threads 2] [--duration 600] [--sample 200]
            [--budget 2G] [--allowance 300] [--format F] [--out results.json] [--workdir DIR] [--single]

Steps:
  1. starts `meshmark serve --catalog CAT --listen 127.0.0.1:0 --memory-budget BUDGET` (its JSON log
     in WORKDIR/serve.log) and reads the port from its 'serving ... on http://...' notice; the token
     comes from CAT.token (created by the service when missing);
  2. warms the asset with one copy request (recipient PREFIX-warm);
  3. samples the service's RSS (/proc/PID/status VmRSS) every second, and VmHWM at the end;
  4. runs `wrk -t THREADS -c CLIENTS -d DURATION --timeout 10s -s copies.lua`: every request a copy
     for a new name (PREFIX-THREAD-N);
  5. meanwhile issues --sample copies itself (http.client, one every DURATION/SAMPLE seconds, names
     PREFIX-s-NNNN), saving each body under WORKDIR/copies/ (Content-Length checked);
  6. stops the service with SIGTERM (exit code 0 expected), exports the asset's key
     (`catalog export`), and detects every sampled copy against the original (`detect --json`, two
     at a time): each must be detected and accuse exactly its own name.

--single: one client, sequential requests (wrk -t1 -c1) for DURATION, to report one client's
latency (p50); the sampled copies are then requested after wrk, so they do not disturb it.

Memory rule: the largest RSS seen (samples and VmHWM) must stay within BUDGET (--memory-budget:
warm originals and bases) plus ALLOWANCE, default 300 MiB: the process itself (binary, allocator,
SQLite, one request's working set per worker: the marked copy and its encoded file, the
connections' buffers).

Prints a JSON summary (and writes it to --out): wrk's RESULT fields, copies/s, RSS max (MiB), the
budget and allowance, the service log's status counts, sampled / traced / innocents accused, and
every error. Exit 1 on any error: a non-200 response (wrk's errors or the log's statuses), a
sampled copy not received whole, a copy not detected or accusing anyone but its own recipient, an
RSS above budget + allowance, or the service not stopping with exit code 0. Standard library only.
"""
import argparse
import collections
import concurrent.futures
import http.client
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import svc_common as sc  # noqa: E402

MIB = 1024 * 1024


def parse_result(text):
    for line in text.splitlines():
        if line.startswith("RESULT "):
            out = {}
            for kv in line.split()[1:]:
                k, v = kv.split("=", 1)
                out[k] = float(v) if "." in v else int(v)
            return out
    return None


class RssSampler(threading.Thread):
    def __init__(self, svc, period=1.0):
        super().__init__(daemon=True)
        self.svc, self.period = svc, period
        self.samples = []
        self.stop_event = threading.Event()

    def run(self):
        while not self.stop_event.is_set():
            rss = self.svc.proc_status("VmRSS")
            if rss is not None:
                self.samples.append((time.monotonic(), rss))
            self.stop_event.wait(self.period)


class CopySampler(threading.Thread):
    """Requests `count` copies, one every `interval` seconds (0: back to back), saving each body."""

    def __init__(self, port, token, asset, fmt, prefix, count, interval, outdir):
        super().__init__(daemon=True)
        self.port, self.token, self.asset, self.fmt = port, token, asset, fmt
        self.prefix, self.count, self.interval, self.outdir = prefix, count, interval, outdir
        self.copies = []  # (name, path)
        self.errors = []
        self.latencies = []

    def run(self):
        conn = None
        start = time.monotonic()
        for i in range(self.count):
            if self.interval > 0:
                delay = start + (i + 0.5) * self.interval - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            name = "%s-s-%04d" % (self.prefix, i)
            t0 = time.monotonic()
            try:
                if conn is None:
                    conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
                status, headers, body = sc.request_copy(conn, self.token, self.asset, name, self.fmt)
            except (OSError, http.client.HTTPException) as e:
                self.errors.append("sampled copy %s: %s: %s" % (name, type(e).__name__, e))
                if conn is not None:
                    conn.close()
                conn = None
                continue
            self.latencies.append(time.monotonic() - t0)
            path, problem = sc.keep_copy(name, status, headers, body, self.outdir)
            if problem:
                self.errors.append("sampled copy %s: %s" % (name, problem))
                continue
            if headers.get("x-meshmark-recipient-new") != "true":
                self.errors.append("sampled copy %s: X-Meshmark-Recipient-New %r for a new name"
                                   % (name, headers.get("x-meshmark-recipient-new")))
            self.copies.append((name, path))
            if headers.get("connection", "").lower() == "close":
                conn.close()
                conn = None
        if conn is not None:
            conn.close()


def main():
    ap = argparse.ArgumentParser(description="Load test of meshmark serve (see the module docstring).")
    ap.add_argument("--catalog", required=True)
    ap.add_argument("--asset", required=True)
    ap.add_argument("--clients", type=int, default=32)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--duration", type=int, default=600, help="seconds of load")
    ap.add_argument("--sample", type=int, default=200, help="copies requested, saved and traced")
    ap.add_argument("--budget", default="2G", help="serve --memory-budget")
    ap.add_argument("--allowance", type=float, default=300, help="MiB allowed above the budget")
    ap.add_argument("--format", default=None, help="copy format (glb, ply, ...); default: the original's")
    ap.add_argument("--single", action="store_true", help="one client, sequential requests (p50 of one client)")
    ap.add_argument("--out", default=None, help="JSON summary file")
    ap.add_argument("--workdir", default=None, help="log, copies, key (default: a new folder in /tmp)")
    ap.add_argument("--meshmark", default=os.environ.get("MESHMARK", sc.DEFAULT_MESHMARK))
    ap.add_argument("--serve-arg", action="append", default=[], help="extra argument for meshmark serve")
    args = ap.parse_args()

    catalog = os.path.abspath(args.catalog)
    workdir = args.workdir or tempfile.mkdtemp(prefix="meshmark-load.")
    os.makedirs(workdir, exist_ok=True)
    copydir = os.path.join(workdir, "copies")
    os.makedirs(copydir, exist_ok=True)
    budget = sc.parse_size(args.budget)
    clients, threads = (1, 1) if args.single else (args.clients, args.threads)
    prefix = "load%d-%d" % (int(time.time()), os.getpid())
    errors = []
    summary = {"catalog": catalog, "asset": args.asset, "format": args.format, "mode": "single" if args.single else "load",
               "clients": clients, "threads": threads, "duration_s": args.duration, "workdir": workdir,
               "prefix": prefix}

    listing = sc.catalog_list(args.meshmark, catalog)
    original = sc.asset_entry(listing, args.asset)["original"]

    svc = sc.Service(args.meshmark, catalog, os.path.join(workdir, "serve.log"),
                     extra=["--memory-budget", args.budget] + args.serve_arg)
    rss, sampler, hwm = None, None, None
    try:
        port = svc.wait_ready()
        token = svc.token()
        # Warm the asset: its original and bases loaded before the clock starts.
        t0 = time.monotonic()
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=300)
        status, headers, body = sc.request_copy(conn, token, args.asset, prefix + "-warm", args.format)
        conn.close()
        summary["warm_s"] = round(time.monotonic() - t0, 3)
        if status != 200:
            raise RuntimeError("warm-up copy: HTTP %d %s" % (status, body[:300].decode(errors="replace")))
        summary["copy_bytes"] = len(body)

        rss = RssSampler(svc)
        rss.start()
        sampler = CopySampler(port, token, args.asset, args.format, prefix, args.sample,
                              0 if args.single else args.duration / max(args.sample, 1), copydir)
        if not args.single:
            sampler.start()
        env = dict(os.environ, MESHMARK_TOKEN=token, MESHMARK_ASSET=urllib.parse.quote(args.asset, safe=""),
                   MESHMARK_PREFIX=prefix, MESHMARK_FORMAT=args.format or "")
        cmd = ["wrk", "-t%d" % threads, "-c%d" % clients, "-d%ds" % args.duration, "--timeout", "10s",
               "-s", os.path.join(sc.HERE, "copies.lua"), "http://127.0.0.1:%d" % port]
        print("+ " + " ".join(cmd), file=sys.stderr)
        w = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           timeout=args.duration + 120)
        with open(os.path.join(workdir, "wrk.txt"), "wb") as f:
            f.write(w.stdout)
        wtext = w.stdout.decode(errors="replace")
        result = parse_result(wtext)
        if w.returncode != 0 or result is None:
            errors.append("wrk exited %d without a RESULT line: %s" % (w.returncode, wtext[-500:]))
            result = {}
        summary["wrk"] = result
        if result:
            summary["copies_per_s"] = round(result["requests"] / result["duration_s"], 2) if result["duration_s"] else None
            for k in ("errors_status", "errors_connect", "errors_read", "errors_timeout"):
                if result.get(k):
                    errors.append("wrk %s=%d" % (k, result[k]))
        if args.single:
            sampler.start()
        sampler.join()
        summary["sample_latency_ms_max"] = round(1000 * max(sampler.latencies), 1) if sampler.latencies else None
        errors += sampler.errors
        hwm = svc.proc_status("VmHWM")
        if svc.proc.poll() is not None:
            last = [r for r in svc.log_records() if "notice" in r or "error" in r][-2:]
            errors.append("meshmark serve exited on its own (exit code %s) during the load; last notices %s"
                          % (svc.proc.returncode, json.dumps(last)))
    except (OSError, RuntimeError, http.client.HTTPException, subprocess.TimeoutExpired) as e:
        errors.append("%s: %s" % (type(e).__name__, e))
    finally:
        if rss is not None:
            rss.stop_event.set()
            rss.join()
        rc = svc.stop()
    if rc != 0:
        errors.append("meshmark serve exited %s after SIGTERM (expected 0); log %s" % (rc, svc.log_path))

    # The service's log: every request's status.
    statuses = collections.Counter()
    for rec in svc.log_records():
        if "status" in rec:
            statuses[rec["status"]] += 1
    errors += ["service log: %s" % line for line in sc.log_problems(svc.log_records()) if '"status"' not in line]
    summary["log_statuses"] = {str(k): v for k, v in sorted(statuses.items())}
    for st, n in statuses.items():
        if st != 200:
            bad = [r for r in svc.log_records() if r.get("status") == st][:3]
            errors.append("service answered HTTP %d %d times, e.g. %s" % (st, n, json.dumps(bad)[:500]))

    peak = max([b for _, b in rss.samples] + [hwm or 0]) if rss else 0
    summary["rss_samples"] = len(rss.samples) if rss else 0
    summary["rss_max_mib"] = round(max([b for _, b in rss.samples], default=0) / MIB, 1) if rss else None
    summary["vmhwm_mib"] = round(hwm / MIB, 1) if hwm else None
    summary["budget_mib"] = round(budget / MIB, 1)
    summary["allowance_mib"] = args.allowance
    if peak > budget + args.allowance * MIB:
        errors.append("RSS peaked at %.1f MiB, above budget %.1f MiB + allowance %.0f MiB"
                      % (peak / MIB, budget / MIB, args.allowance))

    # Tracing of the sampled copies.
    key = os.path.join(workdir, "key.json")
    sc.export_key(args.meshmark, catalog, args.asset, key)
    traced, innocents, wrong = 0, 0, []
    t0 = time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        copies = sampler.copies if sampler else []
        futs = {pool.submit(sc.check_trace, args.meshmark, n, p, original, key): n for n, p in copies}
        for fut in concurrent.futures.as_completed(futs):
            ok, accused, problem = fut.result()
            traced += ok
            innocents += len([a for a in accused if a != futs[fut]])
            if problem:
                wrong.append(problem)
    summary["detect_s"] = round(time.monotonic() - t0, 1)
    errors += wrong
    summary.update(sampled=args.sample, received=len(copies), traced=traced, innocents_accused=innocents)
    if len(copies) != args.sample:
        errors.append("%d of %d sampled copies received" % (len(copies), args.sample))
    summary["errors_total"] = len(errors)
    summary["errors"] = sc.capped(errors)
    summary["ok"] = not errors
    text = json.dumps(summary, indent=2)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")
    return 0 if not errors else 1


if __name__ == "__main__":
    sys.exit(main())
