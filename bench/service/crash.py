#!/usr/bin/env python3
"""Crash test of `meshmark serve`: SIGKILL it under load, again and again, then check that every
copy a client received is recorded in the catalogue and traces to its own recipient only.

    crash.py --catalog CAT --asset ID [--rounds 20] [--clients 8] [--seed N] [--format F]
             [--workdir DIR] [--out summary.json]

Each round:
  1. starts `meshmark serve --catalog CAT --listen 127.0.0.1:0` (its JSON log appended to
     WORKDIR/serve.log; the token file CAT.token is reused) and checks GET /healthz;
  2. runs CLIENTS threads, each requesting copies in a loop for new names
     (PREFIX-rROUND-tTHREAD-N) and saving every fully received 200 body (Content-Length checked)
     under WORKDIR/copies/ with its name and the time it was received;
  3. after a random 0.5-3 s (from --seed) kills the service with SIGKILL, stops the clients and
     counts their connection errors after the kill (expected, not failures).

After the rounds: `meshmark catalog list CAT` must exit 0; every received copy's name must be among
the asset's recipients in `catalog list --json` ({"assets": [{"asset", "recipients": [{"name",
...}]}]}); the asset's key is exported and a sample of the received copies is detected against the
original (all of them when <= 300, else a random 300 plus every copy received in the last 0.2 s
before a kill, the risky ones): each must be detected and accuse exactly its own name.

Failures (exit 1): any non-200 response or client error before the kill, a 200 whose body is short
of its Content-Length (a complete 200 response is what a buyer keeps), a service that does not
start or exits before it is killed, a catalogue that does not open, a received name not recorded,
a copy not traced to exactly its own name. Prints (and writes with --out) a JSON summary.
Standard library only.
"""
import argparse
import concurrent.futures
import http.client
import json
import os
import random
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import svc_common as sc  # noqa: E402

RISKY_S = 0.2
DETECT_SAMPLE = 300


def _records(log_path):
    out = []
    with open(log_path, encoding="utf-8", errors="replace") as f:
        for line in f:
            try:
                out.append(json.loads(line))
            except ValueError:
                out.append({"unparsed": line.rstrip()})
    return out


class Client(threading.Thread):
    def __init__(self, port, token, asset, fmt, prefix, outdir, stop_event, killed_at):
        super().__init__(daemon=True)
        self.port, self.token, self.asset, self.fmt = port, token, asset, fmt
        self.prefix, self.outdir, self.stop_event, self.killed_at = prefix, outdir, stop_event, killed_at
        self.received = []   # (name, path, monotonic time received)
        self.failures = []   # problems before the kill
        self.after_kill = 0  # connection errors after the kill (expected)
        self.requested = 0

    def run(self):
        n = 0
        conn = None
        while not self.stop_event.is_set():
            n += 1
            name = "%s-%d" % (self.prefix, n)
            self.requested += 1
            try:
                if conn is None:
                    conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
                status, headers, body = sc.request_copy(conn, self.token, self.asset, name, self.fmt)
                t = time.monotonic()
            except (OSError, http.client.HTTPException) as e:
                if conn is not None:
                    conn.close()
                conn = None
                if self.killed_at:
                    self.after_kill += 1
                    return
                self.failures.append("%s: %s: %s (before the kill)" % (name, type(e).__name__, e))
                time.sleep(0.05)
                continue
            path, problem = sc.keep_copy(name, status, headers, body, self.outdir)
            if problem:
                self.failures.append("%s: %s" % (name, problem))
                continue
            self.received.append((name, path, t))
        if conn is not None:
            conn.close()


