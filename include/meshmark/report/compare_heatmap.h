// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/render/heatmap_image.h"

namespace meshmark
{

/// What a distance heatmap file holds, from its extension.
enum class HeatmapFile
{
    Ply,  ///< the mesh with per-vertex colours
    Png,  ///< a picture of it (render_heatmap)
};

/// \brief The kind of heatmap \p path names: a .ply or a .png file (any case).
/// \param option Names the option in the message ("--heatmap" for the program, "heatmap" for
/// the Python package).
/// \throws InvalidOption for any other extension.
[[nodiscard]] HeatmapFile heatmap_file_kind(const std::filesystem::path& path,
                                            const std::string& option = "--heatmap");

/// \brief The heatmap of `meshmark compare --heatmap` (and of the Python package's compare):
/// \p b coloured by \p distances, one per vertex of \p b (its distance to the other surface),
/// blue at 0 and red at the largest distance of a referenced vertex of \p b.
/// \details A .ply file is \p b with per-vertex colours and float positions (every viewer reads
/// them); a .png file is render_heatmap's picture with \p image's view, size and up axis, its
/// colour bar in % of \p diagonal. Written atomically.
/// \returns The distance drawn in red, in the mesh's units.
/// \throws InvalidOption as heatmap_file_kind and render_heatmap, IoError when it cannot be
/// written.
double write_distance_heatmap(const std::filesystem::path& path, const TriangleMesh& b,
                              const Eigen::VectorXd& distances, HeatmapImageOptions image,
                              double diagonal, int threads);

}  // namespace meshmark
