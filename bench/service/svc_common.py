"""Helpers shared by load.py and crash.py: start/stop `meshmark serve`, ask it for copies, read the
catalogue, detect copies. Standard library only (run with /usr/bin/python3 or any Python >= 3.8)."""
import http.client
import json
import os
import re
import signal
import subprocess
import time
import urllib.parse

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MESHMARK = os.path.normpath(os.path.join(HERE, "..", "..", "build", "bin", "meshmark"))
PORT_RE = re.compile(r"serving .* on http://[^:/\s]+:(\d+)")


def parse_size(text):
    """'2G', '512M', '300MiB', '1024' (bytes) -> bytes (binary units, as meshmark reads them)."""
    m = re.fullmatch(r"\s*([0-9.]+)\s*([KMGT]?)(I?B)?\s*", text.upper())
    if not m:
        raise ValueError("bad size %r" % text)
    return int(float(m.group(1)) * 1024 ** " KMGT".index(m.group(2) or " "))


class Service:
    """One `meshmark serve` process; its stderr (JSON lines) goes to log_path (appended)."""

    def __init__(self, meshmark, catalog, log_path, token_file=None, extra=(), quiet=False):
        self.log_path = log_path
        cmd = [meshmark, "serve", "--catalog", catalog, "--listen", "127.0.0.1:0"]
        if token_file:
            cmd += ["--token-file", token_file]
        if quiet:
            cmd.append("-q")
        cmd += list(extra)
        self.cmd = cmd
        self.log = open(log_path, "ab")
        self.start_offset = self.log.tell()
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self.log, stderr=self.log)
        self.pid = self.proc.pid
        self.port = None
        self.token_file = token_file or catalog + ".token"

    def wait_ready(self, timeout=60.0):
        """Waits for the 'serving ... on http://HOST:PORT' notice; returns the port."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.log_lines():
                m = PORT_RE.search(line)
                if m:
                    self.port = int(m.group(1))
                    return self.port
            if self.proc.poll() is not None:
                raise RuntimeError("meshmark serve exited with %s before serving; log %s"
                                   % (self.proc.returncode, self.log_path))
            time.sleep(0.05)
        raise RuntimeError("meshmark serve printed no 'serving' notice in %.0f s; log %s" % (timeout, self.log_path))

    def log_lines(self):
        """This process's lines of the log."""
        with open(self.log_path, "rb") as f:
            f.seek(self.start_offset)
            return f.read().decode("utf-8", "replace").splitlines()

    def log_records(self):
        out = []
        for line in self.log_lines():
            try:
                out.append(json.loads(line))
            except ValueError:
                out.append({"unparsed": line})
        return out

    def token(self):
        with open(self.token_file) as f:
            return f.readline().strip()

    def proc_status(self, field):
        """VmRSS / VmHWM of the process in bytes, or None once it is gone."""
        try:
            with open("/proc/%d/status" % self.pid) as f:
                for line in f:
                    if line.startswith(field + ":"):
                        return int(line.split()[1]) * 1024
        except OSError:
            return None
        return None

    def stop(self, timeout=30.0):
        """SIGTERM and wait; returns the exit code (None if it had to be killed)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                self.log.close()
                return None
        self.log.close()
        return self.proc.returncode

    def kill(self):
        """SIGKILL and reap."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self.log.close()
        return self.proc.returncode


def copies_path(asset):
    return "/v1/assets/%s/copies" % urllib.parse.quote(asset, safe="")


def request_copy(conn, token, asset, recipient, fmt=None):
    """POSTs a copy request on conn; returns (status, headers dict (lower-case keys), body bytes).
    Raises http.client / OS errors (connection refused, reset, incomplete read)."""
    req = {"recipient": recipient}
    if fmt:
        req["format"] = fmt
    body = json.dumps(req).encode()
    conn.request("POST", copies_path(asset), body=body,
                 headers={"Authorization": "Bearer " + token, "Content-Type": "application/json"})
    resp = conn.getresponse()
    data = resp.read()  # raises IncompleteRead when the body is cut short
    headers = {k.lower(): v for k, v in resp.getheaders()}
    return resp.status, headers, data


