# SPDX-License-Identifier: MIT
"""The build backend of `pip install .` (PEP 517): builds the extension with the project's CMake
build for the Python that runs pip, and packs it into a wheel.

Written here rather than taken from scikit-build-core or setuptools: those come from the package
index, and `pip install .` must work offline with what scripts/setup.sh installs (CMake, Ninja,
a compiler, the project's -dev packages). The backend needs nothing but the standard library, so
pip's isolated build environment installs nothing.

Config settings (`pip install . --config-settings KEY=VALUE`):
  build-dir  a CMake build folder to build in (default: build-wheel/<python tag> under the
             source tree). An existing one configured for another Python is refused.
  jobs       parallel compile jobs (default: the cores).
The environment variable MESHMARK_WHEEL_BUILD_DIR is read when build-dir is not given.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
NAME = "meshmark"
SUMMARY = "Robust invisible watermarks for 3D meshes (Wu & Kobbelt's spectral method)"
REQUIRES_PYTHON = ">=3.10"
EXTRAS = {"arrays": ["numpy>=1.21"]}  # the in-memory functions take and return numpy arrays


def _version() -> str:
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    found = re.search(r"project\(\s*meshmark\s+VERSION\s+([0-9][0-9.]*)", text)
    if not found:
        raise RuntimeError(f"{ROOT / 'CMakeLists.txt'}: no `project(meshmark VERSION x.y.z)` to read the version from")
    return found.group(1)


def _tag() -> str:
    """This interpreter's wheel tag, e.g. cp311-cp311-linux_x86_64."""
    if sys.implementation.name != "cpython":
        raise RuntimeError(f"meshmark's extension is built for CPython; this is {sys.implementation.name}")
    python = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{python}-{python}-{platform}"


def _metadata() -> str:
    lines = [
        "Metadata-Version: 2.1",
        f"Name: {NAME}",
        f"Version: {_version()}",
        f"Summary: {SUMMARY}",
        "License: MIT",
        f"Requires-Python: {REQUIRES_PYTHON}",
    ]
    for extra, requirements in EXTRAS.items():
        lines.append(f"Provides-Extra: {extra}")
        lines += [f'Requires-Dist: {r}; extra == "{extra}"' for r in requirements]
    readme = ROOT / "README.md"
    lines.append("Description-Content-Type: text/markdown")
    return "\n".join(lines) + "\n\n" + readme.read_text(encoding="utf-8")


def _dist_info() -> str:
    return f"{NAME}-{_version()}.dist-info"


def _cmake_cache(build_dir: Path) -> dict[str, str]:
    cache = build_dir / "CMakeCache.txt"
    values = {}
    if cache.exists():
        for line in cache.read_text(encoding="utf-8", errors="replace").splitlines():
            found = re.match(r"([A-Za-z_0-9]+):[A-Z]+=(.*)", line)
            if found:
                values[found.group(1)] = found.group(2)
    return values


def _run(command: list[str]) -> None:
    print("meshmark_build:", " ".join(command), file=sys.stderr, flush=True)
    subprocess.run(command, check=True, stdout=sys.stderr)


def _build_extension(config_settings: dict | None) -> Path:
    """Configures (when needed) and builds the target meshmark_python; returns the package folder."""
    settings = config_settings or {}
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    given = settings.get("build-dir") or os.environ.get("MESHMARK_WHEEL_BUILD_DIR")
    build_dir = Path(given).resolve() if given else ROOT / "build-wheel" / _tag()
    jobs = str(settings.get("jobs") or os.cpu_count() or 2)
    cache = _cmake_cache(build_dir)
    if cache:
        built_for = cache.get("Python_EXECUTABLE", "")
        if not built_for:
            raise RuntimeError(f"{build_dir}: configured without the Python package; build elsewhere")
        probe = subprocess.run([built_for, "-c", "import sysconfig; print(sysconfig.get_config_var('EXT_SUFFIX'))"],
                               capture_output=True, text=True)
        if probe.returncode != 0 or probe.stdout.strip() != suffix:
            raise RuntimeError(f"{build_dir}: configured for {built_for}, whose extensions are not {suffix}; "
                               "give another build-dir or none")
    else:
        if shutil.which("cmake") is None:
            raise RuntimeError("cmake is not installed (scripts/setup.sh installs what the build needs)")
        configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                     f"-DPython_EXECUTABLE={sys.executable}", "-DMESHMARK_PYTHON=ON",
                     "-DMESHMARK_BUILD_TESTS=OFF", "-DMESHMARK_BUILD_CLI=OFF", "-DMESHMARK_BUILD_BENCH=OFF",
                     "-DMESHMARK_WARNINGS_AS_ERRORS=OFF"]
        if shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        _run(configure)
    _run(["cmake", "--build", str(build_dir), "--target", "meshmark_python", "-j", jobs])
    package = build_dir / "python" / NAME
    if not list(package.glob(f"_meshmark{suffix}")):
        raise RuntimeError(f"{package}: the build left no _meshmark{suffix}")
    return package


def _package_files(package: Path) -> list[tuple[str, Path]]:
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    files = [(f"{NAME}/_meshmark{suffix}", package / f"_meshmark{suffix}")]
    sources = ROOT / "python" / NAME  # the Python files and stubs as written, not as last copied
    for source in sorted(sources.iterdir()):
        if source.is_file() and (source.suffix in (".py", ".pyi") or source.name == "py.typed"):
            files.append((f"{NAME}/{source.name}", source))
    return files


def _record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def get_requires_for_build_wheel(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    info = Path(metadata_directory) / _dist_info()
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text(_metadata(), encoding="utf-8")
    return info.name


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    package = _build_extension(config_settings)
    tag = _tag()
    wheel_name = f"{NAME}-{_version()}-{tag}.whl"
    info = _dist_info()
    contents: list[tuple[str, bytes]] = [(name, path.read_bytes()) for name, path in _package_files(package)]
    contents.append((f"{info}/METADATA", _metadata().encode()))
    contents.append((f"{info}/WHEEL", (f"Wheel-Version: 1.0\nGenerator: meshmark_build {_version()}\n"
                                       f"Root-Is-Purelib: false\nTag: {tag}\n").encode()))
    license_file = ROOT / "LICENSE"
    if license_file.exists():
        contents.append((f"{info}/LICENSE", license_file.read_bytes()))
    record = [_record_line(name, data) for name, data in contents] + [f"{info}/RECORD,,"]
    contents.append((f"{info}/RECORD", ("\n".join(record) + "\n").encode()))
    out = Path(wheel_directory) / wheel_name
    partial = out.with_suffix(".whl.partial")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as wheel:
        for name, data in contents:
            entry = zipfile.ZipInfo(name, date_time=(2000, 1, 1, 0, 0, 0))
            entry.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            entry.compress_type = zipfile.ZIP_DEFLATED
            wheel.writestr(entry, data)
    os.replace(partial, out)
    return wheel_name
