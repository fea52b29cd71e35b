#!/usr/bin/env python3
"""Compare the verdict rules on the trials of `meshmark bench robustness --json-file`.

For every attack (marked copies) and for the null trials (wrong keys, unmarked copies), counts
the copies claimed at --max-fpp by the soft correlation alone (its recorded
score_false_positive_probability: the union over its statistics, 5 since the damped readings of
2026-11-25, 3 before; files without the field are taken as 3) and by the combined rule (that and the bit count, a share --share of the level to the bit
count: FPP = min(p_soft / (1 - share), p_bits / share)), and how many copies that read
R >= 0.9 each rule refuses. Both are recomputed from the recorded score z and the bits'
binomial tail, so a trials file made under either default gives the same table.
Usage: verdicts.py [--max-fpp 1e-6] [--share 0.0625] TRIALS.json [...]
"""
import argparse
import json
import math
from collections import defaultdict


def rademacher_tail(z):
    if not z > 0:
        return 1.0
    return min(1.0, math.exp(-0.5 * z * z), 2 * math.exp(3) / 9 * 0.5 * math.erfc(z / math.sqrt(2)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-fpp", type=float, default=1e-6)
    parser.add_argument("--share", type=float, default=1.0 / 16.0)
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    trials = []
    for path in args.files:
        with open(path) as f:
            trials += [t for t in json.load(f)["trials"] if not t["error"]]
    rows = defaultdict(lambda: [0, 0, 0, 0, 0, 0, 0.0])  # n, soft, combined, R>=.9, refused soft, refused comb, sum R
    for t in trials:
        key = t["attack"] if t["kind"] == "marked" else f'({t["kind"]})'
        soft = t.get("score_false_positive_probability", min(1.0, 3 * rademacher_tail(t["score"])))
        combined = min(1.0, soft / (1.0 - args.share), t["bits_false_positive_probability"] / args.share)
        high = t["correlation"] >= 0.9
        r = rows[key]
        r[0] += 1
        r[1] += soft <= args.max_fpp
        r[2] += combined <= args.max_fpp
        r[3] += high
        r[4] += high and soft > args.max_fpp
        r[5] += high and combined > args.max_fpp
        r[6] += t["correlation"]
    print(f"| attack | copies | claimed: correlation | claimed: combined | R >= 0.9 | of those refused: correlation | combined | mean R |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    total = [0] * 6
    for key in sorted(rows, key=lambda k: (k.startswith("("), k)):
        n, s, c, h, rs, rc, sr = rows[key]
        print(f"| `{key}` | {n} | {s} | {c} | {h} | {rs} | {rc} | {sr / n:.3f} |")
        if not key.startswith("("):
            total = [a + b for a, b in zip(total, [n, s, c, h, rs, rc])]
    print(f"| all marked | {total[0]} | {total[1]} | {total[2]} | {total[3]} | {total[4]} | {total[5]} | |")


if __name__ == "__main__":
    main()
