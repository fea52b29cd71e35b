# SPDX-License-Identifier: MIT
"""The options the package shares with the meshmark program (issue 56): compare's heatmap (the
same bytes as `compare --heatmap`), `--unit`, `--no-trace` (trace=False), `--recipients`
(recipients_file) and `catalog reindex` (Catalog.reindex)."""
import json
import re
import subprocess

import numpy as np
import pytest

import meshmark


def run_cli(cli, *args):
    done = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if done.returncode not in (0, 1):
        raise AssertionError(f"meshmark {' '.join(map(str, args))}: exit {done.returncode}: {done.stderr}")
    return done


@pytest.fixture()
def original(torus, tmp_path):
    path = tmp_path / "original.ply"
    meshmark.write_mesh(path, *torus)
    return path


@pytest.fixture()
def marked(original, tmp_path):
    meshmark.embed_file(original, tmp_path / "marked.ply", tmp_path / "key.json", seed=5)
    return tmp_path / "marked.ply"


@pytest.mark.parametrize("name, options", [
    ("h.png", {}),
    ("h.png", {"view": "top", "size": "320x200", "up": "z"}),
    ("h.ply", {}),
])
def test_compare_heatmap_is_the_programs_byte_for_byte(original, marked, tmp_path, cli, name, options):
    ours = tmp_path / f"py_{name}"
    theirs = tmp_path / f"cli_{name}"
    report = meshmark.compare(original, marked, heatmap=ours, **options)
    flags = [f"--{key}={value}" for key, value in options.items()]
    cli_report = json.loads(run_cli(cli, "compare", original, marked, "--heatmap", theirs, *flags,
                                    "--json", "--quiet").stdout)
    assert ours.read_bytes() == theirs.read_bytes()
    assert set(report) == set(cli_report)
    assert report["heatmap"] == {"file": str(ours), "max_distance": cli_report["heatmap"]["max_distance"]}
    assert report["hausdorff"] == cli_report["hausdorff"]


def test_compare_unit_and_heatmap_errors_are_the_programs(original, marked, tmp_path, cli):
    report = meshmark.compare(original, marked, unit="mm")
    cli_report = json.loads(run_cli(cli, "compare", original, marked, "--unit", "mm", "--json").stdout)
    assert report["in_unit"] == cli_report["in_unit"]
    assert "in_unit" not in meshmark.compare(original, marked)  # PLY states no unit
    with pytest.raises(meshmark.InvalidOption, match=r"heatmap .*h\.jpg must name a \.ply file"):
        meshmark.compare(original, marked, heatmap=tmp_path / "h.jpg")
    with pytest.raises(meshmark.InvalidOption, match="view applies to a .png heatmap only"):
        meshmark.compare(original, marked, view="top")
    with pytest.raises(meshmark.InvalidOption, match="would overwrite an input mesh"):
        meshmark.compare(original, marked, heatmap=marked)
    with pytest.raises(meshmark.InvalidOption, match="compare: "):
        meshmark.compare(original, marked, heatmap=tmp_path / "h.png", size="1x1")
    with pytest.raises(meshmark.InvalidOption, match="heatmap must be a str, an os.PathLike or None, got a int"):
        meshmark.compare(original, marked, heatmap=3)
    with pytest.raises(meshmark.InvalidOption, match="unit must be a str or None"):
        meshmark.compare(original, marked, unit=1.0)
    with pytest.raises(meshmark.InvalidOption):
        meshmark.compare(original, marked, unit="furlong")
    assert not (tmp_path / "h.png").exists()


