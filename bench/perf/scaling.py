#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Time per vertex of `meshmark embed` from ~10K to 4M vertices (the paper's Fig. 5).

Runs `meshmark bench speed --json --no-detect` (every mesh of --mesh-dir plus generated
meshes of --sizes), or reads a saved JSON with --json-in, then writes a log-log chart as SVG
(hand-written: no plotting library is installed, and a chart of two series needs none) and
prints a Markdown table.

    bench/perf/scaling.py --meshmark build-perf/bin/meshmark --mesh-dir DIR \
        --sizes 10000,100000,1000000,4000000 --threads 2 --repeat 2 \
        --json-out /tmp/scaling.json --svg docs/scaling.svg
"""
import argparse
import json
import math
import subprocess
import sys


def run_bench(args):
    command = [args.meshmark, "bench", "speed", "--json", "--no-detect", "-q",
               "--threads", str(args.threads), "--repeat", str(args.repeat)]
    if args.mesh_dir:
        command += ["--mesh-dir", args.mesh_dir]
    else:
        command += ["--no-shared"]
    if args.sizes:
        command += ["--sizes", args.sizes]
    else:
        command += ["--no-generated"]
    result = subprocess.run(command, check=True, capture_output=True, text=True)
    return json.loads(result.stdout)


def points(report, min_vertices):
    rows = []
    for run in report["runs"]:
        if run.get("embed_exit_code") != 0 or run.get("vertices", 0) < min_vertices:
            continue
        n = run["vertices"]
        seconds = run["embed_seconds"]
        rows.append({
            "mesh": run["mesh"],
            "vertices": n,
            "generated": run["mesh"].startswith("generated-"),
            "total": seconds["total"],
            "cpu": run.get("embed_cpu_seconds", float("nan")),
            "phases": {k: seconds.get(k, 0.0) for k in ("read", "basis", "embed", "write")},
            "peak": run["embed_peak_mib"],
        })
    rows.sort(key=lambda r: r["vertices"])
    return rows


def svg_chart(rows, title):
    width, height = 720, 440
    left, right, top, bottom = 70, 170, 40, 50
    xs = [r["vertices"] for r in rows]
    ys = [1e6 * r[key] / r["vertices"] for r in rows for key in ("total", "cpu") if r[key] == r[key]]
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))

    def px(x):
        return left + (math.log10(x) - x0) / (x1 - x0) * (width - left - right)

    def py(y):
        return height - bottom - (math.log10(y) - y0) / (y1 - y0) * (height - top - bottom)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{left}" y="22" font-size="14">{title}</text>']
    for e in range(x0, x1 + 1):
        x = px(10 ** e)
        out.append(f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{height - bottom}" stroke="#ddd"/>')
        out.append(f'<text x="{x:.1f}" y="{height - bottom + 16}" text-anchor="middle">1e{e}</text>')
    for e in range(y0, y1 + 1):
        y = py(10 ** e)
        out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{width - right}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 6}" y="{y + 4:.1f}" text-anchor="end">{10 ** e:g}</text>')
    out.append(f'<rect x="{left}" y="{top}" width="{width - left - right}" height="{height - top - bottom}" '
               'fill="none" stroke="black"/>')
    out.append(f'<text x="{(left + width - right) / 2}" y="{height - 12}" text-anchor="middle">vertices</text>')
    out.append(f'<text x="18" y="{(top + height - bottom) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 18 {(top + height - bottom) / 2})">microseconds per vertex</text>')
    series = [("total", "#1f77b4", "wall, end to end"), ("cpu", "#d62728", "CPU (all threads)")]
    for index, (key, color, label) in enumerate(series):
        line = [(px(r["vertices"]), py(1e6 * r[key] / r["vertices"])) for r in rows if r[key] == r[key]]
        path = " ".join(f"{x:.1f},{y:.1f}" for x, y in line)
        out.append(f'<polyline points="{path}" fill="none" stroke="{color}" stroke-width="1.5"/>')
        for r, (x, y) in zip([r for r in rows if r[key] == r[key]], line):
            if r["generated"]:
                out.append(f'<rect x="{x - 3.5:.1f}" y="{y - 3.5:.1f}" width="7" height="7" fill="{color}"/>')
            else:
                out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3.5" fill="{color}"/>')
        ly = top + 10 + 20 * index
        out.append(f'<line x1="{width - right + 12}" y1="{ly}" x2="{width - right + 32}" y2="{ly}" '
                   f'stroke="{color}" stroke-width="2"/>')
        out.append(f'<text x="{width - right + 38}" y="{ly + 4}">{label}</text>')
    ly = top + 60
    out.append(f'<circle cx="{width - right + 22}" cy="{ly}" r="3.5" fill="#555"/>')
    out.append(f'<text x="{width - right + 38}" y="{ly + 4}">shared mesh</text>')
    out.append(f'<rect x="{width - right + 18.5}" y="{ly + 16.5}" width="7" height="7" fill="#555"/>')
    out.append(f'<text x="{width - right + 38}" y="{ly + 24}">generated</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--meshmark", default="build-perf/bin/meshmark")
    parser.add_argument("--mesh-dir", default="")
    parser.add_argument("--sizes", default="10000,100000,1000000,4000000")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--min-vertices", type=int, default=10000)
    parser.add_argument("--json-in", help="Use a saved `bench speed --json` report instead of running it")
    parser.add_argument("--json-out", help="Save the report")
    parser.add_argument("--svg", default="docs/scaling.svg")
    parser.add_argument("--title", default="meshmark embed, k = 100: time per vertex")
    args = parser.parse_args()
    if args.json_in:
        with open(args.json_in) as f:
            report = json.load(f)
    else:
        report = run_bench(args)
    if args.json_out:
        with open(args.json_out, "w") as f:
            json.dump(report, f, indent=1)
    rows = points(report, args.min_vertices)
    if not rows:
        sys.exit("no successful runs to plot")
    with open(args.svg, "w") as f:
        f.write(svg_chart(rows, args.title))
    print("| mesh | vertices | read | basis | embed | write | total | CPU | us/vertex (wall) | us/vertex (CPU) | peak MiB |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        p = r["phases"]
        print(f"| {r['mesh']} | {r['vertices']} | {p['read']:.3f} | {p['basis']:.3f} | {p['embed']:.3f} | "
              f"{p['write']:.3f} | {r['total']:.3f} | {r['cpu']:.3f} | {1e6 * r['total'] / r['vertices']:.2f} | "
              f"{1e6 * r['cpu'] / r['vertices']:.2f} | {r['peak']:.1f} |")


if __name__ == "__main__":
    main()
