// SPDX-License-Identifier: MIT
// The glTF cases of the interop suite: each a shared mesh (or the multi-part scene) run through
// one variant of the ecosystem's writers, and its input file, generated into the corpus on
// first use.
#pragma once

#include <algorithm>
#include <ostream>
#include <string>
#include <vector>

#include "interop_support.h"

namespace meshmark::test::interop
{

enum class Source
{
    Gltfpack,       // gltfpack -i MESH.obj -o in.glb FLAGS
    GltfTransform,  // gltf-transform COMMAND... on the `gltfpack -noq -kn` glb (chained)
    GltfPipeline,   // gltf-pipeline -i in.gltf -o in.glb FLAGS, in.gltf from `gltfpack -noq -kn`
    Scene,          // gltf-transform COMMAND... on the multi-part scene (make_scene.mjs)
    SceneGltfpack,  // gltfpack -i scene.glb -o in.glb FLAGS
};

struct Variant
{
    const char* name;
    Source source;
    std::vector<std::vector<std::string>> steps;  // gltfpack / gltf-pipeline flags: steps[0]
    /// Position bits of the grid the tool stored the positions on (0: float32). The tolerance
    /// of the position check is one step of that grid, in world units (see tolerance()).
    int position_bits;
    bool draco;  // point order may change when meshmark re-encodes (edgebreaker)
};

struct GltfCase
{
    std::string mesh;
    Variant variant;
    [[nodiscard]] std::string name() const
    {
        std::string stem = fs::path(mesh).stem().string();
        std::replace(stem.begin(), stem.end(), '-', '_');
        return stem + "_" + variant.name;
    }
};

// gtest prints a test's parameter: the case name, not GltfCase's bytes.
inline void PrintTo(const GltfCase& c, std::ostream* os)
{
    *os << c.name();
}

// The multi-part asset of make_scene.mjs (spot textured under a rotated node with fandisk as its
// scaled child, the bunny instanced by two nodes), as written and after the ecosystem's tools.
// Draco variants are left to the single meshes: their point order changes, and the position
// check would need to tell the second bunny's points from the first's.
inline constexpr const char* kScene = "scene";
inline const std::vector<std::string> kSceneMeshes{"spot.obj", "fandisk.obj", "stanford-bunny.obj"};

/// The glTF cases of the default suite: each shared mesh with each variant (the Stanford
/// bunny with one variant of each compression family only), then the scene's variants.
std::vector<GltfCase> gltf_cases();

/// The bunny with the other variants, the same layouts as spot's and fandisk's on a 35K-vertex
/// mesh: the `slow` label's (tests/interop/CMakeLists.txt), run by `scripts/test.sh --all`.
std::vector<GltfCase> gltf_large_cases();

// The input file of a case (generated on first use).
fs::path case_input(const GltfCase& c, std::string* error);

}  // namespace meshmark::test::interop
