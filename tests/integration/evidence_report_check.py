#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""`meshmark detect --report` end to end (issue 55, item 2), on the shared bunny.

Marks bunny.off for the owner and, with a family key, for two recipients; then checks three
suspects (a marked copy cropped, moved and simplified; bob's copy; the unmarked original moved
and noised) with `detect --json` and `detect --report x.html|x.pdf --json`, and checks that:
  - each report states what `--json` states: the `meshmark:` meta tags equal `detected`,
    `false_positive_probability` and the accused names, and the visible words say CLAIMED (with
    the accused names) or NOT SHOWN;
  - the HTML is self-contained (two PNG data URIs, no script, no http(s) or file reference)
    and neither report holds the key's seed or payload bits (the PDF's streams inflated);
  - the PDF report starts with %PDF and has at most 3 pages;
  - a report with another extension is refused with exit code 2 and leaves no file;
  - with chromium on PATH: a headless screenshot shows the two pictures (orange pixels of the
    suspect, heat-map colours of the distances), and chromium's print of each report to PDF has
    at most 3 pages.
Exit 0 when every check held; 77 without the shared meshes, or without chromium once every
other check held (1 when one failed).
"""
import argparse
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path


def default_cli():
    here = Path(__file__).resolve().parents[2]
    return os.environ.get("MESHMARK_CLI") or str(here / "build" / "bin" / "meshmark")


def mesh_dir():
    here = Path(__file__).resolve().parents[3]
    return Path(os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
                or here / "shared" / "data" / "meshes")


class Checks:
    def __init__(self):
        self.failed = 0

    def check(self, ok, what):
        print(("ok   " if ok else "FAIL ") + what, flush=True)
        if not ok:
            self.failed += 1
        return ok


def run(cli, *args, expect=None):
    result = subprocess.run([cli, *map(str, args)], capture_output=True, text=True, timeout=300)
    if expect is not None and result.returncode not in expect:
        sys.exit(f"meshmark {' '.join(map(str, args))}: exit {result.returncode}\n{result.stderr}")
    return result


def pdf_pages(data):
    return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", data))


def pdf_text(data):
    """The PDF's bytes with every Flate stream inflated (where the text of its pages lives)."""
    out = [data]
    for match in re.finditer(rb"stream\r?\n", data):
        try:
            out.append(zlib.decompressobj().decompress(data[match.end():]))
        except zlib.error:
            pass
    return b"\n".join(out)


def png_pixels(path):
    """(width, height, channels, rows of bytes) of an 8-bit non-interlaced PNG, with PIL if it is
    installed, else decoded here (zlib + the five row filters)."""
    try:
        from PIL import Image  # python3-pil
        image = Image.open(path).convert("RGB")
        w, h = image.size
        raw = image.tobytes()
        return w, h, 3, [raw[y * w * 3:(y + 1) * w * 3] for y in range(h)]
    except ImportError:
        pass
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    w, h, depth, color, _, _, interlace = header
    assert depth == 8 and interlace == 0 and color in (2, 6), f"unsupported PNG {header}"
    channels = 3 if color == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * channels
    rows, previous = [], bytearray(stride)
    for y in range(h):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if kind == 1:
            for i in range(channels, stride):
                line[i] = (line[i] + line[i - channels]) & 255
        elif kind == 2:
            for i in range(stride):
                line[i] = (line[i] + previous[i]) & 255
        elif kind == 3:
            for i in range(stride):
                left = line[i - channels] if i >= channels else 0
                line[i] = (line[i] + ((left + previous[i]) >> 1)) & 255
        elif kind == 4:
            for i in range(stride):
                a = line[i - channels] if i >= channels else 0
                b = previous[i]
                c = previous[i - channels] if i >= channels else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        previous = line
    return w, h, channels, rows


def picture_pixels(path):
    """Counts of the suspect's orange and of the heat map's blue-to-green in a screenshot."""
    w, h, channels, rows = png_pixels(path)
    orange = heat = 0
    for row in rows:
        for x in range(0, w * channels, channels):
            r, g, b = row[x], row[x + 1], row[x + 2]
            if r > 120 and r > g + 40 and g > b + 20:
                orange += 1
            elif b > 120 and r < 90 and b > r + 60:
                heat += 1
            elif g > 120 and r < 90 and b < 90:
                heat += 1
    return orange, heat


