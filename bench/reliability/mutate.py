#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Mutated-copies reliability study (issue 6): meshmark must never crash, hang or leave output.

From small shared meshes (plus small PLY/STL/glTF/GLB/3MF copies made with `meshmark attack
... similarity:scale=1`), make mutated copies (byte flips, truncations, header-field and
number edits, duplicated/deleted/swapped lines, deleted/duplicated byte ranges, and for 3MF
edits of the model XML inside the zip), then per copy run

    meshmark embed MUTANT -o out/marked.EXT --key out/key.json --seed 1 --threads 1
    meshmark detect MUTANT --original BASE --key BASE_KEY --threads 1

and check the contract: exit 0, 1 or >= 2 (never a signal, never >= 128), an error carries a
message on stderr, no run exceeds --timeout, and a failed run leaves no file behind (embed:
no marked copy, no key, no staging file; detect never writes). Every violation is a finding:
the mutant is copied to --findings with the command and its stderr. Python stdlib only.

Usage: bench/reliability/mutate.py --meshmark build/bin/meshmark [--count 2000] [--jobs 2]
       [--seed 1] [--timeout 60] [--mesh-dir DIR] [--findings DIR] [--json FILE]
       [--from-marked] [--shared MESH ...] [--no-generated]
"""
import argparse
import collections
import concurrent.futures
import io
import json
import os
import random
import re
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zipfile

SHARED = ["beetle.obj", "teapot.obj", "bunny.off", "fertility.off", "dragon_vrip_res4.ply"]
# Generated copies: (source in the shared folder, file name of the copy).
GENERATED = [("beetle.obj", "beetle_bin.ply"), ("beetle.obj", "beetle.stl"),
             ("beetle.obj", "beetle.gltf"), ("beetle.obj", "beetle.glb"),
             ("beetle.obj", "beetle.3mf"), ("bunny.off", "bunny_small.glb"),
             ("teapot.obj", "teapot.3mf"), ("teapot.obj", "teapot.off")]
EXTREMES = [b"0", b"-1", b"1", b"2", b"3", b"255", b"256", b"65535", b"2147483647",
            b"2147483648", b"4294967295", b"4294967296", b"18446744073709551615",
            b"99999999999999999999999", b"-2147483648", b"1e308", b"1e309", b"-1e309",
            b"nan", b"inf", b"-0", b"0x10", b"1.5", b"", b"1e-320", b"5126", b"5123", b"34963"]
NUMBER = re.compile(rb"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")
TEXT_EXT = {".obj", ".off", ".gltf"}


def is_text(ext, data):
    if ext in TEXT_EXT:
        return True
    if ext == ".ply":
        return b"format ascii" in data[:200]
    if ext == ".stl":
        return data[:5] == b"solid" and b"facet" in data[:400]
    return False


def header_end(ext, data):
    """Bytes that hold counts, sizes and offsets: where header-field edits aim."""
    if ext == ".ply":
        end = data.find(b"end_header")
        return end + 10 if end > 0 else min(len(data), 300)
    if ext == ".off":
        return min(len(data), 80)
    if ext == ".stl":
        return 84
    if ext == ".glb":
        json_len = struct.unpack_from("<I", data, 12)[0] if len(data) >= 20 else 0
        return min(len(data), 20 + json_len)
    if ext == ".gltf":
        return len(data)
    return min(len(data), 200)


def edit_number(rng, data, lo, hi):
    spans = [m.span() for m in NUMBER.finditer(data, lo, hi)]
    if not spans:
        return None
    a, b = rng.choice(spans)
    return data[:a] + rng.choice(EXTREMES) + data[b:]


def mutate_bytes(rng, ext, data):
    """One or a few mutations of one kind; returns (kind, bytes)."""
    n = len(data)
    kinds = ["flip", "truncate", "header", "number", "range"]
    if is_text(ext, data):
        kinds += ["lines", "lines"]
    if ext == ".glb" or (ext == ".stl" and not is_text(ext, data)) or ext == ".ply":
        kinds += ["field"]
    kind = rng.choice(kinds)
    buf = bytearray(data)
    if kind == "flip":
        for _ in range(rng.choice([1, 1, 2, 4, 16])):
            i = rng.randrange(n)
            buf[i] = rng.randrange(256) if rng.random() < 0.5 else buf[i] ^ (1 << rng.randrange(8))
        return kind, bytes(buf)
    if kind == "truncate":
        cut = rng.randrange(n) if rng.random() < 0.7 else rng.randrange(min(n, header_end(ext, data) + 64))
        return kind, data[:cut]
    if kind == "header":
        end = max(1, header_end(ext, data))
        out = edit_number(rng, data, 0, end)
        if out is None:  # binary header: flip a byte in it
            i = rng.randrange(end)
            buf[i] = rng.randrange(256)
            out = bytes(buf)
        return kind, out
    if kind == "number":
        out = edit_number(rng, data, 0, n)
        return kind, out if out is not None else data[: n // 2]
    if kind == "range":
        a = rng.randrange(n)
        b = min(n, a + rng.choice([1, 4, 12, 50, 400, 5000]))
        if rng.random() < 0.5:
            return kind, data[:a] + data[b:]
        return kind, data[:b] + data[a:b] + data[b:]
    if kind == "lines":
        lines = data.split(b"\n")
        for _ in range(rng.choice([1, 1, 3])):
            i = rng.randrange(len(lines))
            op = rng.randrange(3)
            if op == 0:
                lines.insert(i, lines[i])
            elif op == 1 and len(lines) > 1:
                del lines[i]
            else:
                j = rng.randrange(len(lines))
                lines[i], lines[j] = lines[j], lines[i]
        return kind, b"\n".join(lines)
    # "field": overwrite a binary count/length field with an extreme 32-bit value.
    values = [0, 1, 2, 3, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0x10000, n, n + 1, n - 1, 12]
    if ext == ".stl":
        offsets = [80]
    elif ext == ".glb":
        json_len = struct.unpack_from("<I", data, 12)[0]
        offsets = [0, 4, 8, 12, 16, 20 + json_len, 24 + json_len]
    else:  # binary PLY body: overwrite a face list length byte or a vertex index
        body = header_end(ext, data)
        off = rng.randrange(body, n) if n > body else 0
        buf[off] = rng.choice([0, 1, 2, 3, 4, 255, 128])
        return kind, bytes(buf)
    off = rng.choice([o for o in offsets if o + 4 <= n] or [0])
    buf[off : off + 4] = struct.pack("<I", rng.choice(values) & 0xFFFFFFFF)[: len(buf[off : off + 4])]
    return kind, bytes(buf)


def mutate_3mf(rng, data):
    """Half the time edit the XML model inside the package (the zip stays valid)."""
    if rng.random() < 0.5:
        return mutate_bytes(rng, ".3mf", data)
    src = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            content = src.read(info.filename)
            if info.filename.endswith(".model"):
                kind, content = mutate_bytes(rng, ".xml", content)
                if rng.random() < 0.3:  # count-like attributes: v1/v2/v3 indices, coordinates
                    content = re.sub(rb'v1="\d+"', b'v1="' + rng.choice(EXTREMES) + b'"', content, count=1)
            dst.writestr(info, content)
    return "xml-" + kind, out.getvalue()


def listing(path):
    return sorted(os.path.relpath(os.path.join(r, f), path) for r, _, fs in os.walk(path) for f in fs)


def run(cmd, timeout, cwd):
    """Run with a timeout and a 4 GiB address-space cap; returns (rc or None on hang, stderr, secs)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
    with tempfile.TemporaryFile() as err:
        start = time.monotonic()
        proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=err, preexec_fn=limit)
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            rc = None
        secs = time.monotonic() - start
        err.seek(0)
        return rc, err.read().decode("utf-8", "replace"), secs