def main():
    ap = argparse.ArgumentParser(description="Crash test of meshmark serve (see the module docstring).")
    ap.add_argument("--catalog", required=True)
    ap.add_argument("--asset", required=True)
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--seed", type=int, default=None, help="random seed (default: from the clock)")
    ap.add_argument("--format", default=None)
    ap.add_argument("--workdir", default=None, help="log, copies, key (default: a new folder in /tmp)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--detect-sample", type=int, default=DETECT_SAMPLE,
                    help="copies detected: all when at most this many, else this many at random plus the risky ones")
    ap.add_argument("--meshmark", default=os.environ.get("MESHMARK", sc.DEFAULT_MESHMARK))
    args = ap.parse_args()

    seed = args.seed if args.seed is not None else int(time.time())
    rng = random.Random(seed)
    catalog = os.path.abspath(args.catalog)
    workdir = args.workdir or tempfile.mkdtemp(prefix="meshmark-crash.")
    copydir = os.path.join(workdir, "copies")
    os.makedirs(copydir, exist_ok=True)
    log_path = os.path.join(workdir, "serve.log")
    prefix = "crash%d-%d" % (int(time.time()), os.getpid())
    errors = []
    received, risky, rounds = [], set(), []

    original = sc.asset_entry(sc.catalog_list(args.meshmark, catalog), args.asset)["original"]

    for r in range(args.rounds):
        svc = sc.Service(args.meshmark, catalog, log_path)
        info = {"round": r}
        try:
            port = svc.wait_ready()
            token = svc.token()
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
            c.request("GET", "/healthz")
            h = c.getresponse()
            h.read()
            c.close()
            if h.status != 200:
                errors.append("round %d: GET /healthz answered %d" % (r, h.status))
        except (RuntimeError, OSError, http.client.HTTPException) as e:
            errors.append("round %d: the service did not start: %s" % (r, e))
            svc.kill()
            rounds.append(info)
            continue
        stop_event = threading.Event()
        killed_at = []  # non-empty once killed (shared by the clients)
        clients = [Client(port, token, args.asset, args.format, "%s-r%d-t%d" % (prefix, r, i), copydir,
                          stop_event, killed_at) for i in range(args.clients)]
        for cl in clients:
            cl.start()
        wait = rng.uniform(0.5, 3.0)
        time.sleep(wait)
        if svc.proc.poll() is not None:
            errors.append("round %d: the service exited on its own (code %s) before the kill"
                          % (r, svc.proc.returncode))
        kill_t = time.monotonic()
        killed_at.append(kill_t)
        rc = svc.kill()
        stop_event.set()
        for cl in clients:
            cl.join(60)
            if cl.is_alive():
                errors.append("round %d: a client thread did not stop 60 s after the kill" % r)
        got = [x for cl in clients for x in cl.received]
        late = [x for x in got if x[2] > kill_t]  # read from the socket after the kill: fully sent before it
        for x in got:
            if kill_t - RISKY_S <= x[2]:
                risky.add(x[0])
        received += got
        for cl in clients:
            errors += ["round %d: %s" % (r, f) for f in cl.failures]
        info.update(kill_after_s=round(wait, 3), exit=rc, requested=sum(cl.requested for cl in clients),
                    received=len(got), received_in_last_0_2s=sum(1 for x in got if kill_t - RISKY_S <= x[2]),
                    received_after_kill_signal=len(late), connection_errors_after_kill=sum(cl.after_kill for cl in clients))
        rounds.append(info)
        print(json.dumps(info), file=sys.stderr)

    summary = {"catalog": catalog, "asset": args.asset, "seed": seed, "rounds": args.rounds,
               "clients": args.clients, "workdir": workdir, "prefix": prefix, "per_round": rounds,
               "received": len(received), "risky": len(risky),
               "connection_errors_after_kill": sum(x.get("connection_errors_after_kill", 0) for x in rounds)}

    # The catalogue opens and records every name a client received.
    lst = subprocess.run([args.meshmark, "catalog", "list", catalog, "-q"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE)
    summary["catalog_list_exit"] = lst.returncode
    if lst.returncode != 0:
        errors.append("meshmark catalog list exited %d: %s" % (lst.returncode, lst.stderr.decode(errors="replace")[-300:]))
    try:
        entry = sc.asset_entry(sc.catalog_list(args.meshmark, catalog), args.asset)
        recorded = {x["name"] for x in entry.get("recipients", [])}
        missing = [n for n, _, _ in received if n not in recorded]
        ours = [n for n in recorded if n.startswith(prefix + "-")]
        summary.update(recorded_names_this_run=len(ours), received_not_recorded=len(missing),
                       recorded_not_received=len(set(ours) - {n for n, _, _ in received}))
        if missing:
            errors.append("%d received copies are not recorded in the catalogue, e.g. %s" % (len(missing), missing[:5]))
    except (RuntimeError, ValueError, KeyError) as e:
        errors.append("catalog list --json: %s" % e)

    # The service's log: 5xx answers, unexpected notices (e.g. 'request failed inside the service').
    # A line cut short by SIGKILL is not JSON: counted, not a failure.
    records = _records(log_path)
    summary["log_unparsed_lines"] = sum(1 for r in records if "unparsed" in r)
    errors += ["service log: %s" % line for line in sc.log_problems([r for r in records if "unparsed" not in r])]

    # Tracing: all copies, or a random DETECT_SAMPLE plus the risky ones.
    if len(received) <= args.detect_sample:
        chosen = received
    else:
        chosen = rng.sample(received, args.detect_sample)
        names = {n for n, _, _ in chosen}
        chosen += [x for x in received if x[0] in risky and x[0] not in names]
    traced, innocents = 0, 0
    try:
        key = os.path.join(workdir, "key.json")
        sc.export_key(args.meshmark, catalog, args.asset, key)
        t0 = time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            futs = {pool.submit(sc.check_trace, args.meshmark, n, p, original, key): n for n, p, _ in chosen}
            for fut in concurrent.futures.as_completed(futs):
                ok, accused, problem = fut.result()
                traced += ok
                innocents += len([a for a in accused if a != futs[fut]])
                if problem:
                    errors.append(problem)
        summary["detect_s"] = round(time.monotonic() - t0, 1)
    except RuntimeError as e:
        errors.append(str(e))
    summary.update(detected_sample=len(chosen), traced=traced, innocents_accused=innocents,
                   errors_total=len(errors), errors=sc.capped(errors), ok=not errors)
    text = json.dumps(summary, indent=2)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")
    return 0 if not errors else 1


if __name__ == "__main__":
    sys.exit(main())
