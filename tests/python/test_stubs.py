# SPDX-License-Identifier: MIT
"""The type stubs (meshmark/_meshmark.pyi) against the extension, and the signatures help() shows.

The stubs are written by hand; these tests keep them true: the same public names as the module,
and for every function and method the parameters of the signature pybind11 states (the first
line of its docstring), in the same order, of the same kinds, with a default where it has one.
With mypy installed (Debian's python3-mypy), a small typed program using the package is checked.
"""
import ast
import importlib.util
import pathlib
import pydoc
import re
import subprocess
import sys
import textwrap

import pytest

import meshmark
from meshmark import _meshmark

PACKAGE = pathlib.Path(meshmark.__file__).parent
STUB = PACKAGE / "_meshmark.pyi"


def public(names):
    return {n for n in names if not n.startswith("_")}


def stub_module():
    return ast.parse(STUB.read_text(), filename=str(STUB))


def is_property(node):
    return any(isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list)


def stub_definitions(body):
    """{name: [FunctionDef, ...]} (several for overloads), {name: ClassDef}, {name: annotated}."""
    functions, classes, values = {}, {}, set()
    for node in body:
        if isinstance(node, ast.FunctionDef):
            functions.setdefault(node.name, []).append(node)
        elif isinstance(node, ast.ClassDef):
            classes[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            values.add(node.target.id)
        elif isinstance(node, ast.Assign):
            values.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return functions, classes, values


def parameters(args):
    """[(name, kind, has_default)] of an ast.arguments, kind 'positional' or 'keyword'."""
    positional = args.posonlyargs + args.args
    defaults = [False] * (len(positional) - len(args.defaults)) + [True] * len(args.defaults)
    out = [(a.arg, "positional", d) for a, d in zip(positional, defaults)]
    out += [(a.arg, "keyword", d is not None) for a, d in zip(args.kwonlyargs, args.kw_defaults)]
    assert args.vararg is None and args.kwarg is None
    return out


def runtime_parameters(function):
    """The parameters of the signature on the first line of a pybind11 function's docstring."""
    first = function.__doc__.splitlines()[0]
    assert re.match(r"^\w+\(", first), first
    tree = ast.parse(f"def {first}: ...")
    return parameters(tree.body[0].args)


def check_function(name, runtime, stubs, method=False):
    found = runtime_parameters(runtime)
    if method and found and found[0][0] == "self":
        found = found[1:]
    for stub in stubs:
        expected = parameters(stub.args)
        if method and expected and expected[0][0] in ("self", "cls") and not any(
            isinstance(d, ast.Name) and d.id == "staticmethod" for d in stub.decorator_list
        ):
            expected = expected[1:]
        if len(stubs) > 1:  # overloads: a Literal may make a keyword required in one of them
            assert [p[:2] for p in expected] == [p[:2] for p in found], name
        else:
            assert expected == found, name


def test_the_stub_names_every_public_name_of_the_module_and_no_other():
    functions, classes, values = stub_definitions(stub_module().body)
    stubbed = public(functions) | public(classes) | public(values) | ({"__version__"} & values)
    assert stubbed == public(dir(_meshmark)) | {"__version__"}
    # The package re-exports all of them.
    assert set(meshmark.__all__) == stubbed


def test_every_stubbed_function_has_the_parameters_of_its_signature():
    functions, _, _ = stub_definitions(stub_module().body)
    for name, stubs in functions.items():
        check_function(name, getattr(_meshmark, name), stubs)


def test_every_class_has_the_stubbed_methods_and_properties():
    _, classes, _ = stub_definitions(stub_module().body)
    for name, node in classes.items():
        cls = getattr(_meshmark, name)
        functions, _, values = stub_definitions(node.body)
        if issubclass(cls, Exception):
            assert not public(functions) and not values, name
            assert issubclass(cls, meshmark.Error), name
            continue
        properties = {n for n, defs in functions.items() if any(is_property(d) for d in defs)}
        methods = {n: defs for n, defs in functions.items() if n not in properties}
        runtime = {n for n in vars(cls) if not n.startswith("_")}
        assert public(properties) | public(methods) == runtime, name
        for prop in properties:
            assert isinstance(vars(cls)[prop], property), f"{name}.{prop}"
        for method, defs in methods.items():
            if method.startswith("_") and method != "__init__":
                continue
            check_function(f"{name}.{method}", getattr(cls, method), defs, method=True)


def test_help_shows_real_types_never_handle_or_object():
    text = pydoc.render_doc(meshmark, renderer=pydoc.plaintext)
    for line in text.splitlines():
        assert not re.search(r"\bhandle\b|-> object|: object\b", line), line
    # A few signatures as help() shows them.
    assert "attack(input: str | os.PathLike, spec: str, output: str | os.PathLike, *, seed: int = 0" in text
    assert "detect(V_suspect: numpy.typing.ArrayLike, F_suspect: numpy.typing.ArrayLike | None" in text
    assert "trace: bool = True" in text


def test_the_stubs_and_the_marker_are_beside_the_package():
    assert STUB.is_file()
    assert (PACKAGE / "py.typed").is_file()


TYPED_EXAMPLE = '''
import numpy as np
import numpy.typing as npt
import meshmark

V: npt.NDArray[np.float64] = np.zeros((4, 3))
F = np.array([[0, 1, 2], [0, 2, 3]])
key, marked = meshmark.embed(V, F, message="x", seed=1)
key2, marked2, info = meshmark.embed(V, F, report=True)
seed: int = key.seed
result = meshmark.detect(marked, F, V, F, key, trace=False)
score: float = result.score
report = meshmark.compare("a.ply", "b.ply", heatmap="h.png", view="front")
catalog = meshmark.Catalog("c.sqlite", create=True)
outcomes = catalog.reindex(all=True)
issued = catalog.issue("a", ["ann"], "{recipient}.ply", recipients_file="names.txt")
Vr, Fr = meshmark.read_mesh("a.ply")
try:
    meshmark.detect_file("s.ply", "o.ply", "k.json", trace=False)
except meshmark.Error as error:
    print(error)
'''

TYPED_MISTAKES = '''
import meshmark
meshmark.attack("a.ply", "noise", "b.ply", seed="one")
meshmark.compare("a.ply", "b.ply", heatmap=3)
key = meshmark.Key.load("k.json")
bad: str = key.seed
'''


def run_mypy(tmp_path, source):
    program = tmp_path / "example.py"
    program.write_text(textwrap.dedent(source))
    env = {"MYPYPATH": str(PACKAGE.parent), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "--cache-dir", str(tmp_path / "cache"),
         str(program)],
        capture_output=True, text=True, env=env, cwd=tmp_path)