def test_trace_false_is_no_trace(torus, original, tmp_path, cli):
    V, F = torus
    names = tmp_path / "names.txt"
    names.write_text("# recipients\nann\n\n  ben  \n")
    issued = meshmark.embed_recipients(original, str(tmp_path / "py_{recipient}.ply"), tmp_path / "family.json",
                                       ["cat"], recipients_file=names, seed=8)
    assert [c["name"] for c in issued["copies"]] == ["cat", "ann", "ben"]
    done = subprocess.run([cli, "embed", original, "-o", tmp_path / "cli_{recipient}.ply", "--key",
                           tmp_path / "cli_family.json", "--recipient", "cat", "--recipients", names, "--seed", "8",
                           "--quiet"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    for name in ("ann", "ben", "cat"):
        assert (tmp_path / f"py_{name}.ply").read_bytes() == (tmp_path / f"cli_{name}.ply").read_bytes(), name
    with pytest.raises(meshmark.IoError, match="cannot open the recipients file"):
        meshmark.embed_recipients(original, str(tmp_path / "{recipient}.ply"), tmp_path / "family.json",
                                  recipients_file=tmp_path / "missing.txt")
    with pytest.raises(meshmark.InvalidOption, match="recipients_file must be"):
        meshmark.embed_recipients(original, str(tmp_path / "{recipient}.ply"), tmp_path / "family.json",
                                  recipients_file=["ann"])

    key = meshmark.Key.load(tmp_path / "family.json")
    ann, _ = meshmark.read_mesh(tmp_path / "py_ann.ply")
    traced = meshmark.detect(ann, F, V, F, key)
    assert [r["name"] for r in traced.recipients] == ["ann"]
    untraced = meshmark.detect(ann, F, V, F, key, trace=False)
    assert untraced.detected and untraced.recipients == []
    assert "recipients_traced" not in untraced.to_dict() and traced.to_dict()["recipients_traced"] == 3
    against = meshmark.detect_against_file(ann, F, original, tmp_path / "family.json", trace=False)
    assert "recipients_traced" not in against.to_dict() and against.score == untraced.score

    suspect = tmp_path / "py_ann.ply"
    ours = meshmark.detect_file(suspect, original, tmp_path / "family.json", trace=False)
    theirs = json.loads(run_cli(cli, "detect", suspect, "--original", original, "--key", tmp_path / "family.json",
                                "--no-trace", "--json").stdout)
    assert set(ours) == set(theirs) and "recipients_traced" not in ours
    for field in ("detected", "score", "headline"):
        assert ours[field] == theirs[field], field
    assert meshmark.detect_file(suspect, original, tmp_path / "family.json")["recipients_traced"] == 3


def test_catalog_reindex_issue_from_a_file_and_scan_without_tracing(torus, tmp_path, cli):
    V, F = torus
    (tmp_path / "in").mkdir()
    meshmark.write_mesh(tmp_path / "in" / "ring.ply", V, F)
    catalog = meshmark.Catalog(tmp_path / "cat.db", create=True)
    added = catalog.add([tmp_path / "in"], tmp_path / "out", seed=3, basis_size=120, coefficients=8)
    assert added["counts"]["marked"] == 1
    assert catalog.key("ring.ply").basis_size == 120

    current = catalog.reindex()
    assert current["counts"] == {"current": 1, "updated": 0, "failed": 0}
    everything = catalog.reindex(all=True)
    assert everything["counts"] == {"current": 0, "updated": 1, "failed": 0}
    cli_report = json.loads(run_cli(cli, "catalog", "reindex", tmp_path / "cat.db", "--all", "--json").stdout)
    assert set(cli_report) == set(everything)
    assert [a["asset"] for a in cli_report["assets"]] == [a["asset"] for a in everything["assets"]]

    names = tmp_path / "names.txt"
    names.write_text("dan\n")
    issued = catalog.issue("ring.ply", ["eve"], str(tmp_path / "copies" / "{recipient}.ply"), recipients_file=names)
    assert [c["name"] for c in issued["copies"]] == ["eve", "dan"]
    traced = catalog.scan([tmp_path / "copies" / "dan.ply"])
    assert [r["name"] for r in traced["suspects"][0]["matches"][0]["recipients"]] == ["dan"]
    untraced = catalog.scan([tmp_path / "copies" / "dan.ply"], trace=False)
    match = untraced["suspects"][0]["matches"][0]
    assert match["asset"] == "ring.ply" and match["recipients"] == []
    assert isinstance(catalog.path, type(tmp_path)) and catalog.path == tmp_path / "cat.db"


def test_recipient_copies_take_the_programs_centers(original, tmp_path, cli):
    meshmark.embed_recipients(original, str(tmp_path / "py_{recipient}.ply"), tmp_path / "py.json", ["ann"],
                              centers="decimate", seed=2)
    assert meshmark.Key.load(tmp_path / "py.json").centers == "decimate"
    run_cli(cli, "embed", original, "-o", tmp_path / "cli_{recipient}.ply", "--key", tmp_path / "cli.json",
            "--recipient", "ann", "--centers", "decimate", "--seed", 2, "--quiet")
    assert (tmp_path / "py_ann.ply").read_bytes() == (tmp_path / "cli_ann.ply").read_bytes()


def test_wrong_types_raise_typed_errors_naming_the_keyword(torus, tmp_path):
    V, F = torus
    with pytest.raises(meshmark.InvalidOption, match="strength must be a number or None, got a str"):
        meshmark.embed(V, F, strength="strong")
    with pytest.raises(meshmark.InvalidOption, match="strength must be a number or None, got a str"):
        meshmark.Catalog(tmp_path / "c.db", create=True).add([tmp_path], tmp_path / "out", strength="strong")
    with pytest.raises(meshmark.InvalidOption, match="message must be a str or None, got a int"):
        meshmark.Catalog(tmp_path / "c.db").add([tmp_path], tmp_path / "out", message=3)
    with pytest.raises(meshmark.InvalidOption, match="seed must be an integer"):
        meshmark.Catalog(tmp_path / "c.db").add([tmp_path], tmp_path / "out", seed="s")
    key, marked = meshmark.embed(V, F, seed=1, strength=np.float32(0.0006))  # numpy scalars convert
    assert key.strength == pytest.approx(0.0006)


def test_embed_file_unit_cap_and_record_are_the_programs(original, tmp_path, cli):
    ours = meshmark.embed_file(original, tmp_path / "py.ply", tmp_path / "py.json", seed=6, unit="mm",
                               max_displacement="0.002mm", record=tmp_path / "py_record.json")
    done = subprocess.run([cli, "embed", original, "-o", tmp_path / "cli.ply", "--key", tmp_path / "cli.json",
                           "--seed", "6", "--unit", "mm", "--max-displacement", "0.002mm",
                           "--record", tmp_path / "cli_record.json", "--json", "--quiet"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    theirs = json.loads(done.stdout)
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    assert set(ours) == set(theirs)
    for field in ("max_displacement", "rms_displacement", "strength"):
        assert ours[field] == theirs[field], field
    for field in set(theirs) & {"in_unit", "cap"}:
        assert ours[field] == theirs[field], field
    record = json.loads((tmp_path / "py_record.json").read_text())
    assert record == ours["record"]
    cli_record = json.loads((tmp_path / "cli_record.json").read_text())
    assert set(record) == set(cli_record)
    assert record["marked"]["sha256"] == cli_record["marked"]["sha256"]
    assert record["original"] == cli_record["original"]
    # A bare number is in the coordinates' unit; the checks are the program's.
    bare = meshmark.embed_file(original, tmp_path / "bare.ply", tmp_path / "bare.json", seed=6,
                               max_displacement=0.002, unit="mm")
    assert bare["max_displacement"] == ours["max_displacement"]
    with pytest.raises(meshmark.InvalidOption, match="must differ from the input, the output and the key"):
        meshmark.embed_file(original, tmp_path / "x.ply", tmp_path / "x.json", record=original)
    with pytest.raises(meshmark.InvalidOption, match="max_displacement"):
        meshmark.embed_file(original, tmp_path / "x.ply", tmp_path / "x.json", max_displacement="far")
    with pytest.raises(meshmark.InvalidOption, match="max_displacement must be a length"):
        meshmark.embed_file(original, tmp_path / "x.ply", tmp_path / "x.json", max_displacement=[1])
    with pytest.raises(meshmark.InvalidOption):
        meshmark.embed_file(original, tmp_path / "x.ply", tmp_path / "x.json", unit="parsec")
    assert not (tmp_path / "x.json").exists()


def test_detect_file_report_is_the_programs_evidence_report(original, marked, tmp_path, cli):
    """report= writes the evidence report `detect --report` writes: the same HTML but for the
    time it was made."""
    key = tmp_path / "key.json"
    found = meshmark.detect_file(marked, original, key, max_fpp=1e-5, trace=False, report=tmp_path / "py.html")
    run_cli(cli, "detect", marked, "--original", original, "--key", key, "--max-fpp", "1e-5", "--no-trace",
            "--report", tmp_path / "cli.html", "--quiet")
    made = re.compile(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC")
    ours = made.sub("TIME", (tmp_path / "py.html").read_text())
    assert ours == made.sub("TIME", (tmp_path / "cli.html").read_text())
    assert "--max-fpp 1e-05 --no-trace --json" in ours and found["detected"]
    html_key = tmp_path / "key.html"  # a key file may have any name
    html_key.write_bytes(key.read_bytes())
    with pytest.raises(meshmark.InvalidOption, match="report .*key.html would overwrite an input file"):
        meshmark.detect_file(marked, original, html_key, report=html_key)
    with pytest.raises(meshmark.InvalidOption, match="must name a .html or a .pdf file"):
        meshmark.detect_file(marked, original, key, report=tmp_path / "report.txt")
    assert html_key.read_bytes() == key.read_bytes()


def test_a_catalogue_of_a_build_that_fanned_polygons_is_flagged_until_reindexed(torus, tmp_path, cli):
    import sqlite3

    V, F = torus
    (tmp_path / "in").mkdir()
    meshmark.write_mesh(tmp_path / "in" / "ring.ply", V, F)
    catalog = meshmark.Catalog(tmp_path / "cat.db", create=True)
    catalog.add([tmp_path / "in"], tmp_path / "out", seed=3)
    published = tmp_path / "out" / "ring.ply"
    fresh = run_cli(cli, "catalog", "scan", tmp_path / "cat.db", published, "--json")
    assert json.loads(fresh.stdout)["stale_signatures"] is False and "older build" not in fresh.stderr

    # As a build before concave polygons were triangulated inside left it: no meta row.
    with sqlite3.connect(tmp_path / "cat.db") as db:
        db.execute("DELETE FROM meta WHERE name = 'signature_polygons'")
    db.close()
    stale = run_cli(cli, "catalog", "scan", tmp_path / "cat.db", published, "--json")
    assert json.loads(stale.stdout)["stale_signatures"] is True
    assert "older build" in stale.stderr and "catalog reindex" in stale.stderr
    assert catalog.scan([published])["stale_signatures"] is True

    assert catalog.reindex()["counts"] == {"current": 0, "updated": 1, "failed": 0}
    again = run_cli(cli, "catalog", "scan", tmp_path / "cat.db", published, "--json")
    assert json.loads(again.stdout)["stale_signatures"] is False and "older build" not in again.stderr
    assert catalog.reindex()["counts"] == {"current": 1, "updated": 0, "failed": 0}