def check_report(c, cli, tmp, name, suspect, original, key, expect_claimed, expect_accused):
    """detect --json and detect --report (html, pdf): the reports state what the JSON states."""
    plain = run(cli, "detect", suspect, "--original", original, "--key", key, "--json", "-q", expect=(0, 1))
    truth = json.loads(plain.stdout)
    html = tmp / f"{name}.html"
    with_report = run(cli, "detect", suspect, "--original", original, "--key", key, "--json", "-q",
                      "--report", html, expect=(0, 1))
    c.check(with_report.returncode == plain.returncode, f"{name}: --report keeps the exit code")
    again = json.loads(with_report.stdout)
    c.check(again["detected"] == truth["detected"], f"{name}: --report keeps the --json verdict")
    c.check(truth["detected"] == expect_claimed, f"{name}: detected is {expect_claimed}")
    accused = [r["name"] for r in truth.get("recipients", [])]
    c.check(accused == expect_accused, f"{name}: accused {accused}")

    text = html.read_text(encoding="utf-8")
    meta = dict(re.findall(r'<meta name="meshmark:([a-z_]+)" content="([^"]*)">', text))
    c.check(meta.get("detected") == ("true" if truth["detected"] else "false"), f"{name}: report's detected = JSON's")
    c.check(float(meta.get("false_positive_probability", "nan")) == truth["false_positive_probability"],
            f"{name}: report's probability = JSON's ({truth['false_positive_probability']:.3g})")
    c.check(meta.get("accused", "") == ",".join(accused), f"{name}: report's accused = JSON's")
    if truth["detected"]:
        c.check("CLAIMED" in text and "NOT SHOWN" not in text, f"{name}: the report says CLAIMED")
    else:
        c.check("NOT SHOWN" in text and "CLAIMED" not in text, f"{name}: the report says NOT SHOWN")
    c.check(" 1 in " in text or "less than 1 in 10" in text, f"{name}: the chance as '1 in N'")
    for who in accused:
        c.check(f"copy issued to {who}" in text, f"{name}: the report names {who}")
    c.check(text.count('src="data:image/png;base64,') == 2, f"{name}: two inlined pictures")
    external = re.findall(r'(?:src|href)="(?!data:)[^"]*"', text)
    c.check(not external and "<script" not in text and "http://" not in text and "https://" not in text,
            f"{name}: self-contained (no script, no external reference)")
    key_json = json.loads(Path(key).read_text())
    secrets = [s for s in (key_json.get("seed"), key_json.get("payload", {}).get("bits")) if s]
    c.check(len(secrets) == 2, f"{name}: the key file has a seed and payload bits to look for")
    c.check(not any(s in text for s in secrets), f"{name}: the HTML holds neither the key's seed nor its payload")

    pdf = tmp / f"{name}.pdf"
    run(cli, "detect", suspect, "--original", original, "--key", key, "-q", "--report", pdf, expect=(0, 1))
    data = pdf.read_bytes()
    pages = pdf_pages(data)
    c.check(data.startswith(b"%PDF") and 1 <= pages <= 3, f"{name}: --report .pdf is a PDF of {pages} page(s)")
    inflated = pdf_text(data)
    c.check(not any(s.encode() in inflated for s in secrets), f"{name}: the PDF holds no key material")
    return html


def check_scan_reports(c, cli, tmp, bunny, spot):
    """catalog scan --report 'dir/{suspect}.html': one report per suspect, each stating what the
    scan's --json states for it (the bound over the whole catalogue)."""
    originals = tmp / "originals"
    originals.mkdir()
    for mesh in (bunny, spot):
        shutil.copy(mesh, originals / mesh.name)
    catalog = tmp / "shop.db"
    run(cli, "catalog", "add", catalog, originals, "-o", tmp / "published", "-q", expect=(0,))
    run(cli, "catalog", "issue", catalog, bunny.name, "--recipient", "bob", "-o", tmp / "sold_{recipient}.ply", "-q",
        expect=(0,))
    run(cli, "attack", tmp / "sold_bob.ply", "similarity,simplify=0.6", "-o", tmp / "leak.ply", "--seed", 3, "-q",
        expect=(0,))
    run(cli, "attack", spot, "similarity,noise=0.0005", "-o", tmp / "lookalike.ply", "--seed", 4, "-q", expect=(0,))
    one = run(cli, "catalog", "scan", catalog, tmp / "leak.ply", tmp / "lookalike.ply", "--report",
              tmp / "scan.html", "-q")
    c.check(one.returncode == 2 and not (tmp / "scan.html").exists(),
            f"scan --report without {{suspect}} for two suspects: exit {one.returncode}: {one.stderr.strip()}")
    done = run(cli, "catalog", "scan", catalog, tmp / "leak.ply", tmp / "lookalike.ply", "--report",
               tmp / "scan" / "{suspect}.html", "--json", "-q", expect=(0,))
    for suspect in json.loads(done.stdout)["suspects"]:
        name = Path(suspect["path"]).stem
        page = tmp / "scan" / f"{name}.html"
        if not c.check(page.exists(), f"scan: {page.name} written"):
            continue
        text = page.read_text(encoding="utf-8")
        meta = dict(re.findall(r'<meta name="meshmark:([a-z_]+)" content="([^"]*)">', text))
        c.check(meta.get("detected") == ("true" if suspect["detected"] else "false"),
                f"scan {name}: report's detected = scan's ({suspect['detected']})")
        if suspect["detected"]:
            match = suspect["matches"][0]
            c.check(float(meta["false_positive_probability"]) == match["false_positive_probability"],
                    f"scan {name}: report's probability = the scan's over the catalogue "
                    f"({match['false_positive_probability']:.3g})")
            names = [r["name"] for r in match.get("recipients", [])]
            c.check(meta.get("accused", "") == ",".join(names) and names == ["bob"],
                    f"scan {name}: report's accused = scan's ({names})")
            c.check("CLAIMED" in text and "catalog scan" in text, f"scan {name}: CLAIMED, and the scan to repeat")
        else:
            c.check("NOT SHOWN" in text, f"scan {name}: NOT SHOWN")


