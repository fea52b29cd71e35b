#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The reading's error per mode of the mark
(bench/results/2026-11-28-five-readings-of-a-5pct-decimation.md).

    meshmark detect MARKED --original ORIGINAL --key KEY --json --verbose > intact.json
    meshmark detect COPY --original ORIGINAL --key KEY --json --verbose > copy.json
    python3 bench/robustness/mode_error.py intact.json copy.json [reference.json]

`normalized_change` of `--verbose` is each modulated coefficient's least-squares reading over its
modulation: the embedded sign where the mark is intact. The intact file's reading gives the signs;
the copy's minus them is the error, printed as its RMS per group of five modes (coefficient c is
mode first_mode + c / 3, axis c % 3) with the mean of sign x reading there (1 where the mark is
read whole). With a third reading (the same attack on the unmarked original, read with the same
key), also the correlation of the copy's error with that reading and the error left after
subtracting it: how much of the attack's error an unmarked copy made the same way would cancel.
Needs nothing but Python's standard library.
"""
import json
import math
import sys

GROUP = 5  # modes per printed row


def reading(path):
    with open(path, encoding="utf-8") as file:
        report = json.load(file)
    if "normalized_change" not in report:
        sys.exit(f"{path}: no normalized_change (run meshmark detect with --json --verbose)")
    return report["normalized_change"], report.get("score")


def rms(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else 0.0


def correlation(a, b):
    ma, mb = sum(a) / len(a), sum(b) / len(b)
    cov = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    va = sum((x - ma) ** 2 for x in a)
    vb = sum((y - mb) ** 2 for y in b)
    return cov / math.sqrt(va * vb) if va > 0 and vb > 0 else 0.0


def uniform_score(signs, values):
    norm = math.sqrt(sum(v * v for v in values))
    return sum(s * v for s, v in zip(signs, values)) / norm if norm > 0 else 0.0


def main(intact_path, copy_path, reference_path=None):
    intact, _ = reading(intact_path)
    copy, score = reading(copy_path)
    if len(intact) != len(copy):
        sys.exit(f"{copy_path}: {len(copy)} coefficients, {intact_path} has {len(intact)}: not the same key")
    signs = [1.0 if v >= 0 else -1.0 for v in intact]
    error = [c - s for c, s in zip(copy, signs)]
    print(f"{copy_path}: score {score}, error RMS {rms(error):.2f} over {len(error)} coefficients")
    modes = len(error) // 3
    for first in range(0, modes, GROUP):
        rows = range(3 * first, 3 * min(modes, first + GROUP))
        mean_read = sum(signs[c] * copy[c] for c in rows) / len(rows)
        print(f"  modes +{first:2d}..+{min(modes, first + GROUP) - 1:2d}: error RMS {rms([error[c] for c in rows]):5.2f}, "
              f"mean sign x reading {mean_read:5.2f}")
    if reference_path:
        reference, _ = reading(reference_path)
        left = [e - r for e, r in zip(error, reference)]
        difference = [c - r for c, r in zip(copy, reference)]
        print(f"  against {reference_path}: correlation of the error with it {correlation(error, reference):.3f}, "
              f"error RMS {rms(error):.2f} -> {rms(left):.2f}, uniform score {uniform_score(signs, copy):.2f} -> "
              f"{uniform_score(signs, difference):.2f}")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(*sys.argv[1:])
