# SPDX-License-Identifier: MIT
"""meshmark.Catalog: the catalogue of `meshmark catalog ...`, shared with the program both ways."""
import json
import subprocess

import pytest

import meshmark


@pytest.fixture()
def originals(torus, tmp_path):
    folder = tmp_path / "originals"
    (folder / "sub").mkdir(parents=True)
    V, F = torus
    meshmark.write_mesh(folder / "ring.ply", V, F)
    meshmark.write_mesh(folder / "sub" / "flat_ring.obj", V * [1.0, 1.0, 0.3], F)
    return folder


def test_add_list_issue_scan_and_the_program_reads_the_same_catalogue(originals, tmp_path, cli):
    path = tmp_path / "cat.db"
    with pytest.raises(meshmark.IoError, match="no such catalogue"):
        meshmark.Catalog(path)
    catalog = meshmark.Catalog(path, create=True)
    added = catalog.add([originals], tmp_path / "out", seed=3)
    assert added["counts"] == {"marked": 2, "present": 0, "unmarkable": 0, "failed": 0}
    assert catalog.add([originals], tmp_path / "out")["counts"]["present"] == 2
    assets = {a["asset"]: a for a in catalog.list()}
    assert sorted(assets) == ["ring.ply", "sub/flat_ring.obj"]
    assert all(a["complete"] and a["recipients"][0]["name"] == "published" for a in assets.values())

    issued = catalog.issue("ring.ply", ["ann", "ben"], str(tmp_path / "copies" / "{recipient}.ply"))
    assert [c["name"] for c in issued["copies"]] == ["ann", "ben"]
    assert "key" not in issued

    # The program sees what Python recorded, and scans ben's copy to its asset and recipient.
    listed = json.loads(subprocess.run([cli, "catalog", "list", path, "--json"], capture_output=True,
                                       text=True, check=True).stdout)
    assert {a["asset"] for a in listed["assets"]} == set(assets)
    report = catalog.scan([tmp_path / "copies" / "ben.ply"], candidates=2)
    suspect = report["suspects"][0]
    assert suspect["detected"]
    assert suspect["matches"][0]["asset"] == "ring.ply"
    assert [r["name"] for r in suspect["matches"][0]["recipients"]] == ["ben"]
    assert report["assets"] == 2

    # The exported key detects with `meshmark detect` as a key file would.
    key = catalog.key("ring.ply")
    key.save(tmp_path / "ring.json")
    done = subprocess.run([cli, "detect", tmp_path / "copies" / "ann.ply", "--original", originals / "ring.ply",
                           "--key", tmp_path / "ring.json", "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert [r["name"] for r in json.loads(done.stdout)["recipients"]] == ["ann"]
    with pytest.raises(meshmark.InvalidOption, match="no asset 'nope'"):
        catalog.key("nope")


def test_scan_writes_the_programs_evidence_report_per_suspect(originals, tmp_path):
    catalog = meshmark.Catalog(tmp_path / "cat.db", create=True)
    catalog.add([originals], tmp_path / "out", seed=3)
    catalog.issue("ring.ply", ["ann"], str(tmp_path / "copies" / "{recipient}.ply"))
    suspects = [tmp_path / "copies" / "ann.ply", originals / "sub" / "flat_ring.obj"]
    # One file for two suspects is refused before any work, as --report is.
    with pytest.raises(meshmark.InvalidOption, match="one file for several suspects"):
        catalog.scan(suspects, report=tmp_path / "one.html")
    assert not (tmp_path / "one.html").exists()
    report = catalog.scan(suspects, candidates=2, report=str(tmp_path / "r_{suspect}.html"))
    found, unmarked = report["suspects"]
    assert found["detected"] and found["report"] == str(tmp_path / "r_ann.html")
    text = (tmp_path / "r_ann.html").read_text()
    assert "ring.ply" in text and "ann" in text and "meshmark.Catalog(" in text
    # An unmarked original: compared with the nearest asset tried, its report says not found.
    assert not unmarked["detected"] and (tmp_path / "r_flat_ring.html").is_file()
