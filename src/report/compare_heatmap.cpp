// SPDX-License-Identifier: MIT
#include "meshmark/report/compare_heatmap.h"

#include <algorithm>
#include <cctype>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/heatmap.h"

namespace meshmark
{

HeatmapFile heatmap_file_kind(const std::filesystem::path& path, const std::string& option)
{
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".ply")
    {
        return HeatmapFile::Ply;
    }
    if (ext == ".png")
    {
        return HeatmapFile::Png;
    }
    throw InvalidOption(
        "compare: " + option + " " + path.string() +
        " must name a .ply file (the mesh with per-vertex colors) or a .png file (a picture).");
}

double write_distance_heatmap(const std::filesystem::path& path, const TriangleMesh& b,
                              const Eigen::VectorXd& distances, HeatmapImageOptions image,
                              double diagonal, int threads)
{
    if (heatmap_file_kind(path) == HeatmapFile::Png)
    {
        // The same colours on a picture of B, its colour bar in % of A's diagonal.
        image.unit_length = diagonal;
        image.threads = threads;
        const HeatmapPicture picture = render_heatmap(b, distances, image);
        write_png(path, picture.image);
        return picture.max_distance;
    }
    double max_distance = 0.0;
    for (const std::int32_t v : referenced_vertices(b))
    {
        max_distance = std::max(max_distance, distances[v]);
    }
    const std::vector<Rgb8> colors = distance_colors(distances, max_distance);
    // Float positions: the file is for viewing, and every PLY viewer reads float.
    write_mesh(
        path, b,
        WriteOptions{.use_single_precision = true, .vertex_colors = &colors, .link_folder = {}});
    return max_distance;
}

}  // namespace meshmark
