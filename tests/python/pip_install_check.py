#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""`pip install` of the package into a fresh virtual environment, offline, then the README's
Python example run by that environment's Python (not the build tree's package).

  pip_install_check.py --python PY --source ROOT [--build-dir DIR] [--system-site-packages]

--python: the Python to make the environment with (default: python3 on PATH).
--build-dir: a CMake build folder the backend builds in (pip's --config-settings build-dir=DIR);
  without it the backend configures a new one under the work folder and builds the library.
--system-site-packages: the environment sees the Python's packages (Debian's numpy).
With numpy in the environment the README's example runs as written (its in.ply a copy of
bun_zipper.ply) and must detect its mark; without it, the file functions embed and detect a
copy and the array functions must say that numpy is missing. Then `pip uninstall` removes every
file. Exit 0 when all held, 1 when not, 77 without the shared meshes or the venv module.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def mesh_dir():
    return Path(os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
                or Path(__file__).resolve().parents[3] / "shared" / "data" / "meshes")


def readme_example(source):
    """The README's Python block (the one after the '- Python' bullet)."""
    text = (source / "README.md").read_text(encoding="utf-8")
    found = re.search(r"^- Python.*?\n```python\n(.*?)```", text, re.S | re.M)
    if not found:
        raise SystemExit("README.md: no ```python block after the '- Python' bullet")
    return found.group(1)


FILE_EXAMPLE = """
import meshmark
meshmark.embed_file("in.ply", "marked.ply", "key.json", message="(c) ACME 2026", seed=42)
report = meshmark.detect_file("marked.ply", "in.ply", "key.json")
assert report["detected"], report
try:
    meshmark.read_mesh("in.ply")
except ImportError as e:
    assert "numpy" in str(e), e
else:
    raise AssertionError("read_mesh worked without numpy")
print("file functions: detected; array functions: numpy asked for")
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--python", default=shutil.which("python3") or sys.executable)
    parser.add_argument("--source", type=Path, default=Path(__file__).resolve().parents[2])
    parser.add_argument("--build-dir", type=Path)
    parser.add_argument("--system-site-packages", action="store_true")
    args = parser.parse_args()
    meshes = mesh_dir()
    if not (meshes / "bun_zipper.ply").exists():
        print(f"pip_install_check: skipped, no bun_zipper.ply in {meshes}", file=sys.stderr)
        return 77
    work = Path(tempfile.mkdtemp(prefix="meshmark-pip-"))
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    try:
        venv = work / "venv"
        made = subprocess.run([args.python, "-m", "venv", *(["--system-site-packages"] if args.system_site_packages
                                                              else []), str(venv)], capture_output=True, text=True)
        if made.returncode != 0:
            print(f"pip_install_check: skipped, {args.python} -m venv failed: {made.stderr.strip()}", file=sys.stderr)
            return 77
        python = venv / "bin" / "python"
        settings = ["--config-settings", f"build-dir={args.build_dir or work / 'build'}"]
        install = subprocess.run([str(python), "-m", "pip", "install", "--no-index", *settings, str(args.source)],
                                 capture_output=True, text=True, env=env)
        if install.returncode != 0:
            print(install.stdout[-3000:], install.stderr[-3000:], sep="\n")
            print("pip_install_check: pip install failed", file=sys.stderr)
            return 1
        run = work / "run"
        run.mkdir()
        shutil.copy(meshes / "bun_zipper.ply", run / "in.ply")
        where = subprocess.run([str(python), "-c", "import meshmark, importlib.util as u; "
                                "print(meshmark.__file__); print(u.find_spec('numpy') is not None)"],
                               capture_output=True, text=True, env=env, cwd=run)
        if where.returncode != 0:
            print(where.stderr)
            return 1
        location, has_numpy = where.stdout.split()
        if not Path(location).resolve().is_relative_to(venv.resolve()):
            print(f"pip_install_check: meshmark imported from {location}, not the environment {venv}")
            return 1
        example = readme_example(args.source) + "\nassert result.detected\nprint('README example: detected')\n" \
            if has_numpy == "True" else FILE_EXAMPLE
        ran = subprocess.run([str(python), "-c", example], capture_output=True, text=True, env=env, cwd=run)
        print(ran.stdout.strip())
        if ran.returncode != 0:
            print(ran.stderr)
            return 1
        removed = subprocess.run([str(python), "-m", "pip", "uninstall", "-y", "meshmark"],
                                 capture_output=True, text=True, env=env)
        left = [p for p in (venv / "lib").glob("python3*/site-packages/meshmark*")]
        if removed.returncode != 0 or left:
            print(f"pip_install_check: uninstall left {left}: {removed.stderr.strip()}")
            return 1
        print(f"pip_install_check: {args.python} installed meshmark into a fresh environment "
              f"({'with' if has_numpy == 'True' else 'without'} numpy) and ran the example")
        return 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