def filename_of(headers, fallback):
    m = re.search(r'filename="?([^";]+)"?', headers.get("content-disposition", ""))
    name = os.path.basename(m.group(1)) if m else fallback
    return name or fallback


def catalog_list(meshmark, catalog):
    r = subprocess.run([meshmark, "catalog", "list", catalog, "--json", "-q"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if r.returncode != 0:
        raise RuntimeError("catalog list --json exited %d: %s" % (r.returncode, r.stderr.decode(errors="replace")))
    return json.loads(r.stdout)


def asset_entry(listing, asset):
    for a in listing.get("assets", []):
        if a.get("asset") == asset:
            return a
    raise RuntimeError("asset %r is not in the catalogue" % asset)


def export_key(meshmark, catalog, asset, key_path):
    r = subprocess.run([meshmark, "catalog", "export", catalog, asset, "--key", key_path, "--force", "-q"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if r.returncode != 0:
        raise RuntimeError("catalog export exited %d: %s" % (r.returncode, r.stderr.decode(errors="replace")))


def detect(meshmark, suspect, original, key):
    """Runs detect --json; returns (exit code, report dict or None, stderr text)."""
    r = subprocess.run([meshmark, "detect", suspect, "--original", original, "--key", key, "--json",
                        "--threads", "1", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        rep = json.loads(r.stdout)
    except ValueError:
        rep = None
    return r.returncode, rep, r.stderr.decode(errors="replace").strip()


def check_trace(meshmark, name, path, original, key):
    """Detects one copy; returns (ok, accused names, problem or None)."""
    rc, rep, err = detect(meshmark, path, original, key)
    if rep is None:
        return False, [], "detect %s exited %d without JSON: %s" % (path, rc, err[-300:])
    accused = [r.get("name") for r in rep.get("recipients", [])]
    if not rep.get("detected"):
        return False, accused, "%s (%s): not detected (exit %d)" % (name, path, rc)
    if accused != [name]:
        return False, accused, "%s (%s): accused %s, expected exactly [%r]" % (name, path, accused, name)
    return True, accused, None


KNOWN_NOTICES = ("serving ", "stopped", "created the token file")


def log_problems(records):
    """The log lines that say something went wrong: a status >= 500, a notice other than the
    usual start/stop ones (e.g. 'request failed inside the service'), a line that is not JSON."""
    out = []
    for rec in records:
        if "unparsed" in rec:
            out.append(rec["unparsed"][:300])
        elif rec.get("status", 0) >= 500:
            out.append(json.dumps(rec)[:300])
        elif "notice" in rec and not rec["notice"].startswith(KNOWN_NOTICES):
            out.append(json.dumps(rec)[:300])
    return out


def capped(errors, limit=50):
    """The first `limit` errors, and a line counting the rest."""
    return errors if len(errors) <= limit else errors[:limit] + ["... and %d more" % (len(errors) - limit)]


def keep_copy(name, status, headers, body, outdir):
    """A copy answer checked and saved: (path, None) for a whole 200 (saved as
    OUTDIR/NAME.EXT, EXT from its Content-Disposition), else (None, the problem)."""
    if status != 200:
        return None, "HTTP %d %s" % (status, body[:300].decode(errors="replace"))
    clen = headers.get("content-length")
    if clen is None or int(clen) != len(body):
        return None, "HTTP 200 with Content-Length %s but %d bytes" % (clen, len(body))
    ext = os.path.splitext(filename_of(headers, ".bin"))[1] or ".bin"
    path = os.path.join(outdir, name + ext)
    with open(path, "wb") as f:
        f.write(body)
    return path, None

