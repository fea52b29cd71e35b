# SPDX-License-Identifier: MIT
# The command-line contract shared by attacks.py (Blender) and open3d_attacks.py (Open3D):
#   SCRIPT INPUT OUT_DIR [--seed S] OP [OP ...]
# and the OUT_DIR/attacks.json report, written atomically. Plain Python, so both Blender's
# interpreter and the system's import it.
import json
import os


class UsageError(Exception):
    pass


def parse_arguments(args, usage):
    """(source, out_dir, specs, seed) from the arguments after the script's own; checks that
    INPUT is a file and OUT_DIR a folder. The operations themselves are the caller's to parse."""
    args = list(args)
    seed = 0
    if "--seed" in args:
        i = args.index("--seed")
        if i + 1 >= len(args) or not args[i + 1].isdigit():
            raise UsageError("--seed needs a non-negative integer")
        seed = int(args[i + 1])
        del args[i:i + 2]
    if len(args) < 3:
        raise UsageError("usage: " + usage)
    source, out_dir, specs = os.path.abspath(args[0]), os.path.abspath(args[1]), args[2:]
    if not os.path.isfile(source):
        raise UsageError("%s: no such file" % source)
    if not os.path.isdir(out_dir):
        raise UsageError("%s: no such folder" % out_dir)
    return source, out_dir, specs, seed


def write_report(out_dir, report):
    """OUT_DIR/attacks.json: one entry per output written, under a temporary name renamed into place."""
    path = os.path.join(out_dir, "attacks.json")
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        json.dump(report, f, indent=1)
        f.write("\n")
    os.replace(temporary, path)
