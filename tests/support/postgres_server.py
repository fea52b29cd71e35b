#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A throwaway PostgreSQL server on loopback for the `postgres` tests (docs/catalog.md, "On
PostgreSQL"), started the way a user would: initdb in a private folder under /tmp, pg_ctl start
listening on 127.0.0.1 on a free port (its socket in that folder, trust authentication for the
local test connections), and at the end, also when the test fails or is interrupted, pg_ctl stop
-m fast and the folder removed. As root, the server runs as the `postgres` user (initdb refuses
root).

    postgres_server.py COMMAND [ARG...]

runs COMMAND once with MESHMARK_TEST_POSTGRES=postgresql://postgres@127.0.0.1:PORT (a server
URL without a database: a test creates its own, e.g. with PostgresServer.create_database, and
appends /NAME; the database `postgres` exists) and exits with its status. Exits 77 (CTest's
SKIP_RETURN_CODE) when there is no server to start: no PostgreSQL binaries (MESHMARK_PG_BINDIR,
/usr/lib/postgresql/*/bin or PATH), or root without a `postgres` user. From Python:

    with PostgresServer() as pg:
        url = pg.create_database("mine")
"""
import glob
import os
import pwd
import shutil
import signal
import socket
import subprocess
import sys
import tempfile

SKIP = 77


class Unavailable(Exception):
    """No PostgreSQL server can be started here (the test is skipped)."""


def _bindir():
    if os.environ.get("MESHMARK_PG_BINDIR"):
        return os.environ["MESHMARK_PG_BINDIR"]
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"),
                   key=lambda p: int(p.split("/")[-3]) if p.split("/")[-3].isdigit() else 0)
    if found:
        return os.path.dirname(found[-1])
    initdb = shutil.which("initdb")
    if initdb:
        return os.path.dirname(initdb)
    raise Unavailable("no PostgreSQL server binaries (initdb, pg_ctl): apt-get install postgresql")


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class PostgresServer:
    def __init__(self):
        self.bindir = _bindir()
        self.as_user = []
        self.owner = None
        if os.geteuid() == 0:
            try:
                self.owner = pwd.getpwnam("postgres")
            except KeyError:
                raise Unavailable("running as root, and no `postgres` user to run the server as")
            self.as_user = ["runuser", "-u", "postgres", "--"]
        self.folder = None
        self.started = False
        self.port = None

    def _run(self, *command, check=True):
        return subprocess.run(self.as_user + [os.path.join(self.bindir, command[0]), *command[1:]],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              check=check, cwd=self.folder)

    def __enter__(self):
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()

    @property
    def data(self):
        return os.path.join(self.folder, "data")

    @property
    def url(self):
        return f"postgresql://postgres@127.0.0.1:{self.port}"

    def start(self):
        self.folder = tempfile.mkdtemp(prefix="meshmark-pg-", dir="/tmp")
        if self.owner:
            os.chown(self.folder, self.owner.pw_uid, self.owner.pw_gid)
        self._run("initdb", "-D", self.data, "-U", "postgres", "--auth=trust", "-E", "UTF8",
                  "--no-sync", "--no-instructions")
        for attempt in range(3):  # a free port can be taken before the server binds it
            self.port = _free_port()
            # fsync=off: a throwaway server (its stop would otherwise flush every database the
            # tests made, ~10 s on a busy disk); commits, locks and constraints are unchanged.
            options = (f"-c listen_addresses=127.0.0.1 -p {self.port} "
                       f"-c unix_socket_directories={self.folder} -c max_connections=64 "
                       "-c fsync=off")
            started = self._run("pg_ctl", "start", "-D", self.data, "-w", "-t", "60",
                                "-l", os.path.join(self.folder, "server.log"), "-o", options,
                                check=False)
            if started.returncode == 0:
                self.started = True
                return
        raise RuntimeError("pg_ctl start failed:\n" + started.stdout + self.log())

    def restart(self):
        """pg_ctl restart -m fast: every connection dropped, the server back on the same port."""
        self._run("pg_ctl", "restart", "-D", self.data, "-m", "fast", "-w", "-t", "60",
                  "-l", os.path.join(self.folder, "server.log"))

    def log(self):
        try:
            with open(os.path.join(self.folder, "server.log")) as f:
                return f.read()
        except OSError:
            return ""

    def stop(self):
        if self.started:
            self._run("pg_ctl", "stop", "-D", self.data, "-m", "fast", "-w", check=False)
            self.started = False
        if self.folder:
            shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None

    def create_database(self, name):
        """A new database `name` (letters, digits, _): its URL."""
        subprocess.run([os.path.join(self.bindir, "createdb"), "-h", "127.0.0.1", "-p",
                        str(self.port), "-U", "postgres", name], check=True)
        return f"{self.url}/{name}"


def _raise_on_signal(signum, _frame):
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv):
    if not argv:
        sys.exit(__doc__)
    for s in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        signal.signal(s, _raise_on_signal)  # so that the server is stopped and its folder removed
    try:
        server = PostgresServer()
    except Unavailable as e:
        print(f"postgres_server.py: skipped: {e}", file=sys.stderr)
        return SKIP
    with server:
        env = dict(os.environ, MESHMARK_TEST_POSTGRES=server.url)
        # Below CTest's own timeout, so that a hung test still has its server stopped.
        timeout = float(os.environ.get("MESHMARK_PG_TIMEOUT", "500"))
        child = subprocess.Popen(argv, env=env)
        try:
            status = child.wait(timeout=timeout)
        except BaseException:
            child.kill()
            child.wait()
            raise
        if status != 0 and status != SKIP:
            sys.stderr.write("--- PostgreSQL server log ---\n" + server.log()[-4000:])
        return status


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except KeyboardInterrupt as e:  # the server is stopped and its folder removed by now
        print(f"postgres_server.py: interrupted ({e})", file=sys.stderr)
        sys.exit(130)
