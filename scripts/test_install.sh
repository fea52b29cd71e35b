#!/usr/bin/env bash
# Installed-package check (issue 7): install meshmark from a build folder into a temporary
# prefix, then configure, build and run examples/library against it with find_package(meshmark)
# -- a program outside meshmark's build, as a user would write one. Checks: the installed
# files, that every installed header compiles alone, that the example's verdicts are right on
# a generated mesh and on a shared mesh, and that the installed CLI detects the example's mark.
# Usage: scripts/test_install.sh [BUILD_DIR]   (default ./build, already built)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
work=$(realpath -m "$build/install-test")
prefix=$work/prefix
mesh_dir=${MESHMARK_MESH_DIR:-../shared/data/meshes}
start=$(date +%s)

fail() { echo "test_install.sh: FAILED: $*" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$prefix" >"$work/install.log"

# What must be there: headers, module libraries, package files, the program.
[[ -x $prefix/bin/meshmark ]] || fail "bin/meshmark was not installed"
config=$(find "$prefix" -name meshmarkConfig.cmake -print -quit)
[[ -n $config ]] || fail "meshmarkConfig.cmake was not installed"
for f in meshmarkConfigVersion.cmake meshmarkTargets.cmake; do
    [[ -f $(dirname "$config")/$f ]] || fail "$f was not installed"
done
for module in core io geometry basis watermark render pipeline; do
    [[ -n $(find "$prefix" -name "libmeshmark_$module.a" -print -quit) ]] ||
        fail "libmeshmark_$module.a was not installed"
done
[[ -f $prefix/include/meshmark/pipeline/embed_file.h ]] || fail "headers were not installed"
headers=$(find "$prefix/include/meshmark" -name '*.h' | wc -l)
[[ $headers -eq $(find include/meshmark -name '*.h' | wc -l) ]] || fail "header count differs"

# The voxel remeshing's OpenVDB plugin: installed under <libdir>/meshmark/, not linked by the
# program, and the one the installed program loads (glibc's LD_DEBUG=files names every object
# opened) when it runs a voxel attack from the fresh prefix.
plugin=$(find "$prefix" -path '*/meshmark/libmeshmark_voxel.so' -print -quit)
[[ -n $plugin ]] || fail "lib/meshmark/libmeshmark_voxel.so was not installed"
if ldd "$prefix/bin/meshmark" | grep -qE 'openvdb|tbb|blosc'; then
    fail "bin/meshmark links OpenVDB/TBB (they belong in the plugin only)"
fi
LD_DEBUG=files "$prefix/bin/meshmark" attack tests/data/cube.off -o "$work/voxel.ply" -q voxel=40 \
    2>"$work/voxel.log" ||
    { grep -v '^ *[0-9]*:' "$work/voxel.log"; fail "the installed meshmark's voxel attack"; }
grep -q "file=$plugin " "$work/voxel.log" ||
    fail "the installed meshmark did not load $plugin but:" \
        "$(grep -o 'file=[^ ]*libmeshmark_voxel[^ ]*' "$work/voxel.log" | head -1)"
[[ -s $work/voxel.ply ]] || fail "the voxel attack wrote nothing"
echo "test_install.sh: the installed meshmark ran voxel=40 with $plugin"

# Build the example against the prefix only (no access to the source tree's build).
cmake -S examples/library -B "$work/example" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >"$work/configure.log" ||
    { cat "$work/configure.log"; fail "configuring the example"; }
found=$(sed -n 's/^meshmark_DIR:PATH=//p' "$work/example/CMakeCache.txt")
[[ $found == "$prefix"/* ]] || fail "the example found meshmark at $found, not in $prefix"
cmake --build "$work/example" -j "$(nproc 2>/dev/null || echo 2)" >"$work/build.log" ||
    { tail -50 "$work/build.log"; fail "building the example"; }

# Run it: on a generated mesh, then on a shared one when the meshes are there.
run_example() {
    local name=$1; shift
    if ! "$work/example/meshmark_example" "$@" "$work/$name" >"$work/$name.log" 2>&1; then
        cat "$work/$name.log"; fail "the example on $name"
    fi
    grep -q '^marked copy: detected=yes' "$work/$name.log" || fail "$name: mark not found"
    grep -q '^original: detected=no' "$work/$name.log" || fail "$name: original claimed"
    grep -q '^OK$' "$work/$name.log" || fail "$name: wrong verdict"
    # The installed program reads the library's key and finds the mark (exit 0 = found).
    local marked
    marked=$(find "$work/$name" -maxdepth 1 -name 'marked.*' -print -quit)
    "$prefix/bin/meshmark" detect "$marked" --original "${1:-$work/$name/generated.ply}" \
        --key "$work/$name/example.key.json" --quiet ||
        fail "$name: the installed meshmark did not detect the example's mark"
    echo "test_install.sh: $name: $(grep -c detected=yes "$work/$name.log") of 3 verdicts 'detected', as expected"
}
run_example generated
if [[ -f $mesh_dir/bunny.off ]]; then
    run_example shared_bunny "$mesh_dir/bunny.off"
else
    echo "test_install.sh: $mesh_dir/bunny.off missing; shared-mesh run skipped"
fi
# The Python package and the Blender add-on, when this build made them (MESHMARK_PYTHON): the
# package imported from the prefix alone, a numpy round trip, and its key read by the installed
# program (and the program's key by the package).
if grep -q '^MESHMARK_PYTHON:BOOL=ON' "$build/CMakeCache.txt"; then
    python=$(sed -n 's/^_\{0,1\}Python_EXECUTABLE:[A-Z]*=//p' "$build/CMakeCache.txt" | head -1)
    site=$prefix/lib/python3/dist-packages
    [[ -f $site/meshmark/__init__.py ]] || fail "the Python package was not installed in $site"
    ls "$site"/meshmark/_meshmark*.so >/dev/null 2>&1 || fail "the _meshmark extension was not installed"
    [[ -f $site/meshmark/_meshmark.pyi && -f $site/meshmark/py.typed ]] ||
        fail "the type stubs (_meshmark.pyi, py.typed) were not installed"
    [[ -f $prefix/share/meshmark/blender/meshmark_blender/__init__.py ]] || fail "the Blender add-on was not installed"
    [[ -f $prefix/share/meshmark/blender/meshmark_blender.zip ]] || fail "the Blender add-on zip was not installed"
    mkdir -p "$work/python"
    (cd "$work/python" && PYTHONPATH=$site "$python" - "$site" "$work/generated/generated.ply" <<'PY') ||
import sys, meshmark
assert meshmark.__file__.startswith(sys.argv[1]), meshmark.__file__
V, F = meshmark.read_mesh(sys.argv[2])
key, marked = meshmark.embed(V, F, seed=5, message="installed")
assert meshmark.detect(marked, F, V, F, key).detected
assert not meshmark.detect(V, F, V, F, key).detected
key.save("py.key.json")
meshmark.write_mesh("marked.ply", marked, F)
try:
    meshmark.embed(V[:, :2], F)
    raise SystemExit("a bad array did not raise")
except meshmark.InvalidMesh:
    pass
PY
        fail "the installed Python package"
    "$prefix/bin/meshmark" detect "$work/python/marked.ply" --original "$work/generated/generated.ply" \
        --key "$work/python/py.key.json" --quiet || fail "the installed meshmark did not detect the package's mark"
    PYTHONPATH=$site "$python" -c 'import sys, meshmark
k = meshmark.Key.load(sys.argv[1]); V, F = meshmark.read_mesh(sys.argv[2]); M, _ = meshmark.read_mesh(sys.argv[3])
assert meshmark.detect(M, F, V, F, k).detected' "$work/generated/example.key.json" \
        "$work/generated/generated.ply" "$(find "$work/generated" -maxdepth 1 -name 'marked.*' -print -quit)" ||
        fail "the installed package did not detect the example's mark with its key"
    echo "test_install.sh: Python package and Blender add-on installed; numpy round trip and keys shared with the program"
fi
echo "test_install.sh: OK ($headers headers, $(($(date +%s) - start)) s)"
