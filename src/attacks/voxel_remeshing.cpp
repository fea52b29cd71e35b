// SPDX-License-Identifier: MIT
#include "meshmark/attacks/voxel_remeshing.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "attacks/detail/format.h"

namespace meshmark {
namespace {

// Half-width of the narrow band, in voxels, on either side of the surface: Blender's value.
// The zero crossing only needs the voxels next to the surface, and a wider band would bridge
// gaps of a few voxels that Blender keeps open.
constexpr float kHalfBandVoxels = 1.0F;

struct Polygons
{
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
};

// Triangles of the extracted polygons, facing outwards: OpenVDB orders the corners clockwise
// seen from outside (negative inside), so each polygon is reversed. A quad is split along its
// shorter diagonal, the one that keeps both triangles closest to the quad.
Faces triangulate(const Polygons& polygons)
{
    Faces faces(static_cast<Eigen::Index>(polygons.triangles.size() + 2 * polygons.quads.size()),
                3);
    Eigen::Index row = 0;
    for (const auto& t : polygons.triangles)
    {
        faces.row(row++) << static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[1]),
            static_cast<std::int32_t>(t[0]);
    }
    const auto& p = polygons.points;
    for (const auto& q : polygons.quads)
    {
        // Reversed: corners a, b, c, d = q0, q3, q2, q1.
        const auto a = static_cast<std::int32_t>(q[0]);
        const auto b = static_cast<std::int32_t>(q[3]);
        const auto c = static_cast<std::int32_t>(q[2]);
        const auto d = static_cast<std::int32_t>(q[1]);
        const double ac = (p[q[0]] - p[q[2]]).lengthSqr();
        const double bd = (p[q[3]] - p[q[1]]).lengthSqr();
        if (ac <= bd)
        {
            faces.row(row++) << a, b, c;
            faces.row(row++) << a, c, d;
        }
        else
        {
            faces.row(row++) << a, b, d;
            faces.row(row++) << b, c, d;
        }
    }
    return faces;
}

}  // namespace

void VoxelRemeshingOptions::validate() const
{
    if (!std::isfinite(resolution) || resolution < 10.0 || resolution > 2000.0)
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

    Polygons input;
    input.points.reserve(static_cast<std::size_t>(mesh.V.rows()));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const Eigen::RowVector3d p = mesh.V.row(i) - shift;
        input.points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                  static_cast<float>(p.z()));
    }
    input.triangles.reserve(static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        input.triangles.emplace_back(static_cast<openvdb::Index32>(mesh.F(f, 0)),
                                     static_cast<openvdb::Index32>(mesh.F(f, 1)),
                                     static_cast<openvdb::Index32>(mesh.F(f, 2)));
    }

    Polygons output;
    openvdb::initialize();
    // TBB never runs more workers than cores and warns on stderr when asked to: capped.
    tbb::task_arena arena(std::min(resolve_threads(threads), tbb::info::default_concurrency()));
    arena.execute([&] {
        const auto transform = openvdb::math::Transform::createLinearTransform(voxel);
        const auto grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(
            *transform, input.points, input.triangles, kHalfBandVoxels);
        openvdb::tools::volumeToMesh(*grid, output.points, output.triangles, output.quads,
                                     /*isovalue=*/0.0, /*adaptivity=*/0.0,
                                     /*relaxDisorientedTriangles=*/false);
    });
    if (output.triangles.empty() && output.quads.empty())
    {
        throw InvalidMesh("voxel: no surface is left at resolution " +
                          detail::format_number(options.resolution) +
                          " (the mesh is thinner than a voxel, or open so that it has no inside).");
    }

    TriangleMesh result;
    result.V.resize(static_cast<Eigen::Index>(output.points.size()), 3);
    for (std::size_t i = 0; i < output.points.size(); ++i)
    {
        const auto& p = output.points[i];
        result.V.row(static_cast<Eigen::Index>(i)) =
            Eigen::RowVector3d(static_cast<double>(p.x()), static_cast<double>(p.y()),
                               static_cast<double>(p.z())) +
            shift;
    }
    result.F = triangulate(output);
    return result;
}

}  // namespace meshmark