def classify(rc):
    if rc is None:
        return "HANG"
    if rc < 0 or rc >= 128:
        return "SIGNAL"
    if rc in (0, 1):
        return str(rc)
    return "err%d" % rc


def check_case(args, case_id, base, ext, kind, blob, base_key):
    findings = []
    outcomes = {}
    case = tempfile.mkdtemp(prefix="case%05d_" % case_id, dir=args.work)
    try:
        mutant = os.path.join(case, "in" + ext)
        with open(mutant, "wb") as f:
            f.write(blob)
        os.mkdir(os.path.join(case, "out"))
        commands = {
            "embed": [args.meshmark, "embed", mutant, "-o", os.path.join(case, "out", "marked" + ext),
                      "--key", os.path.join(case, "out", "key.json"), "--seed", "1", "--threads", "1"],
            "detect": [args.meshmark, "detect", mutant, "--original", base, "--key", base_key,
                       "--threads", "1"],
        }
        for name, cmd in commands.items():
            before = listing(case)
            rc, err, secs = run(cmd, args.timeout, case)
            outcome = classify(rc)
            outcomes[name] = outcome
            after = listing(case)
            lines = [l for l in err.splitlines() if l.strip()]
            problems = []
            if outcome in ("HANG", "SIGNAL"):
                problems.append("%s (rc %s) after %.1f s" % (outcome, rc, secs))
            # Exit 1 is detect's "not found" verdict (on stdout); errors are exits >= 2.
            if rc is not None and 2 <= rc < 128 and not lines:
                problems.append("exit %d with no message on stderr" % rc)
            if rc is not None and 2 <= rc < 128 and len(lines) > 1:
                problems.append("exit %d with a %d-line message" % (rc, len(lines)))
            if name == "embed" and rc == 0:
                if not {"out/marked" + ext, "out/key.json"} <= set(after):
                    problems.append("exit 0 but the marked copy or key is missing")
            elif after != before:
                problems.append("left files: %s" % sorted(set(after) - set(before)))
            if problems:
                findings.append({"case": case_id, "base": os.path.basename(base), "mutation": kind,
                                 "command": name, "rc": rc, "problems": problems,
                                 "stderr": err[-2000:], "seconds": round(secs, 2)})
        if findings:
            os.makedirs(args.findings, exist_ok=True)
            keep = os.path.join(args.findings, "case%05d_%s%s" % (case_id, os.path.basename(base), ext))
            shutil.copyfile(mutant, keep)
            for f in findings:
                f["file"] = keep
    finally:
        shutil.rmtree(case, ignore_errors=True)
    return outcomes, findings


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--meshmark", required=True)
    ap.add_argument("--mesh-dir", default=os.environ.get("MESHMARK_MESH_DIR", "../shared/data/meshes"))
    ap.add_argument("--count", type=int, default=2000, help="mutants in total (spread over the bases)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds before a run counts as a hang")
    ap.add_argument("--findings", default="mutate-findings")
    ap.add_argument("--json", help="write counts and findings here")
    ap.add_argument("--from-marked", action="store_true",
                    help="mutate each base's marked copy instead (detect then also reaches 'found')")
    ap.add_argument("--shared", nargs="*", default=SHARED,
                    help="shared meshes to use (default: the small ones)")
    ap.add_argument("--no-generated", action="store_true", help="skip the generated copies")
    args = ap.parse_args()
    args.meshmark = os.path.abspath(args.meshmark)
    args.findings = os.path.abspath(args.findings)
    args.work = tempfile.mkdtemp(prefix="meshmark_mutate_")
    try:
        bases = prepare_bases(args)
        rng = random.Random(args.seed)
        jobs = []
        for i in range(args.count):
            base, key, marked = bases[i % len(bases)]
            ext = os.path.splitext(base)[1]
            data = open(marked if args.from_marked else base, "rb").read()
            kind, blob = mutate_3mf(rng, data) if ext == ".3mf" else mutate_bytes(rng, ext, data)
            jobs.append((i, base, ext, kind, blob, key))
        counts = collections.defaultdict(collections.Counter)
        findings = []
        start = time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            futures = {pool.submit(check_case, args, *job): job for job in jobs}
            for done, fut in enumerate(concurrent.futures.as_completed(futures), 1):
                _, base, _, kind, _, _ = futures[fut]
                outcomes, found = fut.result()
                label = os.path.basename(base)
                counts[label]["mutants"] += 1
                for cmd, outcome in outcomes.items():
                    counts[label]["%s %s" % (cmd, outcome)] += 1
                findings += found
                for f in found:
                    print("FINDING", json.dumps(f), flush=True)
                if done % 200 == 0:
                    print("%d/%d mutants, %d findings, %.0f s" % (done, len(jobs), len(findings),
                          time.monotonic() - start), flush=True)
        report(args, bases, counts, findings, time.monotonic() - start)
    finally:
        shutil.rmtree(args.work, ignore_errors=True)
    return 1 if findings else 0


