// SPDX-License-Identifier: MIT
// Helpers of the interop suite's real-asset cases (real_assets_*_test.cpp, docs/interop.md):
// the models of Debian's assimp-testmodels converted, marked, attacked in Blender and checked.
#pragma once
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "interop_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::test::interop
{
inline const fs::path kModels = "/usr/share/assimp/models";

inline nlohmann::json detect_json(const fs::path& suspect, const fs::path& original,
                                  const fs::path& key, const fs::path& scratch, int* exit_code)
{
    const ToolRun detect = meshmark({"detect", suspect.string(), "--original", original.string(),
                                     "--key", key.string(), "--json"},
                                    scratch);
    *exit_code = detect.result.exit_code;
    return nlohmann::json::parse(detect.result.out, nullptr, false);
}

// Largest and RMS distance from each point of \p A to the nearest point of \p B, over the
// diagonal of A's bounding box (an order-free comparison: a Draco encoder reorders vertices).
inline std::pair<double, double> nearest_distances(const Positions& A, const Positions& B)
{
    const ClosestPointIndex index = cloud_index(B);
    double worst = 0.0;
    double squares = 0.0;
    for (const ClosestPoint& c : index.closest(A))
    {
        worst = std::max(worst, c.distance);
        squares += c.distance * c.distance;
    }
    const double diagonal = bounds(A).diagonal();
    return {worst / diagonal, std::sqrt(squares / static_cast<double>(A.rows())) / diagonal};
}

// `meshmark embed ORIGINAL -o MARKED --key KEY --seed SEED -q`.
inline ToolRun embed(const fs::path& original, const fs::path& marked, const fs::path& key,
                     const std::string& seed, const fs::path& scratch,
                     const std::vector<std::string>& options = {})
{
    std::vector<std::string> words = {"embed", original.string(), "-o",     marked.string(),
                                      "--key", key.string(),      "--seed", seed,
                                      "-q"};
    words.insert(words.end(), options.begin(), options.end());
    return meshmark(words, scratch);
}

// Blender runs the re-work bench's operations \p ops on \p input, writing into \p out.
inline ToolRun blender_attacks(const fs::path& input, const fs::path& out,
                               const std::vector<std::string>& ops, const fs::path& scratch)
{
    fs::create_directories(out);
    std::vector<std::string> words = {
        tools().blender.string(),
        "-b",
        "--factory-startup",
        "--python-exit-code",
        "2",
        "--python",
        (fs::path(MESHMARK_BENCH_BLENDER_DIR) / "attacks.py").string(),
        "--",
        input.string(),
        out.string(),
        "--seed",
        "1"};
    words.insert(words.end(), ops.begin(), ops.end());
    return run(words, scratch);
}

// bench/blender/make_game_asset.py's model \p kind, made by Blender into \p scratch / KIND.glb
// and marked (marked.glb, key.json) with \p seed and the embed \p options; \p error is set if a
// step fails.
struct MarkedGameAsset
{
    fs::path original;
    fs::path marked;
    fs::path key;
};
inline MarkedGameAsset make_and_mark_game_asset(const std::string& kind, const std::string& seed,
                                                const std::vector<std::string>& options,
                                                const fs::path& scratch, std::string* error)
{
    MarkedGameAsset asset{scratch / (kind + ".glb"), scratch / "marked.glb", scratch / "key.json"};
    const ToolRun making =
        run({tools().blender.string(), "-b", "--factory-startup", "--python-exit-code", "2",
             "--python", (fs::path(MESHMARK_BENCH_BLENDER_DIR) / "make_game_asset.py").string(),
             "--", asset.original.string(), kind},
            scratch);
    const ToolRun marking =
        making.ok() ? embed(asset.original, asset.marked, asset.key, seed, scratch, options)
                    : making;
    if (!marking.ok())
    {
        *error = marking.describe();
    }
    return asset;
}

// Blender's re-work operation \p op on \p marked and on \p original, each result (\p output in
// the operation's folder) detected against \p original with \p key; \p check gets each report, its
// exit code and whether it came from the marked copy.
inline void check_marked_and_clean(
    const fs::path& original, const fs::path& marked, const fs::path& key, const std::string& op,
    const std::string& output, const fs::path& scratch,
    const std::function<void(const nlohmann::json&, int, bool)>& check)
{
    for (const auto& [input, folder] :
         {std::pair{marked, scratch / "marked"}, std::pair{original, scratch / "clean"}})
    {
        const ToolRun blender = blender_attacks(input, folder, {op}, scratch);
        ASSERT_TRUE(blender.ok()) << blender.describe();
        int exit_code = -1;
        const nlohmann::json report =
            detect_json(folder / output, original, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << folder;
        check(report, exit_code, input == marked);
    }
}

// `assimp export MODEL OUT -tri -jiv`: a model of assimp-testmodels as .glb.
inline ToolRun assimp_to_glb(const fs::path& model, const fs::path& out, const fs::path& scratch)
{
    return run({tools().assimp.string(), "export", model.string(), out.string(), "-tri", "-jiv"},
               scratch);
}

// The uniform scale of the registration's transform in a `detect --json` report.
inline double registration_scale(const nlohmann::json& report)
{
    const auto& T = report["registration"]["transform"];
    return std::hypot(T[0][0].get<double>(), T[1][0].get<double>(), T[2][0].get<double>());
}

// A model of assimp-testmodels converted to \p scratch / \p name (.glb) and marked with key
// seed 1 into scratch / marked.glb and scratch / key.json; empty when a step failed (the
// failure recorded in \p error).
struct ConvertedAndMarked
{
    fs::path original;
    fs::path marked;
    fs::path key;
};

inline ConvertedAndMarked convert_and_mark(const fs::path& model, const std::string& name,
                                           const fs::path& scratch, std::string* error)
{
    ConvertedAndMarked files{scratch / name, scratch / "marked.glb", scratch / "key.json"};
    const ToolRun convert = assimp_to_glb(kModels / model, files.original, scratch);
    if (!convert.ok() || !fs::exists(files.original))
    {
        *error = convert.describe();
        return {};
    }
    const ToolRun marking = embed(files.original, files.marked, files.key, "1", scratch);
    if (!marking.ok())
    {
        *error = marking.describe();
        return {};
    }
    return files;
}

// \p model converted to \p name and marked (convert_and_mark), then the marked copy and the
// unmarked original each written by Blender's PLY writer: the marked copy is claimed with
// z >= 9, the unmarked one is not.
// \p operation: one of bench/blender/attacks.py's, whose output is a PLY ("ply", "pose=F");
// \p method, when given: the marked copy's registration.method.
inline void expect_blender_ply_copy_claimed(const fs::path& model, const std::string& name,
                                            const fs::path& scratch,
                                            const std::string& operation = "ply",
                                            const std::string& method = "")
{
    std::string output = operation;
    std::replace(output.begin(), output.end(), '=', '_');
    std::string error;
    const auto [original, marked, key] = convert_and_mark(model, name, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    for (const auto& [input, folder] :
         {std::pair{marked, scratch / "marked"}, std::pair{original, scratch / "clean"}})
    {
        const ToolRun blender = blender_attacks(input, folder, {operation}, scratch);
        ASSERT_TRUE(blender.ok()) << blender.describe();
        int exit_code = -1;
        const nlohmann::json report =
            detect_json(folder / (output + ".ply"), original, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << folder;
        if (input == marked)
        {
            EXPECT_EQ(exit_code, 0) << report.dump();
            EXPECT_GE(report.value("score", 0.0), 9.0) << report.dump();
            if (!method.empty())
            {
                EXPECT_EQ(report["registration"].value("method", ""), method) << report.dump();
            }
        }
        else
        {
            EXPECT_EQ(exit_code, 1) << report.dump();
        }
    }
}

}  // namespace meshmark::test::interop