def check_browser(c, tmp, html):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        print("skip chromium checks: chromium is not on PATH")
        return False
    common = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
              f"--user-data-dir={tmp / 'chromium-profile'}"]
    shot = tmp / "shot.png"
    subprocess.run(common + [f"--screenshot={shot}", "--window-size=1200,2000", html.as_uri()],
                   capture_output=True, timeout=120)
    if c.check(shot.exists(), "chromium took a screenshot"):
        orange, heat = picture_pixels(shot)
        c.check(orange > 2000, f"the screenshot shows the aligned suspect ({orange} orange pixels)")
        c.check(heat > 2000, f"the screenshot shows the distance picture ({heat} heat-map pixels)")
    for page in sorted(tmp.glob("*.html")):
        printed = tmp / f"{page.stem}-printed.pdf"
        subprocess.run(common + ["--no-pdf-header-footer", f"--print-to-pdf={printed}", page.as_uri()],
                       capture_output=True, timeout=120)
        if c.check(printed.exists(), f"chromium printed {page.name} to PDF"):
            pages = pdf_pages(printed.read_bytes())
            c.check(1 <= pages <= 3, f"chromium's print of {page.name}: {pages} A4 page(s)")
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = parser.parse_args()
    bunny = mesh_dir() / "bunny.off"
    if not bunny.exists():
        print(f"skip: {bunny} is missing")
        return 77
    c = Checks()
    browsed = False
    tmp = Path(tempfile.mkdtemp(prefix="meshmark-evidence-"))
    try:
        cli = args.cli
        # The owner's mark, and a copy cropped, moved and simplified (registered and resampled).
        run(cli, "embed", bunny, "-o", tmp / "marked.ply", "--key", tmp / "owner.key", "--message", "owner",
            "-q", expect=(0,))
        run(cli, "attack", tmp / "marked.ply", "similarity,crop=0.8,simplify=0.7", "-o", tmp / "found.ply",
            "--seed", 5, "-q", expect=(0,))
        html = check_report(c, cli, tmp, "claimed", tmp / "found.ply", bunny, tmp / "owner.key", True, [])
        # An unmarked suspect: the original, moved and noised.
        run(cli, "attack", bunny, "similarity,noise=0.0005", "-o", tmp / "other.ply", "--seed", 7, "-q",
            expect=(0,))
        check_report(c, cli, tmp, "unmarked", tmp / "other.ply", bunny, tmp / "owner.key", False, [])
        # A family key: bob's copy, moved, is traced to bob.
        run(cli, "embed", bunny, "-o", tmp / "copy_{recipient}.ply", "--key", tmp / "family.key",
            "--recipient", "alice", "--recipient", "bob", "-q", expect=(0,))
        run(cli, "attack", tmp / "copy_bob.ply", "similarity,noise=0.0002", "-o", tmp / "bob_found.ply",
            "--seed", 9, "-q", expect=(0,))
        check_report(c, cli, tmp, "family", tmp / "bob_found.ply", bunny, tmp / "family.key", True, ["bob"])
        # Another extension: a usage error, no file.
        bad = run(cli, "detect", tmp / "found.ply", "--original", bunny, "--key", tmp / "owner.key",
                  "--report", tmp / "x.txt", "-q")
        c.check(bad.returncode == 2 and not (tmp / "x.txt").exists() and bad.stderr.count("\n") == 1,
                f"--report x.txt: exit {bad.returncode}, one line: {bad.stderr.strip()}")
        check_scan_reports(c, cli, tmp, bunny, mesh_dir() / "spot.obj")
        browsed = check_browser(c, tmp, html)
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    print("all checks held" if c.failed == 0 else f"{c.failed} check(s) failed")
    if c.failed == 0 and not browsed:
        return 77  # the report's own checks held, but nothing opened it in a browser
    return 0 if c.failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