def prepare_bases(args):
    """The shared small meshes and generated copies, each with a valid key from a clean embed."""
    gen = os.path.join(args.work, "bases")
    os.makedirs(gen)
    paths = [os.path.join(args.mesh_dir, m) for m in args.shared]
    for src, name in [] if args.no_generated else GENERATED:
        out = os.path.join(gen, name)
        subprocess.run([args.meshmark, "attack", os.path.join(args.mesh_dir, src), "-o", out,
                        "-q", "similarity:scale=1"], check=True)
        paths.append(out)
    bases = []
    for path in paths:
        key = os.path.join(gen, os.path.basename(path) + ".key.json")
        marked = os.path.join(gen, "marked_" + os.path.basename(path))
        subprocess.run([args.meshmark, "embed", path, "-o", marked, "--key", key, "--seed", "1",
                        "-q"], check=True)
        bases.append((path, key, marked))
    return bases


def report(args, bases, counts, findings, seconds):
    cols = sorted({c for v in counts.values() for c in v if c != "mutants"})
    print("\n%d mutants in %.0f s, %d findings\n" % (sum(v["mutants"] for v in counts.values()),
                                                       seconds, len(findings)))
    print("| base | mutants | " + " | ".join(cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    total = collections.Counter()
    for label in sorted(counts):
        total.update(counts[label])
        print("| %s | %d | " % (label, counts[label]["mutants"]) +
              " | ".join(str(counts[label][c]) for c in cols) + " |")
    print("| **all** | %d | " % total["mutants"] + " | ".join(str(total[c]) for c in cols) + " |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"counts": counts, "findings": findings, "seconds": seconds}, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
