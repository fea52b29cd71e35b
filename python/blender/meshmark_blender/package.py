# SPDX-License-Identifier: MIT
"""Finding the meshmark Python package from inside Blender.

Blender ignores PYTHONPATH, so the package is looked for, in order: where Python already finds
it (e.g. a /usr prefix), the add-on preference "Python package folder", $MESHMARK_PYTHONPATH,
the prefix the add-on was installed into (<prefix>/share/meshmark/blender/meshmark_blender ->
<prefix>/lib/python3/dist-packages), and the folders recorded when it was built (_paths.py).
"""
import importlib
import os
import sys

_ADDON_DIR = os.path.dirname(os.path.abspath(__file__))


def _candidates():
    try:
        import bpy

        prefs = bpy.context.preferences.addons[__package__].preferences
        if prefs.package_path:
            yield bpy.path.abspath(prefs.package_path)
    except (AttributeError, KeyError, ImportError):
        pass
    env = os.environ.get("MESHMARK_PYTHONPATH")
    if env:
        yield from env.split(os.pathsep)
    yield os.path.normpath(os.path.join(_ADDON_DIR, "..", "..", "..", "..", "lib", "python3", "dist-packages"))
    try:
        from . import _paths

        yield from _paths.PACKAGE_DIRS
    except ImportError:
        pass


def import_meshmark():
    """The meshmark module; ImportError with the folders tried when it is nowhere."""
    try:
        return importlib.import_module("meshmark")
    except ImportError:
        pass
    tried = []
    for folder in _candidates():
        if not folder or folder in tried:
            continue
        tried.append(folder)
        if os.path.isfile(os.path.join(folder, "meshmark", "__init__.py")):
            if folder not in sys.path:
                sys.path.insert(0, folder)
            sys.modules.pop("meshmark", None)
            return importlib.import_module("meshmark")
    raise ImportError(
        "the meshmark Python package was not found (tried " + (", ".join(tried) or "nothing") +
        "); set the add-on's 'Python package folder' preference or $MESHMARK_PYTHONPATH."
    )


def status():
    """One line for the preferences: where the package is, or why it is not found."""
    try:
        module = import_meshmark()
        return f"meshmark {module.__version__} from {os.path.dirname(module.__file__)}"
    except ImportError as error:
        return str(error)
