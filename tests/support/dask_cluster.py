#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A throwaway Dask cluster on loopback for the `cluster` tests and benches (docs/cluster.md),
started the way a user would: `dask-scheduler` on 127.0.0.1 on a free port and N `dask-worker`
processes (one thread each) connected to it, each with its own folder under a private temporary
folder; stopped at the end (SIGTERM, then SIGKILL to their process groups), also when the test
fails or is interrupted, and the folder removed.

    with DaskCluster(workers=2, pythonpath="build/python") as cluster:
        cluster.address            # tcp://127.0.0.1:PORT
        cluster.kill_worker(0)     # kill -9 one worker process

Raises Unavailable (a test then exits 77, CTest's SKIP_RETURN_CODE) when dask-scheduler or
dask-worker is missing (apt-get install python3-distributed).
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

SKIP = 77


class Unavailable(Exception):
    """No Dask cluster can be started here (the test is skipped)."""


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DaskCluster:
    def __init__(self, workers=2, pythonpath=None, nthreads=1, python=None):
        self.scheduler_program = shutil.which("dask-scheduler")
        self.worker_program = shutil.which("dask-worker")
        if not self.scheduler_program or not self.worker_program:
            raise Unavailable("no dask-scheduler or dask-worker: apt-get install python3-distributed")
        self.count = workers
        self.nthreads = nthreads
        self.python = python or sys.executable
        self.env = dict(os.environ)
        if pythonpath:
            rest = self.env.get("PYTHONPATH", "")
            self.env["PYTHONPATH"] = str(pythonpath) + (":" + rest if rest else "")
        self.env.setdefault("OMP_NUM_THREADS", "1")
        self.folder = None
        self.scheduler = None
        self.workers = []
        self.address = None

    def _start(self, command, log):
        with open(os.path.join(self.folder, log), "wb") as out:
            return subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=self.env,
                                    cwd=self.folder, start_new_session=True)

    def start_worker(self):
        n = len(self.workers)
        worker = self._start([self.worker_program, self.address, "--nthreads", str(self.nthreads),
                              "--no-dashboard", "--host", "127.0.0.1", "--local-directory",
                              os.path.join(self.folder, f"worker-{n}"), "--name", f"w{n}"],
                             f"worker-{n}.log")
        self.workers.append(worker)
        return worker

    def __enter__(self):
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()
        return False

    def start(self):
        self.folder = tempfile.mkdtemp(prefix="meshmark-dask-")
        port = _free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        self.scheduler = self._start([self.scheduler_program, "--host", "127.0.0.1", "--port",
                                      str(port), "--no-dashboard"], "scheduler.log")
        for _ in range(self.count):
            self.start_worker()
        self.wait_for_workers(self.count)

    def connected_workers(self):
        """Workers the scheduler knows, asked through a client (this interpreter's)."""
        code = ("import sys\nfrom dask.distributed import Client\n"
                f"c = Client({self.address!r}, timeout=20)\nprint(len(c.nthreads()))\nc.close()\n")
        done = subprocess.run([self.python, "-c", code], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True, env=self.env, timeout=60)
        return int(done.stdout.strip() or 0) if done.returncode == 0 else 0

    def wait_for_workers(self, count, timeout=60):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.scheduler.poll() is not None:
                raise RuntimeError("dask-scheduler exited: " + self.log("scheduler.log"))
            if self.connected_workers() >= count:
                return
            time.sleep(0.5)
        raise RuntimeError(f"{count} Dask workers did not connect in {timeout} s: "
                           + self.log("worker-0.log"))

    def kill_worker(self, n):
        """kill -9 worker n's process group (the worker and its nanny's child)."""
        os.killpg(self.workers[n].pid, signal.SIGKILL)
        self.workers[n].wait()

    def log(self, name):
        try:
            with open(os.path.join(self.folder, name), encoding="utf-8", errors="replace") as f:
                return f.read()[-2000:]
        except OSError:
            return ""

    def stop(self):
        processes = [p for p in self.workers + [self.scheduler] if p is not None]
        for p in processes:
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + 10
        for p in processes:
            try:
                p.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                p.wait()
        self.workers = []
        self.scheduler = None
        if self.folder:
            shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None


if __name__ == "__main__":
    # Start a cluster, print its address, wait for Ctrl-C (a manual check).
    with DaskCluster(workers=int(sys.argv[1]) if len(sys.argv) > 1 else 2) as c:
        print(c.address, flush=True)
        try:
            signal.pause()
        except KeyboardInterrupt:
            pass
