#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""`catalog add` on a real Dask cluster (meshmark.cluster): 1 vs 2 workers, a worker killed,
the coordinator killed.

Corpus: the OBJ models of Debian's sweethome3d-furniture (/usr/share/sweethome3d/furniture/
*.sh3f, extracted under --work-dir), --assets of those with >= 500 `v ` lines (sorted paths,
evenly spaced), each copied with its folder (.mtl, textures) into WORK/corpus/.

Starts `dask-scheduler` and `dask-worker` processes (one thread each, PYTHONPATH passed through)
on 127.0.0.1 and always stops them at the end (also on Ctrl-C). Then:
  1. throughput: Catalog.add(client=...) with 1 worker and with 2 workers, and the local
     Catalog.add(jobs=1) and jobs=2 (threads=1: one thread per file, as on a worker), --repeats
     rounds, alternating, each run into a fresh catalogue and folder with the same --seed;
     every run's files must be byte-identical to the first run's (and a few exported keys);
     the coordinator's seconds in _catalog_plan_add / _catalog_record and the CPU seconds of
     every process (/proc/PID/stat) are reported;
  2. worker kill: --kill-assets files (WORK/corpus-kill) added with 2 workers without a kill,
     then again with one worker process kill -9'ed at 30-60% of that run's time (its nanny
     restarts it), then with a worker and its nanny kill -9'ed (the add finishes on the other);
  3. coordinator kill: the add run by `python3 -m meshmark.cluster REQUEST.json` in a child
     process, kill -9'ed at 30-60% of its files, then run again to the end.
After each kill: every asset recorded once and complete (`meshmark catalog list --json`),
outcomes and files byte-identical to the run without a kill, keys (`catalog export`) too.
Prints a markdown summary (and --json-file); exit 0 when every check held, 1 otherwise.

  PYTHONPATH=build/python /usr/bin/python3 bench/cluster/cluster_bench.py --assets 300
"""
import argparse
import hashlib
import json
import os
import random
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from pathlib import Path

MESH_SUFFIXES = {".ply", ".obj", ".off", ".stl", ".gltf", ".glb", ".3mf"}
TICKS = os.sysconf("SC_CLK_TCK")


def say(*words):
    print(*words, file=sys.stderr, flush=True)


def default_cli():
    here = Path(__file__).resolve().parents[2] / "build" / "bin" / "meshmark"
    return os.environ.get("MESHMARK_CLI") or (str(here) if here.exists() else shutil.which("meshmark"))


# ---------------------------------------------------------------------------------------- corpus

def extract_sh3f(source, work):
    root = work / "sh3f"
    for archive in sorted(Path(source).glob("*.sh3f")):
        dest = root / archive.stem
        done = dest / ".extracted"
        if not done.exists():
            dest.mkdir(parents=True, exist_ok=True)
            with zipfile.ZipFile(archive) as z:
                z.extractall(dest)
            done.touch()
    return root


def vertex_lines(path):
    with open(path, "rb") as f:
        return sum(1 for line in f if line.startswith(b"v "))


def qualifying_objs(root, min_vertices):
    objs = sorted(p for p in root.rglob("*") if p.suffix.lower() == ".obj" and p.is_file())
    return [p for p in objs if vertex_lines(p) >= min_vertices], len(objs)


def evenly(items, n):
    return [items[i * len(items) // n] for i in range(n)] if n < len(items) else list(items)


def copy_asset(obj, sh3f_root, corpus):
    """The OBJ with its folder (materials, textures), other meshes of that folder left out."""
    folder = obj.parent
    dest = corpus / folder.relative_to(sh3f_root)
    for item in folder.rglob("*"):
        if not item.is_file() or (item.suffix.lower() in MESH_SUFFIXES and item != obj):
            continue
        target = dest / item.relative_to(folder)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(item, target)


def make_corpus(corpus, objs, sh3f_root):
    if corpus.exists():
        shutil.rmtree(corpus)
    corpus.mkdir(parents=True)
    for obj in objs:
        copy_asset(obj, sh3f_root, corpus)
    return len(objs)


# ---------------------------------------------------------------------------------------- cluster

def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def proc_cpu(pid):
    """CPU seconds (user + system) of a live process, 0 when gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICKS
    except (OSError, IndexError, ValueError):
        return 0.0


def system_cpu():
    """Machine-wide CPU seconds from /proc/stat: (busy, iowait, steal)."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    # user nice system idle iowait irq softirq steal
    return (v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / TICKS, v[4] / TICKS, v[7] / TICKS


def thread_cpu():
    """This process's CPU seconds per thread, named by Python where it knows the thread."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    out = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        tid = int(task.name)
        name = names.get(tid, (task / "comm").read_text().strip() if (task / "comm").exists() else "?")
        out[f"{name}[{tid}]"] = (int(fields[11]) + int(fields[12])) / TICKS
    return out


