// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace meshmark::test
{

/// Folder of the tiny hand-written fixtures (tests/data).
[[nodiscard]] std::filesystem::path data_dir();

/// Folder of the shared real meshes: $MESHMARK_MESH_DIR if set, else ../shared/data/meshes
/// next to the source tree.
[[nodiscard]] std::filesystem::path mesh_dir();

/// Every mesh file in mesh_dir() (sorted by name); empty if the folder is missing.
[[nodiscard]] std::vector<std::filesystem::path> shared_meshes();

/// Shared meshes with at most \p max_vertices vertices according to SOURCES.md's table
/// (the dragon at 437K is left out of quick tests this way).
[[nodiscard]] std::vector<std::filesystem::path> shared_meshes_up_to(long max_vertices);

/// Path of the built meshmark program (empty if the CLI is not built).
[[nodiscard]] std::filesystem::path cli_path();

/// A fresh empty temporary folder, removed when the process exits normally (kept when
/// MESHMARK_KEEP_TEST_DIRS is set).
[[nodiscard]] std::filesystem::path temp_dir(const std::string& name);

/// The whole file as bytes ("" if it cannot be read).
inline std::string file_bytes(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

}  // namespace meshmark::test
