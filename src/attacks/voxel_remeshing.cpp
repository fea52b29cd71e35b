// SPDX-License-Identifier: MIT
#include "meshmark/attacks/voxel_remeshing.h"

#include <array>
#include <cmath>
#include <new>
#include <string>

#include "attacks/detail/format.h"
#include "attacks/detail/voxel_plugin.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"

namespace meshmark
{

// The OpenVDB part runs in the plugin libmeshmark_voxel.so (voxel_openvdb_plugin.cpp), loaded
// on the first call: see detail/voxel_plugin.h.

void VoxelRemeshingOptions::validate() const
{
    if (!std::isfinite(resolution) || resolution < kLowestResolution ||
        resolution > kHighestResolution)
    {
        throw InvalidOption("voxel: resolution " + detail::format_number(resolution) +
                            " is outside [10, 2000] voxels along the bounding-box diagonal.");
    }
}

TriangleMesh voxel_remesh(const TriangleMesh& mesh, const VoxelRemeshingOptions& options,
                          int threads)
{
    options.validate();
    if (mesh.is_point_cloud())
    {
        throw InvalidMesh("voxel: the mesh has no faces (a point cloud cannot be voxel-remeshed).");
    }
    const double diagonal = bounding_box(mesh.V, referenced_vertices(mesh)).diagonal();
    if (!(diagonal > 0.0))
    {
        throw InvalidMesh("voxel: the faces span no volume (every vertex is at the same point).");
    }
    const double voxel = diagonal / options.resolution;

    // Moved by whole voxels so that the single-precision points are near the origin while the
    // grid cells stay where Blender's would be (aligned to the origin).
    Eigen::RowVector3d shift = Eigen::RowVector3d::Zero();
    if (mesh.V.rows() > 0)
    {
        const Eigen::RowVector3d centre =
            0.5 * (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff());
        shift = (centre / voxel).array().round().matrix() * voxel;
    }

    const detail::VoxelRemeshFunction remesh = detail::voxel_plugin();
    TriangleMesh result;
    std::array<char, 512> message{};
    switch (remesh(&mesh, voxel, shift.data(), resolve_threads(threads), &result, message.data(),
                   message.size()))
    {
        case detail::kVoxelPluginOk:
            break;
        case detail::kVoxelPluginOutOfMemory:
            throw std::bad_alloc();
        default:
            throw Error(std::string("voxel: OpenVDB failed: ") + message.data());
    }
    if (result.F.rows() == 0)
    {
        throw InvalidMesh("voxel: no surface is left at resolution " +
                          detail::format_number(options.resolution) +
                          " (the mesh is thinner than a voxel, or open so that it has no inside).");
    }
    return result;
}

}  // namespace meshmark
