#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Add recipients to a family key without issuing their copies, to time tracing at scale.

    grow_key.py FAMILY.json OUT.json --total N [--prefix r]

OUT.json is FAMILY.json with recipients added (names PREFIX00000.., the next free indices)
until it lists N, and its checksum recomputed as meshmark computes it (SplitMix64 over the
compact, key-sorted JSON without it: checksum_of in src/watermark/key.cpp). `meshmark detect` then traces all N: the
copies of the added recipients were never issued, so they are innocents of every suspect.
A bench tool: issuing 10,000 copies of a 437K-vertex mesh would take 150 GB of disk.
"""
import argparse
import json
import os
import struct
import sys

MASK = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15


def splitmix64(x):
    x = (x + GOLDEN) & MASK
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & MASK
    return x ^ (x >> 31)


def hash_bytes(data, seed):
    """meshmark's hash_bytes (include/meshmark/core/hash.h)."""
    h = splitmix64(seed ^ ((len(data) * GOLDEN) & MASK))
    padded = data + b"\0" * (-len(data) % 8)
    for (word,) in struct.iter_unpack("<Q", padded):
        h = splitmix64(h ^ word)
    return h


def checksum(content):
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode()
    return "%016x" % hash_bytes(text, 0x6B6579)


def grow(family, output, total, prefix="r"):
    """Write OUT = FAMILY with never-issued recipients added up to TOTAL; returns the count."""
    with open(family) as f:
        key = json.load(f)
    stated = key.pop("checksum", None)
    if stated != checksum(key):
        sys.exit("grow_key.py: %s: the checksum does not match its content (or this script no longer "
                 "computes it as meshmark does)" % family)
    issued = key.get("recipients", {}).get("issued")
    if issued is None:
        sys.exit("grow_key.py: %s is not a family key" % family)
    names = {r["name"] for r in issued}
    index = max((r["index"] for r in issued), default=-1) + 1
    while len(issued) < total:
        name = "%s%05d" % (prefix, index)
        if name not in names:
            issued.append({"index": index, "name": name})
            names.add(name)
        index += 1
    key["checksum"] = checksum(key)
    temporary = output + ".tmp"
    with open(temporary, "w") as f:
        json.dump(key, f, indent=2)
        f.write("\n")
    os.replace(temporary, output)
    return len(issued)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("family")
    parser.add_argument("output")
    parser.add_argument("--total", type=int, required=True)
    parser.add_argument("--prefix", default="r")
    args = parser.parse_args()
    print("%s: %d recipients" % (args.output, grow(args.family, args.output, args.total, args.prefix)))

if __name__ == "__main__":
    main()
