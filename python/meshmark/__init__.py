# SPDX-License-Identifier: MIT
"""meshmark: robust invisible watermarks for 3D meshes, on numpy arrays.

In memory (numpy arrays in and out)::

    import meshmark
    key, marked = meshmark.embed(V, F, message="(c) studio", seed=42)
    key.save("model.key.json")
    result = meshmark.detect(marked, F, V, F, key)
    result.detected, result.score, result.false_positive_probability, result.to_dict()

V is an (n, 3) array of positions, F an (m, 3) array of vertex indices or None for a point
cloud. The file functions embed_file, embed_recipients (one traceable copy per recipient),
detect_file, attack and compare do what the meshmark program's commands do and return its
--json report as a dict; the key file is the same.
detect_against_file looks in a mesh in memory with the original and the key as files (the
original's instances and animation used as detect_file uses them).
compare writes the program's heatmap (heatmap="b.png" or "b.ply"); trace=False is detect's
--no-trace; Catalog wraps `meshmark catalog` (add, list, issue, scan, reindex).
Errors are meshmark.Error subclasses (IoError, InvalidMesh, InvalidOption, NumericalError)
carrying the program's one-sentence message. The signatures in help() and the type stubs
(_meshmark.pyi, with py.typed) give every type. See docs/library.md, "Python".
"""

from ._meshmark import (
    Catalog,
    DetectResult,
    Error,
    InvalidMesh,
    InvalidOption,
    IoError,
    Key,
    NumericalError,
    __version__,
    attack,
    attack_mesh,
    compare,
    detect,
    detect_against_file,
    detect_file,
    embed,
    embed_file,
    embed_recipients,
    read_mesh,
    write_mesh,
)

__all__ = [
    "Catalog",
    "DetectResult",
    "Error",
    "InvalidMesh",
    "InvalidOption",
    "IoError",
    "Key",
    "NumericalError",
    "__version__",
    "attack",
    "attack_mesh",
    "compare",
    "detect",
    "detect_against_file",
    "detect_file",
    "embed",
    "embed_file",
    "embed_recipients",
    "read_mesh",
    "write_mesh",
]

# Without numpy (`pip install meshmark[arrays]` or `pip install numpy` adds it) the file and
# catalogue functions work; the functions on arrays say what is missing when called, instead of
# failing inside the extension on its first array.
import importlib.util as _importlib_util

if _importlib_util.find_spec("numpy") is None:
    import functools as _functools
    from typing import Any as _Any
    from typing import Callable as _Callable
    from typing import NoReturn as _NoReturn

    def _needs_numpy(function: _Callable[..., _Any]) -> _Callable[..., _Any]:
        @_functools.wraps(function)
        def refuse(*args: _Any, **kwargs: _Any) -> _NoReturn:
            import sys

            raise ImportError(
                f"meshmark.{function.__name__} works on numpy arrays and numpy is not installed for "
                f"{sys.executable}: pip install numpy (or meshmark[arrays]); the file and catalogue "
                "functions work without it."
            )

        return refuse

    for _name in ("embed", "detect", "detect_against_file", "attack_mesh", "read_mesh", "write_mesh"):
        globals()[_name] = _needs_numpy(globals()[_name])
    del _name, _needs_numpy, _functools, _Any, _Callable, _NoReturn
del _importlib_util

# Shown as meshmark.Error, meshmark.Key, ... in tracebacks and help(), where users import them.
for _name in ("Catalog", "DetectResult", "Error", "InvalidMesh", "InvalidOption", "IoError", "Key", "NumericalError"):
    globals()[_name].__module__ = __name__
del _name
