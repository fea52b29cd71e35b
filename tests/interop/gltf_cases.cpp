// SPDX-License-Identifier: MIT
// The glTF cases (gltf_cases.h): the variants, and the making of each case's input with
// gltfpack, glTF-Transform, gltf-pipeline and make_scene.mjs.
#include "gltf_cases.h"

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "support/test_paths.h"

namespace meshmark::test::interop
{
namespace
{

// Position grids (L = the largest extent of the asset's bounding box in world units, as read by
// glTF-Transform; every corpus asset has one primitive, so this is the primitive's extent):
// - gltfpack (default, -c, -cc, -kn): 14-bit positions (-vp 14), stored as unnormalized
//   integers 0..16383 over the scene's bounds, the node scale L / 16383: a step L / (2^14 - 1).
//   -c / -cc add EXT_meshopt_compression (lossless on the quantized integers).
// - gltf-transform quantize (and meshopt / optimize, which quantize first): 14 bits over the
//   mesh's bounds mapped to [-1, 1] in normalized SHORTs; the tool's grid is (L / 2) / 16383, the
//   SHORT storage (L / 2) / 32767. We allow one 14-bit step over the extent, L / (2^14 - 1):
//   twice the tool's grid, and at least 9x below the watermark's RMS surface distance (5.9e-4 D).
// - gltf-transform draco: Draco's 14-bit position quantization over the primitive's largest
//   extent, step L / (2^14 - 1). quantize then draco: Draco stores the normalized SHORTs
//   losslessly, so the grid is quantize's (14 bits).
// - gltf-pipeline -d: Draco with 11-bit positions (its default), step L / (2^11 - 1).
// - float32 (-noq, weld, reorder, simplify): no grid; float32 rounding of T^-1 p, allowed as
//   1e-6 of the diagonal in the position check (gltf_interop_test.cpp; also added to every
//   quantized tolerance for the node transform).
const std::vector<Variant>& variants()
{
    static const std::vector<Variant> list{
        {"gltfpack", Source::Gltfpack, {{}}, 14, false},
        {"gltfpack_c", Source::Gltfpack, {{"-c"}}, 14, false},
        {"gltfpack_cc", Source::Gltfpack, {{"-cc"}}, 14, false},
        {"gltfpack_noq", Source::Gltfpack, {{"-noq"}}, 0, false},
        {"gltfpack_kn", Source::Gltfpack, {{"-kn"}}, 14, false},
        {"gt_quantize", Source::GltfTransform, {{"quantize"}}, 14, false},
        {"gt_draco", Source::GltfTransform, {{"draco"}}, 14, true},
        {"gt_meshopt", Source::GltfTransform, {{"meshopt"}}, 14, false},
        {"gt_optimize", Source::GltfTransform, {{"optimize"}}, 14, false},
        {"gt_weld", Source::GltfTransform, {{"weld"}}, 0, false},
        {"gt_reorder", Source::GltfTransform, {{"reorder"}}, 0, false},
        {"gt_simplify", Source::GltfTransform, {{"simplify", "--ratio", "0.5"}}, 0, false},
        {"gt_quantize_draco", Source::GltfTransform, {{"quantize"}, {"draco"}}, 14, true},
        {"gltfpipeline_draco", Source::GltfPipeline, {{"-d"}}, 11, true},
    };
    return list;
}

const std::vector<std::string>& meshes()
{
    // spot: 2.9K vertices with UVs (a game asset); the Stanford bunny: 35K; fandisk: hard edges.
    static const std::vector<std::string> list{"spot.obj", "stanford-bunny.obj", "fandisk.obj"};
    return list;
}

const std::vector<Variant>& scene_variants()
{
    static const std::vector<Variant> list{
        {"plain", Source::Scene, {}, 0, false},
        {"gltfpack", Source::SceneGltfpack, {{}}, 14, false},
        {"gltfpack_cc", Source::SceneGltfpack, {{"-cc"}}, 14, false},
        {"gt_quantize", Source::Scene, {{"quantize"}}, 14, false},
        {"gt_meshopt", Source::Scene, {{"meshopt"}}, 14, false},
        {"gt_optimize", Source::Scene, {{"optimize"}}, 14, false},
    };
    return list;
}

// `gltfpack -noq -kn` of a mesh as .glb or .gltf (+ .bin): the float input of the
// glTF-Transform and gltf-pipeline variants.
fs::path float_base(const fs::path& mesh, const std::string& extension, std::string* error)
{
    const std::string name = mesh.stem().string() + ".noq_kn" + extension;
    const std::vector<std::string> flags{"-noq", "-kn"};
    const std::string stamp =
        "gltfpack -noq -kn\n" + file_stamp(mesh) + file_stamp(tools().gltfpack);
    const fs::path folder = corpus_entry(
        name, stamp,
        [&](const fs::path& staging)
        {
            const ToolRun r = run({tools().gltfpack.string(), "-i", mesh.string(), "-o",
                                   (staging / ("in" + extension)).string(), "-noq", "-kn"},
                                  staging);
            return r.ok() ? std::string{} : r.describe();
        },
        error);
    return folder.empty() ? fs::path{} : folder / ("in" + extension);
}

// The scene of make_scene.mjs from the float bases of kSceneMeshes.
fs::path scene_base(std::string* error)
{
    std::vector<std::string> words{tools().node.string(),
                                   (kInteropDir / "make_scene.mjs").string()};
    std::string stamp = "make_scene\n" + file_stamp(kInteropDir / "make_scene.mjs");
    for (const auto& mesh : kSceneMeshes)
    {
        const fs::path base = float_base(mesh_dir() / mesh, ".glb", error);
        if (base.empty())
        {
            return {};
        }
        words.push_back(base.string());
        stamp += file_stamp(base);
    }
    const fs::path folder = corpus_entry(
        "scene_base", stamp,
        [&](const fs::path& staging)
        {
            std::vector<std::string> command = words;
            command.push_back((staging / "in.glb").string());
            const ToolRun r = run(command, staging);
            return r.ok() ? std::string{} : r.describe();
        },
        error);
    return folder.empty() ? fs::path{} : folder / "in.glb";
}

// The bunny in the default suite: one variant of each compression family (gltfpack's
// quantized default, Draco, meshopt); the others are gltf_large_cases'.
constexpr const char* kLargeMesh = "stanford-bunny.obj";
bool is_large_only(const std::string& mesh, const Variant& variant)
{
    static const std::vector<std::string> kept{"gltfpack", "gt_draco", "gt_meshopt"};
    return mesh == kLargeMesh && std::find(kept.begin(), kept.end(), variant.name) == kept.end();
}

std::vector<GltfCase> mesh_cases(bool large_only)
{
    std::vector<GltfCase> cases;
    for (const auto& mesh : meshes())
    {
        for (const auto& variant : variants())
        {
            if (is_large_only(mesh, variant) == large_only)
            {
                cases.push_back({mesh, variant});
            }
        }
    }
    return cases;
}

}  // namespace

std::vector<GltfCase> gltf_cases()
{
    std::vector<GltfCase> cases = mesh_cases(false);
    for (const auto& variant : scene_variants())
    {
        cases.push_back({kScene, variant});
    }
    return cases;
}

std::vector<GltfCase> gltf_large_cases()
{
    return mesh_cases(true);
}

fs::path case_input(const GltfCase& c, std::string* error)
{
    const fs::path mesh = c.mesh == kScene ? scene_base(error) : mesh_dir() / c.mesh;
    if (mesh.empty())
    {
        return {};
    }
    const Tools& t = tools();
    std::string stamp = c.name() + "\n" + file_stamp(mesh);
    for (const auto& step : c.variant.steps)
    {
        stamp += quoted(step) + "\n";
    }
    std::function<std::string(const fs::path&)> produce;
    switch (c.variant.source)
    {
        case Source::Gltfpack:
        case Source::SceneGltfpack:
            stamp += file_stamp(t.gltfpack);
            produce = [&](const fs::path& staging)
            {
                std::vector<std::string> words{t.gltfpack.string(), "-i", mesh.string(), "-o",
                                               (staging / "in.glb").string()};
                words.insert(words.end(), c.variant.steps[0].begin(), c.variant.steps[0].end());
                const ToolRun r = run(words, staging);
                return r.ok() ? std::string{} : r.describe();
            };
            break;
        case Source::GltfTransform:
        case Source::Scene:
        {
            const fs::path base =
                c.variant.source == Source::Scene ? mesh : float_base(mesh, ".glb", error);
            if (base.empty())
            {
                return {};
            }
            stamp += file_stamp(base) + file_stamp(t.gltf_transform);
            produce = [&, base](const fs::path& staging)
            {
                fs::path from = base;
                if (c.variant.steps.empty())
                {
                    fs::copy_file(base, staging / "in.glb");
                }
                for (std::size_t i = 0; i < c.variant.steps.size(); ++i)
                {
                    const fs::path to = staging / (i + 1 == c.variant.steps.size()
                                                       ? "in.glb"
                                                       : "step" + std::to_string(i) + ".glb");
                    std::vector<std::string> words{t.gltf_transform.string(), c.variant.steps[i][0],
                                                   from.string(), to.string()};
                    words.insert(words.end(), c.variant.steps[i].begin() + 1,
                                 c.variant.steps[i].end());
                    const ToolRun r = run(words, staging);
                    if (!r.ok())
                    {
                        return r.describe();
                    }
                    from = to;
                }
                return std::string{};
            };
            break;
        }
        case Source::GltfPipeline:
        {
            const fs::path base = float_base(mesh, ".gltf", error);
            if (base.empty())
            {
                return {};
            }
            stamp += file_stamp(base) + file_stamp(t.gltf_pipeline);
            produce = [&, base](const fs::path& staging)
            {
                std::vector<std::string> words{t.gltf_pipeline.string(), "-i", base.string(), "-o",
                                               (staging / "in.glb").string()};
                words.insert(words.end(), c.variant.steps[0].begin(), c.variant.steps[0].end());
                const ToolRun r = run(words, staging);
                return r.ok() ? std::string{} : r.describe();
            };
            break;
        }
    }
    const fs::path folder = corpus_entry(c.name(), stamp, produce, error);
    return folder.empty() ? fs::path{} : folder / "in.glb";
}

}  // namespace meshmark::test::interop
