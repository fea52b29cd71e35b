#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Many `meshmark embed --recipient` processes issuing on one family key at once (issue 50).

Each round starts --processes calls together, each issuing one new name (and, with --shared,
one name every call of the round also issues) on one key, with -o naming a folder that does not
exist yet. With --kill, one call of each round is killed with SIGKILL at a random moment of its
run. While the calls run, a reader parses the key file over and over, and `meshmark detect`
reads the key once per round. After each round:
  - every call not killed exited 0;
  - the key loads and names every recipient once, with an index of its own;
  - every visible copy (file name without a leading '.') belongs to a recipient the key holds;
  - the copies of a name issued by several calls are byte for byte the same.
At the end `meshmark detect` runs on every copy (two at a time): each must accuse its own
recipient and nobody else. Prints a JSON summary; exit 0 when every check held.

Full run (the issue's targets; about 20 minutes on 2 cores):
  python3 bench/issuing/concurrent_issue.py --processes 16 --rounds 50
  python3 bench/issuing/concurrent_issue.py --processes 16 --rounds 50 --kill
The test suite runs a short version (tests/integration/CMakeLists.txt, concurrent_issue_smoke).
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path


def default_cli():
    here = Path(__file__).resolve().parents[2]
    return os.environ.get("MESHMARK_CLI") or str(here / "build" / "bin" / "meshmark")


def default_mesh():
    base = (os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
            or str(Path(__file__).resolve().parents[3] / "shared" / "data" / "meshes"))
    return str(Path(base) / "bunny.stl")


class KeyReader(threading.Thread):
    """Parses the key file over and over while calls issue on it; counts reads and failures."""

    def __init__(self, path):
        super().__init__(daemon=True)
        self.path = path
        self.reads = 0
        self.failures = []
        self.stop = threading.Event()

    def run(self):
        while not self.stop.is_set():
            try:
                with open(self.path, "rb") as f:
                    text = f.read()
            except FileNotFoundError:
                continue
            try:
                json.loads(text)
                self.reads += 1
            except ValueError as e:
                self.failures.append(f"{len(text)} bytes: {e}")


def load_key(path):
    with open(path) as f:
        key = json.load(f)
    recipients = key["recipients"]["issued"]
    names = [r["name"] for r in recipients]
    indices = [r["index"] for r in recipients]
    return names, indices


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--mesh", default=default_mesh(), help="the original (default: the shared bunny.stl)")
    parser.add_argument("--processes", type=int, default=16)
    parser.add_argument("--rounds", type=int, default=50)
    parser.add_argument("--kill", action="store_true", help="SIGKILL one call at a random moment each round")
    parser.add_argument("--shared", action="store_true", help="every call of a round also issues one common name")
    parser.add_argument("--detect-every", type=int, default=1, help="detect every Nth copy at the end (1 = all)")
    parser.add_argument("--seed", type=int, default=50)
    parser.add_argument("--workdir", default=None, help="kept when given; a temporary folder otherwise")
    args = parser.parse_args()
    if not Path(args.mesh).exists():
        print(f"concurrent_issue: {args.mesh} is missing; skipped", file=sys.stderr)
        return 77
    rng = random.Random(args.seed)
    work = Path(args.workdir) if args.workdir else Path(tempfile.mkdtemp(prefix="meshmark-issue-"))
    if args.workdir:
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
    key = work / "fam.json"
    copies = work / "copies"  # does not exist: the calls create it, one folder per call slot
    ext = Path(args.mesh).suffix

    def call(slot, names):
        pattern = str(copies / f"p{slot}" / ("{recipient}" + ext))
        words = [args.cli, "embed", args.mesh, "--key", str(key), "-o", pattern, "--quiet"]
        for name in names:
            words += ["--recipient", name]
        return words

    def visible_copies():
        return sorted(f for f in copies.rglob("*" + ext) if not f.name.startswith("."))

    problems = []
    start = time.monotonic()
    first = subprocess.run(call(0, ["alice"]), capture_output=True, text=True)
    if first.returncode != 0:
        print(first.stderr, file=sys.stderr)
        return 1
    call_seconds = time.monotonic() - start
    reader = KeyReader(key)
    reader.start()
    owners = {"alice": None}  # name -> round
    kills = 0
    killed_names = set()
    kills_landed = 0
    killed_outcome = {"not recorded": 0, "recorded, no copy": 0, "recorded, copy delivered": 0}
    calls = 0
    detect_during = 0
    issue_start = time.monotonic()
    round_seconds = call_seconds * args.processes / max(1, os.cpu_count() or 1)  # a guess until measured
    for r in range(args.rounds):
        round_start = time.monotonic()
        names = [f"r{r}p{p}" for p in range(args.processes)]
        common = f"r{r}all"
        procs = []
        for p, name in enumerate(names):
            issued = [name] + ([common] if args.shared else [])
            procs.append(subprocess.Popen(call(p, issued), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                          text=True))
        calls += len(procs)
        victim = rng.randrange(len(procs)) if args.kill else None
        if victim is not None:
            time.sleep(rng.uniform(0.0, round_seconds))  # any moment of the victim's run
            procs[victim].send_signal(signal.SIGKILL)
            kills += 1
        # detect reads the key while the calls write it.
        detect = subprocess.run([args.cli, "detect", str(copies / "p0" / ("alice" + ext)), "--original", args.mesh,
                                 "--key", str(key), "--json", "--quiet"], capture_output=True, text=True)
        detect_during += 1
        if detect.returncode != 0 or json.loads(detect.stdout)["recipients"][0]["name"] != "alice":
            problems.append(f"round {r}: detect during issuing: exit {detect.returncode} {detect.stderr.strip()}")
        for p, proc in enumerate(procs):
            _, err = proc.communicate()
            if p == victim and proc.returncode == -signal.SIGKILL:
                killed_names.add(names[p])
                kills_landed += 1
                continue
            if proc.returncode != 0:
                problems.append(f"round {r}: {names[p]} exited {proc.returncode}: {err.strip()}")
        round_seconds = time.monotonic() - round_start
        try:
            held, indices = load_key(key)
        except Exception as e:  # noqa: BLE001 - any failure to load is the finding
            problems.append(f"round {r}: the key does not load: {e}")
            break
        if len(set(held)) != len(held) or len(set(indices)) != len(indices):
            problems.append(f"round {r}: a name or an index appears twice in the key")
        for name in names + ([common] if args.shared else []):
            if name in held:
                owners.setdefault(name, r)
        for file in visible_copies():
            if file.stem not in held:
                problems.append(f"round {r}: {file.name} is visible but the key does not hold {file.stem}")
        for p, name in enumerate(names):
            if name in killed_names and p == victim:
                delivered = (copies / f"p{p}" / (name + ext)).exists()
                outcome = ("recorded, copy delivered" if delivered else "recorded, no copy") if name in held \
                    else "not recorded"
                killed_outcome[outcome] += 1
            elif name not in held:
                problems.append(f"round {r}: {name} exited 0 but is not in the key")
        if args.shared:
            # Every call of the round issued the common name: one index, the same bytes everywhere.
            if held.count(common) != 1:
                problems.append(f"round {r}: {common} recorded {held.count(common)} times")
            versions = {hashlib.sha256((copies / f"p{p}" / (common + ext)).read_bytes()).hexdigest()
                        for p in range(args.processes) if (copies / f"p{p}" / (common + ext)).exists()}
            if len(versions) != 1:
                problems.append(f"round {r}: {common} was issued as {len(versions)} different copies")
    issue_seconds = time.monotonic() - issue_start
    reader.stop.set()
    reader.join()
    if reader.failures:
        problems.append(f"the key was read half-written {len(reader.failures)} times: {reader.failures[:3]}")

    # Every visible copy accuses its own recipient only.
    held, _ = load_key(key)
    visible = visible_copies()
    checked = visible[:: args.detect_every]
    leftovers = sorted(str(f.relative_to(work)) for f in work.rglob(".*"))

    def accused(path):
        out = subprocess.run([args.cli, "detect", str(path), "--original", args.mesh, "--key", str(key), "--json",
                              "--quiet"], capture_output=True, text=True)
        if out.returncode > 1:
            return path, None, out.stderr.strip()
        return path, [r["name"] for r in json.loads(out.stdout).get("recipients", [])], ""

    wrong = 0
    detect_start = time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        for path, names, err in pool.map(accused, checked):
            own = path.stem
            if names != [own]:
                wrong += 1
                problems.append(f"{path.name}: accuses {names} {err}".strip())
    detect_seconds = time.monotonic() - detect_start
    summary = {
        "mesh": args.mesh,
        "processes": args.processes,
        "rounds": args.rounds,
        "calls": calls,
        "kills_sent": kills,
        "kills_landed": kills_landed,
        "killed_calls": killed_outcome,
        "recipients_in_key": len(held),
        "visible_copies": len(visible),
        "distinct_copies": len({hashlib.sha256(f.read_bytes()).hexdigest() for f in visible}),
        "copies_detected": len(checked),
        "copies_accusing_someone_else": wrong,
        "hidden_files_left": leftovers,
        "key_reads_during_issuing": reader.reads,
        "detect_runs_during_issuing": detect_during,
        "issuing_seconds": round(issue_seconds, 1),
        "detect_seconds": round(detect_seconds, 1),
        "problems": problems[:50],
        "problem_count": len(problems),
    }
    print(json.dumps(summary, indent=2))
    if not args.workdir:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if not problems else 1


if __name__ == "__main__":
    sys.exit(main())
