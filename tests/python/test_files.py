# SPDX-License-Identifier: MIT
"""The file-level calls and the key file, shared with the meshmark program both ways."""
import json
import subprocess

import numpy as np
import pytest

import meshmark


def run_cli(cli, *args, check=True):
    done = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if check and done.returncode not in (0, 1):
        raise AssertionError(f"meshmark {' '.join(map(str, args))}: exit {done.returncode}: {done.stderr}")
    return done


@pytest.fixture()
def original(torus, tmp_path):
    path = tmp_path / "original.ply"
    meshmark.write_mesh(path, *torus)
    return path


def test_read_write_round_trip(torus, tmp_path):
    V, F = torus
    for name in ("m.ply", "m.off", "m.obj"):
        meshmark.write_mesh(tmp_path / name, V, F)
        V2, F2 = meshmark.read_mesh(tmp_path / name)
        assert np.array_equal(V2, V), name
        assert np.array_equal(F2, F), name
    meshmark.write_mesh(tmp_path / "cloud.ply", V, None)
    V3, F3 = meshmark.read_mesh(tmp_path / "cloud.ply")
    assert F3 is None and np.array_equal(V3, V)
    with pytest.raises(meshmark.IoError, match="missing.ply"):
        meshmark.read_mesh(tmp_path / "missing.ply")


def test_python_key_detects_through_the_cli(torus, original, tmp_path, cli):
    V, F = torus
    key, marked = meshmark.embed(V, F, message="from python", seed=21)
    key.save(tmp_path / "py.key.json")
    meshmark.write_mesh(tmp_path / "marked.ply", marked, F)
    done = run_cli(cli, "detect", tmp_path / "marked.ply", "--original", original,
                   "--key", tmp_path / "py.key.json", "--json")
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["detected"] is True
    # The same verdict and statistics as in Python, field for field (timings aside).
    mine = meshmark.detect(marked, F, V, F, key).to_dict()
    assert set(mine) == set(report)
    for field in ("score", "false_positive_probability", "bits_found", "bits_expected", "correlation"):
        assert mine[field] == report[field], field
    # And the unmarked original is not claimed.
    assert run_cli(cli, "detect", original, "--original", original, "--key", tmp_path / "py.key.json").returncode == 1


def test_detect_against_file_is_detect_file_for_a_mesh_in_memory(torus, original, tmp_path):
    V, F = torus
    key, marked = meshmark.embed(V, F, seed=8)
    key.save(tmp_path / "k.json")
    moved = marked @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).T * 2.0 + 0.5
    meshmark.write_mesh(tmp_path / "moved.ply", moved, F)
    from_file = meshmark.detect_file(tmp_path / "moved.ply", original, tmp_path / "k.json")
    held = meshmark.detect_against_file(moved, F, original, tmp_path / "k.json")
    assert held.detected and from_file["detected"]
    assert held.score == from_file["score"]
    assert held.to_dict()["registration"]["method"] == from_file["registration"]["method"]
    clean = meshmark.detect_against_file(V, F, original, tmp_path / "k.json")
    assert not clean.detected
    with pytest.raises(meshmark.IoError, match="missing.json"):
        meshmark.detect_against_file(moved, F, original, tmp_path / "missing.json")


def test_cli_key_detects_in_python(torus, original, tmp_path, cli):
    V, F = torus
    done = run_cli(cli, "embed", original, "-o", tmp_path / "cli.ply", "--key", tmp_path / "cli.key.json",
                   "--seed", 33, "--message", "from the cli", "--quiet")
    assert done.returncode == 0, done.stderr
    key = meshmark.Key.load(tmp_path / "cli.key.json")
    assert key.seed == 33 and key.message == "from the cli"
    marked, marked_F = meshmark.read_mesh(tmp_path / "cli.ply")
    assert meshmark.detect(marked, marked_F, V, F, key).detected
    # The in-memory embed with the same seed and options gives the program's bytes and key.
    same_key, same = meshmark.embed(V, F, seed=33, message="from the cli")
    assert np.array_equal(same, marked)
    assert same_key == key


def test_file_reports_match_the_cli(original, tmp_path, cli):
    report = meshmark.embed_file(original, tmp_path / "m.ply", tmp_path / "k.json", seed=4, message="x")
    done = run_cli(cli, "embed", original, "-o", tmp_path / "c.ply", "--key", tmp_path / "c.json",
                   "--seed", 4, "--message", "x", "--json", "--quiet")
    cli_report = json.loads(done.stdout)
    assert set(report) == set(cli_report)
    for field in ("bits", "rms_displacement", "max_displacement", "strength", "vertices", "faces"):
        assert report[field] == cli_report[field], field
    assert report["output"] == str(tmp_path / "m.ply")
    assert (tmp_path / "m.ply").read_bytes() == (tmp_path / "c.ply").read_bytes()
    with pytest.raises(meshmark.InvalidOption, match="already exists"):
        meshmark.embed_file(original, tmp_path / "m2.ply", tmp_path / "k.json", seed=4)
    assert not (tmp_path / "m2.ply").exists()

    found = meshmark.detect_file(tmp_path / "m.ply", original, tmp_path / "k.json")
    cli_found = json.loads(run_cli(cli, "detect", tmp_path / "m.ply", "--original", original,
                                   "--key", tmp_path / "k.json", "--json").stdout)
    assert found["detected"] is True
    assert set(found) == set(cli_found)
    assert found["score"] == cli_found["score"]
    verbose = meshmark.detect_file(tmp_path / "m.ply", original, tmp_path / "k.json", verbose=True)
    assert len(verbose["bit_values"]) == verbose["bit_count"]

    attacked = meshmark.attack(tmp_path / "m.ply", "similarity,noise=0.0005", tmp_path / "a.ply", seed=3)
    cli_attacked = json.loads(run_cli(cli, "attack", tmp_path / "m.ply", "similarity,noise=0.0005",
                                      "-o", tmp_path / "ca.ply", "--seed", 3, "--json", "--quiet").stdout)
    assert set(attacked) == set(cli_attacked)
    assert attacked["transform"] == cli_attacked["transform"] and attacked["spec"] == cli_attacked["spec"]
    assert (tmp_path / "a.ply").read_bytes() == (tmp_path / "ca.ply").read_bytes()
    assert meshmark.detect_file(tmp_path / "a.ply", original, tmp_path / "k.json")["detected"] is True
    with pytest.raises(meshmark.InvalidOption, match="input file"):
        meshmark.attack(tmp_path / "m.ply", "noise", tmp_path / "m.ply")
    with pytest.raises(meshmark.InvalidOption):
        meshmark.attack(tmp_path / "m.ply", "explode=3", tmp_path / "b.ply")

    compared = meshmark.compare(original, tmp_path / "m.ply")
    cli_compared = json.loads(run_cli(cli, "compare", original, tmp_path / "m.ply", "--json").stdout)
    assert set(compared) == set(cli_compared)
    assert set(compared["seconds"]) == set(cli_compared["seconds"])
    for field in ("hausdorff", "rms_ab", "mrms", "max_displacement", "samples", "a", "b"):
        assert compared[field] == cli_compared[field], field
    assert 0.0 < compared["rms_displacement"] < 0.01


