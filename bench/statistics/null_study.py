#!/usr/bin/env python3
"""Compare the verdicts of suspects that do NOT carry the key's mark with the null model.

Input: the --json-file of `meshmark bench robustness` (trials of kind "wrong-key" and
"unmarked"). For each kind, prints the number of trials, the largest score z, and for several
levels alpha the share of trials whose reported false-positive probability is <= alpha (the
bound is valid when that share never exceeds alpha beyond sampling error), plus the same for
the paper's binomial probability of R. Usage: null_study.py TRIALS.json [...]
"""
import json
import math
import sys

LEVELS = [0.5, 0.1, 0.01, 1e-3, 1e-4, 1e-6]


def summarize(name, trials):
    n = len(trials)
    if n == 0:
        return
    zs = sorted(t["score"] for t in trials)
    print(f"### {name}: {n} trials\n")
    print(f"largest z {zs[-1]:.2f}, mean z {sum(zs) / n:.3f}, largest R {max(t['correlation'] for t in trials):.3f}, "
          f"claimed {sum(1 for t in trials if t['detected'])}, "
          f"claimed by the bits rule (R >= 0.75) {sum(1 for t in trials if t['correlation'] >= 0.75)}\n")
    print("| alpha | share with FPP <= alpha (the verdict) | share with binomial FPP <= alpha (bits) | "
          "3-sigma allowance |")
    print("|---:|---:|---:|---:|")
    for a in LEVELS:
        corr = sum(1 for t in trials if t["false_positive_probability"] <= a) / n
        bits = sum(1 for t in trials if t["bits_false_positive_probability"] <= a) / n
        slack = a + 3 * math.sqrt(a * (1 - a) / n)
        print(f"| {a:g} | {corr:.4g} | {bits:.4g} | {slack:.4g} |")
    print()


def main():
    trials = []
    for path in sys.argv[1:]:
        with open(path) as f:
            trials += [t for t in json.load(f)["trials"] if not t["error"]]
    summarize("wrong keys on marked copies", [t for t in trials if t["kind"] == "wrong-key"])
    summarize("unmarked copies (original and attacked)", [t for t in trials if t["kind"] == "unmarked"])


if __name__ == "__main__":
    main()