@pytest.mark.skipif(importlib.util.find_spec("mypy") is None, reason="mypy is not installed (python3-mypy)")
def test_mypy_checks_a_typed_program_against_the_stubs(tmp_path):
    done = run_mypy(tmp_path, TYPED_EXAMPLE)
    assert done.returncode == 0, done.stdout + done.stderr
    wrong = run_mypy(tmp_path, TYPED_MISTAKES)
    assert wrong.returncode == 1, wrong.stdout + wrong.stderr
    assert wrong.stdout.count("error:") == 3, wrong.stdout


@pytest.mark.skipif(importlib.util.find_spec("mypy") is None, reason="mypy is not installed (python3-mypy)")
@pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                    reason="dask.distributed is not installed (python3-distributed)")
def test_mypy_checks_the_cluster_module_against_the_stubs(tmp_path):
    """meshmark.cluster calls the extension's private steps as the stubs declare them."""
    cluster = PACKAGE / "cluster.py"
    env = {"MYPYPATH": str(PACKAGE.parent), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "--cache-dir", str(tmp_path / "cache"),
         "-p", "meshmark.cluster"],
        capture_output=True, text=True, env=env, cwd=tmp_path)
    assert cluster.is_file()
    assert done.returncode == 0, done.stdout + done.stderr