def test_file_errors_carry_the_program_message(original, tmp_path, cli):
    with pytest.raises(meshmark.IoError) as error:
        meshmark.detect_file(tmp_path / "nope.ply", original, tmp_path / "k.json")
    done = run_cli(cli, "embed", original, "-o", tmp_path / "x.ply", "--key", original, "--force", check=False)
    assert done.returncode == 2
    with pytest.raises(meshmark.InvalidOption) as error:
        meshmark.embed_file(original, tmp_path / "x.ply", original, force=True)
    assert done.stderr.strip() == f"meshmark: {error.value}"


def test_family_key_from_the_cli_traces_in_python(torus, original, tmp_path, cli):
    """Recipient copies issued by the program are traced in Python: the copies of two
    recipients averaged vertex by vertex accuse one of them and nobody else."""
    V, F = torus
    done = run_cli(cli, "embed", original, "-o", tmp_path / "{recipient}.ply", "--key", tmp_path / "family.json",
                   "--recipient", "ann", "--recipient", "ben", "--recipient", "cat", "--seed", 8, "--quiet")
    assert done.returncode == 0, done.stderr
    key = meshmark.Key.load(tmp_path / "family.json")
    ann, _ = meshmark.read_mesh(tmp_path / "ann.ply")
    cat, _ = meshmark.read_mesh(tmp_path / "cat.ply")
    single = meshmark.detect(ann, F, V, F, key)
    assert single.detected and single.owner_detected
    assert [r["name"] for r in single.recipients] == ["ann"]
    # One verdict: the headline names ann, at the accusation's probability.
    assert single.headline.startswith("Claimed: a copy of the original, made from the copy issued to ann. ")
    assert single.false_positive_probability == single.recipients[0]["false_positive_probability"]
    assert single.to_dict()["headline"] == single.headline
    pooled = meshmark.detect((ann + cat) / 2, F, V, F, key)
    assert pooled.owner_detected
    assert pooled.recipients and {r["name"] for r in pooled.recipients} <= {"ann", "cat"}
    unmarked = meshmark.detect(V, F, V, F, key)
    assert not unmarked.detected and unmarked.recipients == []
    assert unmarked.headline.startswith("Not shown: ")
    assert unmarked.to_dict()["recipients_traced"] == 3


def test_threads_issuing_on_one_key_get_a_code_each_and_key_save_is_one_step(original, tmp_path):
    """Issue 50 through Python: eight threads issue at once on a key none of them finds; one
    key results, every name has its own index, the name all of them issue gets one copy's
    bytes, and each copy names its own recipient. Two saves to one new path: one wins."""
    import concurrent.futures

    key_path = tmp_path / "keys" / "fam.json"  # the folder does not exist yet

    def issue(i):
        return meshmark.embed_recipients(original, str(tmp_path / f"call{i}" / "{recipient}.ply"), key_path,
                                         [f"buyer{i}", "everyone"], seed=100 + i, threads=1)

    with concurrent.futures.ThreadPoolExecutor(max_workers=8) as pool:
        reports = list(pool.map(issue, range(8)))
    assert sum(r["key_created"] for r in reports) == 1
    recipients = json.loads(key_path.read_text())["recipients"]["issued"]
    assert sorted(r["name"] for r in recipients) == sorted([f"buyer{i}" for i in range(8)] + ["everyone"])
    assert len({r["index"] for r in recipients}) == 9
    everyone = (tmp_path / "call0" / "everyone.ply").read_bytes()
    for i in range(1, 8):
        assert (tmp_path / f"call{i}" / "everyone.ply").read_bytes() == everyone
    for i in (0, 7):
        report = meshmark.detect_file(tmp_path / f"call{i}" / f"buyer{i}.ply", original, key_path)
        assert [r["name"] for r in report["recipients"]] == [f"buyer{i}"]

    V, F = meshmark.read_mesh(original)
    keys = [meshmark.embed(V, F, seed=s)[0] for s in (1, 2)]

    def save(key):
        try:
            key.save(tmp_path / "single.json")
            return key.seed
        except meshmark.InvalidOption:
            return None

    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        saved = [s for s in pool.map(save, keys) if s is not None]
    assert len(saved) == 1
    assert meshmark.Key.load(tmp_path / "single.json").seed == saved[0]
