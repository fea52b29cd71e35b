# SPDX-License-Identifier: MIT
"""Runs blender_addon_test.py in headless Blender (label `interop`); exit 77 (skip) without Blender.

Usage: run_blender_test.py ADDON_ZIP WORK_DIR. Blender gets an empty user-scripts folder inside
WORK_DIR, so installing the add-on's zip there leaves the user's Blender alone.
"""
import os
import shutil
import subprocess
import sys

blender = os.environ.get("BLENDER") or shutil.which("blender")
if not blender:
    print("blender not found; test skipped")
    sys.exit(77)
addon_zip, work = sys.argv[1], sys.argv[2]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(os.path.join(work, "scripts"))
env = dict(os.environ, BLENDER_USER_SCRIPTS=os.path.join(work, "scripts"),
           BLENDER_USER_CONFIG=os.path.join(work, "config"))
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_addon_test.py")
done = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script,
                       "--", addon_zip, work], env=env, timeout=600)
sys.exit(done.returncode)
