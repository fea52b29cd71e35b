// SPDX-License-Identifier: MIT
// The interop suite's harness (docs/interop.md): finding the ecosystem's tools and running them,
// the corpus cache the cases' inputs are generated into, and the checks made through the node
// helpers (the Khronos validator, glTF-Transform's reading of positions).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "integration/process_util.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/geometry/closest_point_index.h"

namespace meshmark::test::interop
{

namespace fs = std::filesystem;

// tests/interop: the node helpers and their node_modules (scripts/setup.sh runs npm ci there).
inline const fs::path kInteropDir = MESHMARK_INTEROP_DIR;
// Where the corpus is generated (build tree; wiped at the start of every ctest run).
inline const fs::path kCorpusDir = MESHMARK_INTEROP_CORPUS_DIR;
// Any fixed seed: the "meant" positions are recomputed from the key file, not from the seed.
inline constexpr const char* kSeed = "1414";

// ---------------------------------------------------------------------------------------------
// Tools

/// True when the CI environment variable is set (and not "false" or "0").
bool in_ci();

/// The tools, found once: PATH for the programs, tests/interop/node_modules/.bin for the npm ones
/// (empty paths for the missing ones).
struct Tools
{
    Tools();
    fs::path node;
    fs::path gltfpack;
    fs::path xvfb_run;
    fs::path prusa_slicer;
    fs::path blender;
    fs::path assimp;  // Debian's assimp-utils: converts game formats (X, MD2, COB, ...) to glTF
    fs::path open3d_python;  // Debian's python3 with python3-open3d (/usr/bin/python3)
    fs::path gltf_transform;
    fs::path gltf_pipeline;
};

const Tools& tools();

// Names of the missing tools among \p needed ("" when all are there).
std::string missing_tools(const std::vector<std::string>& needed);

// A missing tool skips the case on a developer's machine, but fails it when CI is set: CI has
// every tool (scripts/setup.sh), so a skip there would silently stop the suite from running.
#define INTEROP_REQUIRE_TOOLS(...)                                                              \
    do                                                                                          \
    {                                                                                           \
        const std::string missing_ = missing_tools({__VA_ARGS__});                              \
        if (!missing_.empty())                                                                  \
        {                                                                                       \
            if (in_ci())                                                                        \
            {                                                                                   \
                GTEST_FAIL() << "missing " << missing_                                          \
                             << " (CI is set: the interop suite must run; "                     \
                                "scripts/setup.sh installs the tools)";                         \
            }                                                                                   \
            GTEST_SKIP() << "missing " << missing_ << " (scripts/setup.sh installs the tools)"; \
        }                                                                                       \
    } while (false)

/// The words joined by spaces, those with a space in single quotes (for messages).
std::string quoted(const std::vector<std::string>& words);

/// The last \p n characters of \p text ("..." before them when cut).
std::string tail(const std::string& text, std::size_t n = 600);

// One run of a tool: its result and a one-line description for messages.
struct ToolRun
{
    CliResult result;
    std::string command;
    [[nodiscard]] bool ok() const { return result.exit_code == 0; }
    [[nodiscard]] std::string describe() const
    {
        return "`" + command + "` exited " + std::to_string(result.exit_code) + ": " +
               tail(result.err.empty() ? result.out : result.err);
    }
};

/// Run the program \p words[0] (a full path) with \p scratch for its captured output.
ToolRun run(std::vector<std::string> words, const fs::path& scratch);

/// Run the meshmark program with \p arguments.
ToolRun meshmark(const std::vector<std::string>& arguments, const fs::path& scratch);

/// Run the node helper \p script of tests/interop with \p arguments.
ToolRun node_helper(const std::string& script, std::vector<std::string> arguments,
                    const fs::path& scratch);

// ---------------------------------------------------------------------------------------------
// The corpus cache

// What a corpus entry was made from: a file's path, size and modification time.
std::string file_stamp(const fs::path& path);

/// \brief The corpus folder \p name, made by \p produce (which fills the folder it is given and
/// returns "" or an error) unless a folder with the same \p stamp is there already. The folder
/// is made beside its final place and renamed into it, under a lock, so a concurrent case
/// waits for it instead of making it again, and a failed or killed run leaves nothing behind.
fs::path corpus_entry(const std::string& name, const std::string& stamp,
                      const std::function<std::string(const fs::path&)>& produce,
                      std::string* error);

// ---------------------------------------------------------------------------------------------
// Checks

struct Validation
{
    int errors = 0;
    int warnings = 0;
    std::string codes;  // {"CODE": count, ...}
    std::string messages;
};

// The Khronos validator's verdict on a file; an error text when it could not run.
Validation validate(const fs::path& file, const fs::path& scratch, std::string* error);

// World positions of every TRIANGLES/POINTS primitive, read by glTF-Transform (read_positions.mjs).
Positions independent_read(const fs::path& file, const fs::path& scratch, std::string* error);

struct Box
{
    Eigen::RowVector3d lo;
    Eigen::RowVector3d hi;
    [[nodiscard]] double diagonal() const { return (hi - lo).norm(); }
    [[nodiscard]] double largest_extent() const { return (hi - lo).maxCoeff(); }
};

Box bounds(const Positions& P);

// A point cloud index (nearest vertex): meshmark's ClosestPointIndex on a mesh without faces
// (nanoflann's kd-tree underneath).
ClosestPointIndex cloud_index(const Positions& P);

}  // namespace meshmark::test::interop
