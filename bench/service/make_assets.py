#!/usr/bin/env python3
"""Build the held-out assets of the service benchmarks (load.py, crash.py) and their catalogue.

    make_assets.py --out DIR [--meshmark PATH] [--jobs N]

From the shared meshes (folder $MESHMARK_MESH_DIR, default ../shared/data/meshes beside the
repository) it writes

    DIR/assets/horse.glb   ~48K vertices, written the way a real tool writes a GLB:
                           horse.ply -> OBJ by `meshmark attack horse.ply -o horse.obj reorder`
                           (a random vertex/face permutation, so the file is not the
                           PLY's order), then `gltfpack -i horse.obj -o horse.glb -noq`
    DIR/assets/dragon.ply  a copy of dragon_vrip.ply (437K vertices)
    DIR/catalog.db         `meshmark catalog add DIR/catalog.db DIR/assets -o DIR/published -q`
                           (asset ids: horse.glb, dragon.ply)

Idempotent: a step whose output exists is skipped; `catalog add` is always run (it skips assets
already recorded and finishes an interrupted call). Standard library only.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MESHMARK = os.path.normpath(os.path.join(HERE, "..", "..", "build", "bin", "meshmark"))


def run(cmd):
    print("+ " + " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--meshmark", default=os.environ.get("MESHMARK", DEFAULT_MESHMARK))
    ap.add_argument("--data", default=os.environ.get("MESHMARK_MESH_DIR") or os.environ.get("MESHMARK_DEFAULT_MESH_DIR")
                    or os.path.normpath(os.path.join(HERE, "..", "..", "..", "shared", "data", "meshes")))
    ap.add_argument("--jobs", type=int, default=0, help="catalog add --jobs (0: one per core)")
    args = ap.parse_args()

    out = os.path.abspath(args.out)
    assets = os.path.join(out, "assets")
    os.makedirs(assets, exist_ok=True)
    horse_ply = os.path.join(args.data, "horse.ply")
    dragon_src = os.path.join(args.data, "dragon_vrip.ply")
    for p in (horse_ply, dragon_src):
        if not os.path.isfile(p):
            sys.exit("make_assets: missing shared mesh %s (set MESHMARK_DATA)" % p)
    if shutil.which("gltfpack") is None:
        sys.exit("make_assets: gltfpack not found on PATH (apt-get install meshoptimizer / gltfpack)")

    horse_glb = os.path.join(assets, "horse.glb")
    if not os.path.isfile(horse_glb):
        with tempfile.TemporaryDirectory(prefix="make_assets.") as tmp:
            obj = os.path.join(tmp, "horse.obj")
            run([args.meshmark, "attack", horse_ply, "-o", obj, "reorder", "--seed", "1", "-q"])
            tmp_glb = os.path.join(tmp, "horse.glb")
            run(["gltfpack", "-i", obj, "-o", tmp_glb, "-noq"])
            shutil.move(tmp_glb, horse_glb)  # only a complete file lands in assets/

    dragon = os.path.join(assets, "dragon.ply")
    if not os.path.isfile(dragon):
        tmp = dragon + ".part"
        shutil.copyfile(dragon_src, tmp)
        os.replace(tmp, dragon)

    catalog = os.path.join(out, "catalog.db")
    cmd = [args.meshmark, "catalog", "add", catalog, assets, "-o", os.path.join(out, "published"), "-q"]
    if args.jobs:
        cmd += ["--jobs", str(args.jobs)]
    run(cmd)
    print(catalog)


if __name__ == "__main__":
    main()
