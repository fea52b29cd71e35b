// SPDX-License-Identifier: MIT
// Generated meshes of a chosen vertex count for `meshmark bench speed` and bench/perf.
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark::cli
{

/// \brief A closed, manifold, asymmetric mesh with about \p vertices vertices: a torus grid of
/// rings x sides vertices (sides the largest divisor of \p vertices not above its square root,
/// so the count is exact whenever such a divisor >= 3 exists), deformed by the smooth bumps and
/// radii of lumpy_ellipsoid. Subdivided ellipsoids only reach 10 * 4^s + 2 vertices, which
/// cannot hit 10K / 100K / 1M; a grid can.
/// \throws InvalidOption if \p vertices < 9.
[[nodiscard]] inline TriangleMesh bumpy_torus(std::int64_t vertices)
{
    if (vertices < 9 || vertices > 100'000'000)
    {
        throw InvalidOption("a generated mesh needs 9 to 100000000 vertices, got " +
                            std::to_string(vertices) + ".");
    }
    const auto root = static_cast<std::int64_t>(std::sqrt(static_cast<double>(vertices)));
    std::int64_t sides = root;
    while (sides >= 3 && vertices % sides != 0)
    {
        --sides;
    }
    if (sides < 3 || vertices / sides > 50 * sides)
    {
        sides = root;  // no usable divisor: nearest grid below the requested count
    }
    const std::int64_t rings = vertices / sides;
    TriangleMesh mesh = torus(1.0, 0.35, static_cast<int>(rings), static_cast<int>(sides));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const double x = mesh.V(i, 0);
        const double y = mesh.V(i, 1);
        const double z = mesh.V(i, 2);
        const double bump = 1.0 + 0.12 * std::sin(3.0 * x + 1.0) * std::cos(2.0 * y - 0.5) +
                            0.08 * std::sin(5.0 * z + 2.0 * x);
        mesh.V.row(i) = Eigen::RowVector3d(1.0 * x, 0.7 * y, 0.45 * z) * bump;
    }
    return mesh;
}

/// The folder `meshmark bench` reads meshes from by default: $MESHMARK_MESH_DIR if set and
/// not empty, else ../shared/data/meshes.
[[nodiscard]] inline std::filesystem::path default_mesh_dir()
{
    if (const char* env = std::getenv("MESHMARK_MESH_DIR"); env != nullptr && *env != '\0')
    {
        return env;
    }
    return std::filesystem::path("..") / "shared" / "data" / "meshes";
}

/// The mesh files (.ply .obj .off .stl, any case) directly in \p dir, sorted by file name;
/// empty if \p dir is not a directory.
[[nodiscard]] inline std::vector<std::filesystem::path> mesh_files_in(
    const std::filesystem::path& dir)
{
    std::vector<std::filesystem::path> paths;
    std::error_code error;
    if (!std::filesystem::is_directory(dir, error))
    {
        return paths;
    }
    for (const auto& entry : std::filesystem::directory_iterator(dir))
    {
        std::string ext = entry.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (entry.is_regular_file() &&
            (ext == ".ply" || ext == ".obj" || ext == ".off" || ext == ".stl"))
        {
            paths.push_back(entry.path());
        }
    }
    std::sort(paths.begin(), paths.end(),
              [](const auto& a, const auto& b) { return a.filename() < b.filename(); });
    return paths;
}

}  // namespace meshmark::cli
