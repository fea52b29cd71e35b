// SPDX-License-Identifier: MIT
// libmeshmark_voxel.so: the OpenVDB half of the voxel remeshing, loaded by the attacks library
// with dlopen on first use (detail/voxel_plugin.h says why). Its only exported symbol is the
// entry point; no exception leaves it.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <new>
#include <type_traits>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include "attacks/detail/voxel_plugin.h"

namespace meshmark
{
namespace
{

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

void remesh(const TriangleMesh& mesh, double voxel, const Eigen::RowVector3d& shift, int threads,
            TriangleMesh& result)
{
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
    tbb::task_arena arena(std::min(threads, tbb::info::default_concurrency()));
    arena.execute(
        [&]
        {
            const auto transform = openvdb::math::Transform::createLinearTransform(voxel);
            const auto grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(
                *transform, input.points, input.triangles, kHalfBandVoxels);
            openvdb::tools::volumeToMesh(*grid, output.points, output.triangles, output.quads,
                                         /*isovalue=*/0.0, /*adaptivity=*/0.0,
                                         /*relaxDisorientedTriangles=*/false);
        });

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
}

void copy_message(const char* text, char* message, std::size_t message_size) noexcept
{
    if (message == nullptr || message_size == 0)
    {
        return;
    }
    const std::size_t n = std::min(std::strlen(text), message_size - 1);
    std::memcpy(message, text, n);
    message[n] = '\0';
}

}  // namespace
}  // namespace meshmark

// The entry point (signature: detail::VoxelRemeshFunction). The static_assert keeps the
// definition and the loader's function type the same.
extern "C" __attribute__((visibility("default"))) int meshmark_voxel_remesh_v1(
    const meshmark::TriangleMesh* mesh, double voxel, const double* shift, int threads,
    meshmark::TriangleMesh* result, char* message, std::size_t message_size) noexcept
{
    try
    {
        meshmark::remesh(*mesh, voxel, Eigen::RowVector3d(shift[0], shift[1], shift[2]), threads,
                         *result);
        return meshmark::detail::kVoxelPluginOk;
    }
    catch (const std::bad_alloc&)
    {
        meshmark::copy_message("out of memory", message, message_size);
        return meshmark::detail::kVoxelPluginOutOfMemory;
    }
    catch (const std::exception& e)
    {
        meshmark::copy_message(e.what(), message, message_size);
        return meshmark::detail::kVoxelPluginFailed;
    }
    catch (...)
    {
        meshmark::copy_message("unknown exception", message, message_size);
        return meshmark::detail::kVoxelPluginFailed;
    }
}
static_assert(
    std::is_same_v<decltype(&meshmark_voxel_remesh_v1), meshmark::detail::VoxelRemeshFunction>);