def kill_group(proc, sig=signal.SIGTERM, wait=10.0):
    if proc is None or proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        return
    try:
        proc.wait(wait)
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(10)


class Cluster:
    def __init__(self, work, env, worker_env=None):
        self.work, self.env = work, env
        self.worker_env = worker_env or env
        self.port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        (work / "logs").mkdir(parents=True, exist_ok=True)
        self.scheduler = None
        self.workers = {}  # slot -> Popen (the nanny, leader of its process group)
        self.started = 0
        self.client = None

    def start(self):
        log = open(self.work / "logs" / "scheduler.log", "ab")
        self.scheduler = subprocess.Popen(
            ["dask-scheduler", "--host", "127.0.0.1", "--port", str(self.port), "--no-dashboard"],
            env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        from dask.distributed import Client
        deadline = time.monotonic() + 60
        while True:
            try:
                # The default client: meshmark.cluster.catalog_add's as_completed() finds its
                # loop through default_client() (with set_as_default=False it fails, "No
                # clients found").
                self.client = Client(self.address, timeout=5)
                return
            except (OSError, TimeoutError):
                if time.monotonic() > deadline or self.scheduler.poll() is not None:
                    raise RuntimeError(f"dask-scheduler did not start (see {self.work}/logs/scheduler.log)")
                time.sleep(0.5)

    def start_worker(self):
        self.started += 1
        n = self.started
        log = open(self.work / "logs" / f"worker-{n}.log", "ab")
        self.workers[n] = subprocess.Popen(
            ["dask-worker", self.address, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1",
             "--local-directory", str(self.work / f"dask-{n}"), "--name", f"w{n}"],
            env=self.worker_env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        return n

    def stop_worker(self, n, sig=signal.SIGTERM):
        kill_group(self.workers.pop(n), sig)

    def worker_pids(self):
        """{worker address: pid of the worker process (the nanny's child)}."""
        return self.client.run(os.getpid)

    def wait_workers(self, count, timeout=120):
        deadline = time.monotonic() + timeout
        while len(self.client.scheduler_info()["workers"]) != count:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the client sees {len(self.client.scheduler_info()['workers'])} "
                                   f"workers, not {count}")
            time.sleep(0.2)
        # Every worker imports the extension now, not in the first timed task.
        self.client.run(lambda: __import__("meshmark._meshmark").__name__)

    def scale(self, count):
        while len(self.workers) > count:
            self.stop_worker(max(self.workers))
        while len(self.workers) < count:
            self.start_worker()
        self.wait_workers(count)

    def cpu(self):
        pids = [self.scheduler.pid] + [p.pid for p in self.workers.values()]
        try:
            pids += list(self.worker_pids().values())
        except Exception:  # noqa: BLE001 - a worker just died: counted without it
            pass
        return {pid: proc_cpu(pid) for pid in pids}

    def close(self):
        if self.client is not None:
            try:
                self.client.close(timeout=5)
            except Exception:  # noqa: BLE001
                pass
        for n in list(self.workers):
            self.stop_worker(n)
        kill_group(self.scheduler)


# ---------------------------------------------------------------------------------------- checks

def tree_digest(folder):
    folder = Path(folder)
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            out[p.relative_to(folder).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def compare_digests(reference, digest, not_marked=()):
    """Differences, each told as in the folder of an asset the reference did not mark or not."""
    problems = []
    missing = sorted(set(reference) - set(digest))
    extra = sorted(set(digest) - set(reference))
    differ = sorted(k for k in set(reference) & set(digest) if reference[k] != digest[k])
    folders = {str(Path(a).parent) for a in not_marked}
    for what, items in (("missing", missing), ("extra", extra), ("different", differ)):
        if items:
            beside = sum(1 for i in items if str(Path(i).parent) in folders)
            note = f" ({beside} of them in the folder of an asset the reference did not mark)" if beside else ""
            problems.append(f"{len(items)} files {what}{note}, e.g. {items[:3]}")
    return problems


def catalog_list(cli, catalog):
    done = subprocess.run([cli, "catalog", "list", str(catalog), "--json"], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"catalog list {catalog}: {done.stderr.strip()}")
    return json.loads(done.stdout)["assets"]


def export_keys(cli, catalog, assets, folder):
    folder.mkdir(parents=True, exist_ok=True)
    keys = {}
    for n, asset in enumerate(assets):
        out = folder / f"key{n}.json"
        if out.exists():
            out.unlink()
        done = subprocess.run([cli, "catalog", "export", str(catalog), asset, "--key", str(out)],
                              capture_output=True, text=True)
        keys[asset] = out.read_bytes() if done.returncode == 0 else f"export failed: {done.stderr.strip()}"
    return keys


def outcomes_of(report):
    return {f["asset"]: f["outcome"] for f in report["files"]}


# ---------------------------------------------------------------------------------------- runs

class RecordTimer:
    """Wraps the coordinator's steps (meshmark.cluster calls them through _meshmark)."""

    def __init__(self, core):
        self.core = core
        self.originals = {}
        self.reset()
        for name in ("_catalog_plan_add", "_catalog_record", "_catalog_add_report"):
            self.originals[name] = getattr(core, name)
            setattr(core, name, self._wrap(name, self.originals[name]))

    def reset(self):
        self.calls = {}
        self.bytes = 0

    def _wrap(self, name, function):
        def timed(*args, **kwargs):
            wall, cpu = time.perf_counter(), time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                entry = self.calls.setdefault(name, [0, 0.0, 0.0])
                entry[0] += 1
                entry[1] += time.perf_counter() - wall
                entry[2] += time.thread_time() - cpu
                if name == "_catalog_record":
                    self.bytes += sum(len(b) for _, b in args[3])
        return timed

    def restore(self):
        for name, function in self.originals.items():
            setattr(self.core, name, function)


class Bench:
    def __init__(self, args, work, env):
        import meshmark
        import meshmark.cluster
        self.meshmark = meshmark
        self.cluster_module = meshmark.cluster
        self.args, self.work, self.env = args, work, env
        self.timer = RecordTimer(meshmark.cluster._meshmark)
        self.cluster = None
        self.problems = []
        self.serial = 0
        self.kept = set()

    def fail(self, what):
        self.problems.append(what)
        say(f"!!! CHECK FAILED: {what}")

    def fresh(self, label):
        self.serial += 1
        folder = self.work / "runs" / f"{self.serial:02d}-{label}"
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        return folder, folder / "shop.catalog", folder / "published"

    def drop(self, folder):
        if not self.args.keep and folder not in self.kept:
            shutil.rmtree(folder, ignore_errors=True)

    def add(self, label, corpus, mode, workers=0, jobs=0, progress=None, during=None):
        """One add into a fresh catalogue; its figures."""
        folder, catalog_path, output = self.fresh(label)
        catalog = self.meshmark.Catalog(catalog_path, create=True)
        self.timer.reset()
        cluster_cpu = self.cluster.cpu() if self.cluster else {}
        own, threads0, machine0 = os.times(), thread_cpu(), system_cpu()
        if during:
            during.start()
        start = time.perf_counter()
        if mode == "cluster" and progress is None:
            report = catalog.add([str(corpus)], str(output), client=self.cluster.client, seed=self.args.seed)
        elif mode == "cluster":
            report = self.cluster_module.catalog_add(catalog, [str(corpus)], str(output),
                                                     client=self.cluster.client, seed=self.args.seed,
                                                     progress=progress)
        else:
            report = catalog.add([str(corpus)], str(output), jobs=jobs, threads=1, seed=self.args.seed)
        wall = time.perf_counter() - start
        if during:
            during.join()
        own2, threads1, machine1 = os.times(), thread_cpu(), system_cpu()
        cluster_cpu2 = self.cluster.cpu() if self.cluster else {}
        counts = report["counts"]
        tasks = counts.get("marked", 0) + counts.get("unmarkable", 0) + counts.get("failed", 0)
        run = {
            "label": label, "mode": mode, "workers": workers, "jobs": jobs, "folder": str(folder),
            "catalog": str(catalog_path), "output": str(output), "wall_s": wall,
            "files": len(report["files"]), "counts": counts,
            "assets_per_s": len(report["files"]) / wall,
            "marking_s_sum": sum(f.get("seconds", 0.0) for f in report["files"]),
            "coordinator_cpu_s": (own2.user - own.user) + (own2.system - own.system),
            "coordinator_threads_cpu_s": {k: round(v - threads0.get(k, 0.0), 3)
                                          for k, v in threads1.items() if v - threads0.get(k, 0.0) >= 0.05},
            "steps": {k: {"calls": v[0], "wall_s": v[1], "cpu_s": v[2]} for k, v in self.timer.calls.items()},
            "record_bytes": self.timer.bytes,
            "tasks": tasks,
        }
        if self.cluster:
            sched = self.cluster.scheduler.pid
            run["scheduler_cpu_s"] = cluster_cpu2.get(sched, 0.0) - cluster_cpu.get(sched, 0.0)
            # A process started during the run counts from 0; one killed during it is not
            # counted (its CPU lands in other_cpu_s).
            run["workers_cpu_s"] = sum(cpu - cluster_cpu.get(p, 0.0)
                                       for p, cpu in cluster_cpu2.items() if p != sched)
        run["machine_busy_s"] = machine1[0] - machine0[0]
        run["machine_iowait_s"] = machine1[1] - machine0[1]
        run["machine_steal_s"] = machine1[2] - machine0[2]
        ours = run["coordinator_cpu_s"] + run.get("scheduler_cpu_s", 0.0) + run.get("workers_cpu_s", 0.0)
        run["other_cpu_s"] = run["machine_busy_s"] - ours  # processes not of this run (and the kernel's)
        run["report"] = report
        return run

    def check_same(self, run, reference, what):
        """Files, outcomes and a few keys as the reference's; catalogue complete, each asset once."""
        args = self.args
        issues = compare_digests(reference["digest"], tree_digest(run["output"]),
                                 [f["asset"] for f in reference["report"]["files"] if f["outcome"] != "marked"])
        ref_out, out = outcomes_of(reference["report"]), outcomes_of(run["report"])
        if sorted(out) != sorted(ref_out):
            issues.append(f"the report names other assets ({len(out)} vs {len(ref_out)})")
        changed = [a for a in ref_out if a in out and out[a] != ref_out[a]
                   and not (out[a] == "present" and ref_out[a] == "marked")]
        if changed:
            issues.append(f"{len(changed)} outcomes differ, e.g. "
                          f"{[(a, ref_out[a], out[a]) for a in changed[:3]]}")
        listed = catalog_list(args.cli, run["catalog"])
        ids = [a["asset"] for a in listed]
        marked = sorted(a for a, o in ref_out.items() if o == "marked")
        if len(ids) != len(set(ids)):
            issues.append(f"catalog list names {len(ids) - len(set(ids))} assets twice")
        if sorted(set(ids)) != marked:
            issues.append(f"catalog list has {len(set(ids))} assets, the reference marked {len(marked)}")
        incomplete = [a["asset"] for a in listed if not a["complete"]]
        if incomplete:
            issues.append(f"{len(incomplete)} assets not complete, e.g. {incomplete[:3]}")
        keys = export_keys(args.cli, run["catalog"], reference["key_assets"], Path(run["folder"]) / "keys")
        bad = [a for a in reference["key_assets"] if keys[a] != reference["keys"][a]]
        if bad:
            issues.append(f"{len(bad)} of {len(keys)} exported keys differ, e.g. {bad[:2]}")
        run["listed_assets"] = len(ids)
        run["keys_compared"] = len(keys)
        run["identical"] = not issues
        for issue in issues:
            self.fail(f"{what} ({run['label']}): {issue}")
        return not issues

    def make_reference(self, run):
        marked = sorted(f["asset"] for f in run["report"]["files"] if f["outcome"] == "marked")
        key_assets = evenly(marked, self.args.keys) if marked else []
        run["digest"] = tree_digest(run["output"])
        run["key_assets"] = key_assets
        run["keys"] = export_keys(self.args.cli, run["catalog"], key_assets, Path(run["folder"]) / "keys")
        failed = [a for a, k in run["keys"].items() if isinstance(k, str)]
        if failed:
            self.fail(f"catalog export failed on the reference for {failed[:2]}")
        listed = catalog_list(self.args.cli, run["catalog"])
        if len(listed) != len(marked) or not all(a["complete"] for a in listed):
            self.fail(f"reference {run['label']}: catalog list shows {len(listed)} assets for {len(marked)} marked")
        self.kept.add(Path(run["folder"]))
        return run

    # ------------------------------------------------------------------------------ throughput

    def throughput(self, corpus):
        args = self.args
        say(f"-- throughput on {corpus}: warm-up / reference run (2 workers)")
        self.cluster.scale(2)
        reference = self.make_reference(self.add("reference-2w", corpus, "cluster", workers=2))
        say(f"   {reference['wall_s']:.1f} s, {reference['counts']}")
        runs, calibrations = [], []
        configs = [("cluster", 1), ("cluster", 2), ("local", 1), ("local", 2)]
        for r in range(args.repeats):
            order = configs if r % 2 == 0 else [configs[1], configs[0], configs[3], configs[2]]
            for mode, n in order:
                if mode == "cluster":
                    self.cluster.scale(n)
                    run = self.add(f"r{r}-{n}w", corpus, "cluster", workers=n)
                else:
                    run = self.add(f"r{r}-jobs{n}", corpus, "local", jobs=n)
                run["round"] = r
                self.check_same(run, reference, "throughput")
                say(f"   round {r} {run['label']}: {run['wall_s']:.2f} s, {run['assets_per_s']:.1f} assets/s, "
                    f"coordinator CPU {run['coordinator_cpu_s']:.1f} s, identical: {run['identical']}")
                runs.append(run)
                self.drop(Path(run["folder"]))
            calibrations.append(self.calibrate(corpus, r))
        return reference, runs, calibrations

    # ------------------------------------------------------------------------------ calibration

    def calibrate(self, corpus, round_):
        """What two processes get from this machine with no coordination at all: a pure-Python
        spin, and two local adds (jobs=1, threads=1) of the corpus's halves, alone then at once."""
        calib = self.work / "calib"
        if not (calib / "a").exists():
            folders = sorted({p.parent for p in corpus.rglob("*") if p.suffix.lower() in MESH_SUFFIXES})
            for n, folder in enumerate(folders):
                for item in folder.rglob("*"):
                    if item.is_file():
                        target = calib / "ab"[n % 2] / item.relative_to(corpus)
                        target.parent.mkdir(parents=True, exist_ok=True)
                        os.link(item, target)

        def spawn(code, *argv):
            return subprocess.Popen([sys.executable, "-c", code, *argv], env=self.env,
                                    stdout=subprocess.PIPE, text=True, start_new_session=True)

        def together(*procs):
            start = time.perf_counter()
            outs = [json.loads(p.communicate()[0]) for p in procs]
            return time.perf_counter() - start, outs

        spin = ("import time,json\nt=time.perf_counter();s=0\nfor i in range(15_000_000): s+=i*i\n"
                "print(json.dumps(time.perf_counter()-t))")
        add = ("import json,sys,time,meshmark\nc=meshmark.Catalog(sys.argv[1],create=True)\n"
               "t=time.perf_counter()\nr=c.add([sys.argv[2]],sys.argv[3],jobs=1,threads=1,seed=7)\n"
               "print(json.dumps([time.perf_counter()-t,len(r['files'])]))")

        def add_args(half, tag):
            folder = calib / f"run-{tag}-{half}"
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(parents=True)
            return str(folder / "c.catalog"), str(calib / half), str(folder / "out")

        spin_one = together(spawn(spin))[0]
        spin_two = together(spawn(spin), spawn(spin))[0]
        alone = {h: together(spawn(add, *add_args(h, "alone")))[1][0] for h in "ab"}
        wall_two, both = together(*[spawn(add, *add_args(h, "both")) for h in "ab"])
        files = sum(n for _, n in both)
        out = {"round": round_, "spin_one_s": spin_one, "spin_two_s": spin_two,
               "spin_ratio": 2 * spin_one / spin_two,
               "halves_alone_s": {h: v[0] for h, v in alone.items()},
               "halves_together_s": wall_two, "halves_files": files,
               "add_ratio": (alone["a"][0] + alone["b"][0]) / wall_two}
        say(f"   round {round_} calibration: spin 2 procs/1 proc {out['spin_ratio']:.2f}; two local adds at "
            f"once vs one after the other {out['add_ratio']:.2f}")
        for folder in calib.glob("run-*"):
            shutil.rmtree(folder, ignore_errors=True)
        return out

    # ------------------------------------------------------------------------------ kills

    def worker_kill(self, corpus, reference, mode):
        """mode 'worker': kill -9 one worker process (its nanny restarts it); 'node': kill -9 a
        worker and its nanny (the process group), the add finishing on the other worker."""
        rng = random.Random(f"{self.args.seed}-{mode}")
        self.cluster.scale(2)
        pids = self.cluster.worker_pids()
        victim_address = sorted(pids)[rng.randrange(len(pids))]
        victim = pids[victim_address]
        nanny = next(n for n, p in self.cluster.workers.items()
                     if victim in children_of(p.pid))
        delay = rng.uniform(0.3, 0.6) * reference["wall_s"]
        state = {"done": 0, "total": 0, "at": None, "times": []}

        def progress(done, total):
            state["done"], state["total"] = done, total
            state["times"].append(time.perf_counter())

        def killer():
            time.sleep(delay)
            state["at"] = (state["done"], state["total"])
            if state["total"] and state["done"] >= state["total"]:
                state["at"] = None  # the add was over: nothing killed midway
                return
            if mode == "worker":
                os.kill(victim, signal.SIGKILL)
            else:
                os.killpg(self.cluster.workers[nanny].pid, signal.SIGKILL)
            say(f"   kill -9 {'worker pid' if mode == 'worker' else 'nanny+worker group of'} "
                f"{victim} at {delay:.1f} s, {state['done']}/{state['total']} files recorded")

        say(f"-- worker kill ({mode}) on {corpus}: kill at {delay:.1f} s")
        run = self.add(f"kill-{mode}", corpus, "cluster", workers=2, progress=progress,
                       during=threading.Thread(target=killer))
        times = state["times"]
        gaps = [(b - a, a - times[0]) for a, b in zip(times, times[1:])]
        if gaps:
            longest = max(gaps)
            run["longest_gap_s"], run["longest_gap_at_s"] = longest[0], longest[1]
            say(f"   longest wait between two recorded files: {longest[0]:.1f} s, at {longest[1]:.1f} s")
        if state["at"] is None:
            self.fail(f"worker kill ({mode}): the add finished before the kill at {delay:.1f} s; "
                      f"nothing was tested (a larger --kill-assets)")
        run["kill_after_s"] = delay
        run["kill_at_files"] = state["at"]
        run["killed"] = "worker process" if mode == "worker" else "worker and nanny"
        if state["at"] is None:
            pass
        elif mode == "node":
            self.cluster.workers.pop(nanny).wait(10)
            run["workers_after"] = len(self.cluster.client.scheduler_info()["workers"])
        else:
            try:
                self.cluster.wait_workers(2, timeout=60)
                after = self.cluster.worker_pids()
                run["workers_after"] = len(after)
                run["restarted"] = victim not in after.values()
            except RuntimeError as error:
                self.fail(f"kill-worker: the nanny did not bring the worker back ({error})")
        self.check_same(run, reference, f"worker kill ({mode})")
        say(f"   {run['wall_s']:.1f} s, {run['counts']}, identical: {run['identical']}")
        self.drop(Path(run["folder"]))
        return run

    def coordinator_kill(self, corpus, reference):
        rng = random.Random(f"{self.args.seed}-coordinator")
        self.cluster.scale(2)
        folder, catalog_path, output = self.fresh("kill-coordinator")
        target = rng.uniform(0.3, 0.6)
        request = {"command": "add", "scheduler": self.cluster.address, "catalog": str(catalog_path),
                   "lock_timeout": 60.0, "inputs": [str(corpus)], "output": str(output),
                   "options": {"seed": self.args.seed}, "progress": True}
        (folder / "request.json").write_text(json.dumps(request))
        say(f"-- coordinator kill on {corpus}: python3 -m meshmark.cluster, kill -9 at {target:.0%} of the files")

        def child():
            return subprocess.Popen([sys.executable, "-m", "meshmark.cluster", str(folder / "request.json")],
                                    env=self.env, stdout=subprocess.PIPE, text=True, start_new_session=True)

        first = child()
        killed_at, result = None, {}
        start = time.perf_counter()
        try:
            for line in first.stdout:
                message = json.loads(line)
                if "progress" in message and message["progress"] >= target:
                    os.killpg(first.pid, signal.SIGKILL)
                    killed_at = message["progress"]
                    break
                result = message
        finally:
            kill_group(first, signal.SIGKILL)
        first_s = time.perf_counter() - start
        run = {"label": "kill-coordinator", "folder": str(folder), "catalog": str(catalog_path),
               "output": str(output), "target": target, "killed_at": killed_at, "first_s": first_s,
               "first_rc": first.returncode}
        if killed_at is None:
            self.fail(f"coordinator kill: the child finished before the kill ({result})")
        listed = catalog_list(self.args.cli, catalog_path)
        run["after_kill"] = {"assets": len(listed), "complete": sum(a["complete"] for a in listed),
                             "files": sum(1 for p in Path(output).rglob("*") if p.is_file())}
        say(f"   killed at {killed_at or 0:.1%} after {first_s:.1f} s: {run['after_kill']}")
        second = child()
        start = time.perf_counter()
        out, _ = second.communicate(timeout=3600)
        run["second_s"] = time.perf_counter() - start
        lines = [json.loads(l) for l in out.splitlines() if l.strip()]
        final = lines[-1] if lines else {}
        if "report" not in final:
            self.fail(f"coordinator kill: the second run gave no report: {final}")
            return run
        run["report"] = final["report"]
        run["counts"] = final["report"]["counts"]
        self.check_same(run, reference, "coordinator kill")
        present = run["counts"].get("present", 0)
        if present < run["after_kill"]["complete"]:
            self.fail(f"coordinator kill: {present} present on the re-run, {run['after_kill']['complete']} "
                      f"were complete after the kill")
        say(f"   re-run {run['second_s']:.1f} s: {run['counts']}, identical: {run['identical']}")
        self.drop(folder)
        return run


def children_of(pid):
    """Every descendant pid of pid (from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                parents.setdefault(int(fields[1]), []).append(int(entry.name))
            except OSError:
                pass
    out, todo = [], [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


# ---------------------------------------------------------------------------------------- summary

def med(values):
    return statistics.median(values) if values else float("nan")


def summary(result):
    lines = ["# catalog add on a Dask cluster", ""]
    if result["args"].get("worker_tmpdir"):
        lines.append(f"workers' TMPDIR (staging folders): {result['args']['worker_tmpdir']}")
    lines.append(f"{result['machine']}; corpus {result['corpus_files']} files ({result['corpus_note']}); "
                 f"seed {result['seed']}")
    runs = result.get("throughput", [])
    if runs:
        lines += ["", "| run | round | wall s | assets/s | sum of per-file marking s | coordinator CPU s "
                  "| _catalog_record wall s / CPU s (calls) | workers CPU s | scheduler CPU s | other CPU s "
                  "| iowait s | identical |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in [result["reference"]] + runs:
            rec = r["steps"].get("_catalog_record", {})
            rec_text = f"{rec['wall_s']:.2f} / {rec['cpu_s']:.2f} ({rec['calls']})" if rec else "-"
            lines.append(f"| {r['label']} | {r.get('round', '-')} | {r['wall_s']:.2f} | {r['assets_per_s']:.1f} | "
                         f"{r['marking_s_sum']:.1f} | {r['coordinator_cpu_s']:.1f} | {rec_text} | "
                         f"{r.get('workers_cpu_s', 0):.1f} | {r.get('scheduler_cpu_s', 0):.1f} | "
                         f"{r['other_cpu_s']:.1f} | {r['machine_iowait_s']:.1f} | {r.get('identical', 'reference')} |")
        lines += ["", "| configuration | median assets/s |", "|---|---|"]
        for key, value in result["medians"].items():
            lines.append(f"| {key} | {value:.1f} |")
        lines += ["", f"ratio 2 workers / 1 worker (medians): **{result['ratio_workers']:.2f}**; "
                  f"local jobs=2 / jobs=1: {result['ratio_local']:.2f}"]
        lines += ["", "| round | 2 workers / 1 worker | local jobs=2 / jobs=1 | calibration: spin | calibration: "
                  "two local adds |", "|---|---|---|---|---|"]
        for c in result["calibration"]:
            r = c["round"]
            per = {(x["mode"], x["workers"] or x["jobs"]): x["assets_per_s"] for x in runs if x["round"] == r}
            lines.append(f"| {r} | {per[('cluster', 2)] / per[('cluster', 1)]:.2f} | "
                         f"{per[('local', 2)] / per[('local', 1)]:.2f} | {c['spin_ratio']:.2f} | {c['add_ratio']:.2f} |")
        lines.append("")
        c = result["calibration_medians"]
        lines.append(f"machine (no coordination, medians): 2 processes / 1 process: pure-Python spin "
                     f"{c['spin_ratio']:.2f}, two local adds of the corpus's halves at once "
                     f"{c['add_ratio']:.2f}")
        lines.append(f"coordinator per recorded asset (2-worker runs, median): "
                     f"{result['record_ms_per_asset']:.1f} ms in _catalog_record, "
                     f"{result['coordinator_cpu_ms_per_asset']:.1f} ms CPU of the whole coordinator process")
    for k in result.get("kills", []):
        if k["label"] == "kill-coordinator":
            lines.append(f"\n**coordinator kill**: killed at {k['killed_at'] or 0:.0%} of the files "
                         f"(after {k['first_s']:.1f} s; then {k['after_kill']}); re-run {k.get('second_s', 0):.1f} s, "
                         f"{k.get('counts')}; identical to the run without kill: {k.get('identical')}")
        else:
            lines.append(f"\n**{k['label']}** ({k['killed']} kill -9'ed after {k['kill_after_s']:.1f} s, at "
                         f"{k['kill_at_files'] or 'no'} files): {k['wall_s']:.1f} s (longest wait between two recorded files "
                         f"{k.get('longest_gap_s', 0):.1f} s, at {k.get('longest_gap_at_s', 0):.1f} s; CPU of other "
                         f"processes, the killed worker's included: {k['other_cpu_s']:.1f} s), {k['counts']}, "
                         f"catalogue lists "
                         f"{k.get('listed_assets')} assets; workers after: {k.get('workers_after')}; "
                         f"identical to the run without kill: {k.get('identical')}")
    if result.get("kill_reference"):
        r = result["kill_reference"]
        lines.append(f"\nrun without kill ({r['files']} files, 2 workers): {r['wall_s']:.1f} s, "
                     f"{r['assets_per_s']:.1f} assets/s, {r['counts']}; other processes' CPU {r['other_cpu_s']:.1f} s")
    lines.append("")
    lines.append("**ALL CHECKS HELD**" if not result["problems"] else
                 "**CHECKS FAILED**:\n" + "\n".join(f"- {p}" for p in result["problems"]))
    return "\n".join(lines)


def strip(run):
    return {k: v for k, v in run.items() if k not in ("report", "digest", "keys")}


# ---------------------------------------------------------------------------------------- main

def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work-dir", help="work folder (default: a new temporary one)")
    parser.add_argument("--assets", type=int, default=300, help="files of the throughput corpus")
    parser.add_argument("--kill-assets", type=int, default=1000, help="files of the kill corpus")
    parser.add_argument("--repeats", type=int, default=2, help="rounds of the throughput runs")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--keys", type=int, default=5, help="assets whose exported keys are compared")
    parser.add_argument("--min-vertices", type=int, default=500)
    parser.add_argument("--sh3f", default="/usr/share/sweethome3d/furniture")
    parser.add_argument("--cli", default=default_cli(), help="the meshmark program")
    parser.add_argument("--skip-throughput", action="store_true")
    parser.add_argument("--skip-kills", action="store_true")
    parser.add_argument("--keep", action="store_true", help="keep every run's catalogue and files")
    parser.add_argument("--worker-tmpdir", help="TMPDIR of the workers (their staging folders)")
    parser.add_argument("--json-file")
    args = parser.parse_args()
    if not args.cli or not Path(args.cli).exists():
        parser.error("the meshmark program was not found: give --cli")
    args.cli = str(Path(args.cli).resolve())
    work = Path(args.work_dir or tempfile.mkdtemp(prefix="meshmark-cluster-")).resolve()
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)

    def terminate(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    signal.signal(signal.SIGTERM, terminate)
    say(f"work folder {work}")
    sh3f_root = extract_sh3f(args.sh3f, work)
    qualifying, all_objs = qualifying_objs(sh3f_root, args.min_vertices)
    say(f"{all_objs} OBJs in the sh3f archives, {len(qualifying)} with >= {args.min_vertices} vertices")
    result = {"machine": f"{os.cpu_count()} cores, {os.uname().sysname} {os.uname().release}",
              "seed": args.seed, "args": vars(args), "problems": [], "kills": [],
              "sh3f_objs": all_objs, "qualifying_objs": len(qualifying)}
    chosen = evenly(qualifying, args.assets)
    result["corpus_files"] = make_corpus(work / "corpus", chosen, sh3f_root)
    result["corpus_note"] = f"{len(chosen)} of {len(qualifying)} sh3f OBJs with >= {args.min_vertices} vertices"
    if len(chosen) < args.assets:
        say(f"only {len(chosen)} OBJs qualify for --assets {args.assets}")
    bench = Bench(args, work, env)
    worker_env = dict(env, TMPDIR=args.worker_tmpdir) if args.worker_tmpdir else env
    bench.cluster = Cluster(work, env, worker_env)
    try:
        bench.cluster.start()
        say(f"scheduler {bench.cluster.address}")
        if not args.skip_throughput:
            reference, runs, calibrations = bench.throughput(work / "corpus")
            result["calibration"] = calibrations
            result["calibration_medians"] = {
                "spin_ratio": med([c["spin_ratio"] for c in calibrations]),
                "add_ratio": med([c["add_ratio"] for c in calibrations])}
            result["reference"] = strip(reference)
            result["throughput"] = [strip(r) for r in runs]
            groups = {"cluster, 1 worker": [r for r in runs if r["mode"] == "cluster" and r["workers"] == 1],
                      "cluster, 2 workers": [r for r in runs if r["mode"] == "cluster" and r["workers"] == 2],
                      "local, jobs=1": [r for r in runs if r["mode"] == "local" and r["jobs"] == 1],
                      "local, jobs=2": [r for r in runs if r["mode"] == "local" and r["jobs"] == 2]}
            result["medians"] = {k: med([r["assets_per_s"] for r in v]) for k, v in groups.items()}
            m = result["medians"]
            result["ratio_workers"] = m["cluster, 2 workers"] / m["cluster, 1 worker"]
            result["ratio_local"] = m["local, jobs=2"] / m["local, jobs=1"]
            two = groups["cluster, 2 workers"]
            result["record_ms_per_asset"] = med([1000 * r["steps"]["_catalog_record"]["wall_s"] /
                                                 r["steps"]["_catalog_record"]["calls"] for r in two])
            result["coordinator_cpu_ms_per_asset"] = med([1000 * r["coordinator_cpu_s"] / r["files"] for r in two])
        if not args.skip_kills:
            kill_corpus = work / "corpus-kill"
            if args.kill_assets <= len(qualifying):
                count = make_corpus(kill_corpus, evenly(qualifying, args.kill_assets), sh3f_root)
                note = f"{args.kill_assets} of {len(qualifying)} qualifying sh3f OBJs"
            else:
                # Fewer qualifying OBJs than asked: all of them, then again under again/ (other
                # asset ids, the same bytes) for the rest.
                count = make_corpus(kill_corpus, qualifying, sh3f_root)
                more = evenly(qualifying, args.kill_assets - count)
                for obj in more:
                    copy_asset(obj, sh3f_root, kill_corpus / "again")
                count += len(more)
                note = (f"only {len(qualifying)} sh3f OBJs have >= {args.min_vertices} vertices, fewer than "
                        f"--kill-assets {args.kill_assets}: all of them, and {len(more)} of them again under "
                        f"again/ (other assets, the same bytes)")
                say(note)
            result["kill_corpus_files"], result["kill_corpus_note"] = count, note
            say(f"-- kill corpus: {count} files; run without kill (2 workers)")
            bench.cluster.scale(2)
            kill_reference = bench.make_reference(bench.add("kill-reference", kill_corpus, "cluster", workers=2))
            result["kill_reference"] = strip(kill_reference)
            say(f"   {kill_reference['wall_s']:.1f} s, {kill_reference['counts']}")
            for mode in ("worker", "node"):
                result["kills"].append(strip(bench.worker_kill(kill_corpus, kill_reference, mode)))
            result["kills"].append(strip(bench.coordinator_kill(kill_corpus, kill_reference)))
    except KeyboardInterrupt:
        say("interrupted: stopping the cluster")
        bench.problems.append("interrupted")
        raise
    finally:
        bench.cluster.close()
        bench.timer.restore()
    result["problems"] = bench.problems
    text = summary(result)
    print(text)
    if args.json_file:
        Path(args.json_file).write_text(json.dumps(result, indent=1, default=str) + "\n")
    return 0 if not bench.problems else 1


if __name__ == "__main__":
    sys.exit(main())
