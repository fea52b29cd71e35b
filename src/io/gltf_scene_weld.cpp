// SPDX-License-Identifier: MIT
// The glTF scene's elements welded into the one mesh meshmark marks (coincident world-space
// vertices of different transform groups joined), the welded vertices handed to the asset's
// records for the writer, and the shown pose kept per welded vertex.
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "io/detail/gltf_pose.h"
#include "io/detail/gltf_scene.h"
#include "io/detail/support.h"
#include "io/detail/weld.h"

namespace meshmark::detail
{

namespace
{

// A pose that one similarity of the stored positions fits within this fraction of its extent
// only moves the asset as a whole (float32 rounding of the posed matrices leaves ~1e-7), and
// registration undoes it anyway: it is not kept.
constexpr double kSimilarityPoseTolerance = 1e-6;

// The shown pose of every welded vertex (its first element's), kept in \p asset unless the pose
// only moves the asset as a whole.
void keep_pose(const SceneElements& elements, const ScenePose& scene_pose, double time,
               const std::vector<std::int32_t>& welded, const std::vector<double>& xyz,
               GltfAsset& asset)
{
    const std::size_t n = xyz.size() / 3;
    ShownPose pose;
    pose.name = scene_pose.name;
    pose.time = time;
    pose.V.resize(static_cast<Eigen::Index>(n), 3);
    pose.to_rest.assign(n, Eigen::Matrix3d::Identity());
    std::vector<char> is_set(n, 0);
    for (std::size_t e = 0; e < welded.size(); ++e)
    {
        const auto v = static_cast<std::size_t>(welded[e]);
        if (is_set[v] == 0)
        {
            is_set[v] = 1;
            pose.V.row(static_cast<Eigen::Index>(v)) << elements.posed_world[3 * e],
                elements.posed_world[3 * e + 1], elements.posed_world[3 * e + 2];
            pose.to_rest[v] = elements.to_rest[e];
        }
    }
    if (n < 3 || !pose.V.allFinite())
    {
        return;
    }
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic>> rest(
        xyz.data(), 3, static_cast<Eigen::Index>(n));
    const Eigen::Matrix<double, 3, Eigen::Dynamic> posed = pose.V.transpose();
    const Eigen::Matrix4d similarity = Eigen::umeyama(rest, posed, true);
    const Eigen::Matrix<double, 3, Eigen::Dynamic> fitted =
        (similarity.topLeftCorner<3, 3>() * rest).colwise() + similarity.topRightCorner<3, 1>();
    const double extent = (posed.rowwise().maxCoeff() - posed.rowwise().minCoeff()).norm();
    if ((fitted - posed).colwise().norm().maxCoeff() <= kSimilarityPoseTolerance * extent)
    {
        return;
    }
    asset.pose = std::move(pose);
}

std::size_t element_count(const GltfPositionAccessor& record)
{
    return record.elements.size();
}

std::size_t element_count(const GltfDracoPrimitive& record)
{
    return record.welded.size();  // (sized to its Draco points when it was read)
}

}  // namespace

TriangleMesh weld_scene(const std::filesystem::path& path, const SceneElements& elements,
                        const RecordStarts& starts, const ScenePose& pose,
                        std::optional<double> animation_time, GltfAsset& asset)
{
    if (elements.size() > kMaxVertices)
    {
        fail_io(path, "the asset has more than " + std::to_string(kMaxVertices) + " vertices");
    }
    if (animation_time)
    {
        // Only the pose is wanted (for_each_animation_pose): the welding is the same at every time.
        if (asset.pose_welded.size() != elements.size())
        {
            asset.pose_welded =
                weld_world_positions(elements.world, elements.group, elements.groups.size(),
                                     kCrossTransformWeldRel, asset.pose_rest);
        }
        if (!pose.empty())
        {
            keep_pose(elements, pose, *animation_time, asset.pose_welded, asset.pose_rest, asset);
        }
        return TriangleMesh{};
    }
    std::vector<double> xyz;
    const auto welded = weld_world_positions(elements.world, elements.group, elements.groups.size(),
                                             kCrossTransformWeldRel, xyz);

    // Hand the welded ids to the records (the same for both stores), then build the mesh.
    const auto hand_over = [&](auto& records, const std::vector<std::size_t>& first)
    {
        for (std::size_t s = 0; s < records.size(); ++s)
        {
            const std::size_t count = element_count(records[s]);
            const auto from = welded.begin() + static_cast<std::ptrdiff_t>(first[s]);
            records[s].welded.assign(from, from + static_cast<std::ptrdiff_t>(count));
        }
    };
    hand_over(asset.accessors, starts.accessors);
    hand_over(asset.draco, starts.draco);
    if (!elements.instance_xyz.empty())
    {
        asset.instances = make_mesh(elements.instance_xyz, elements.instance_corners);
    }
    TriangleBuffer triangles;
    triangles.reserve(elements.corners.size() / 3);
    for (std::size_t t = 0; t + 2 < elements.corners.size(); t += 3)
    {
        triangles.push(welded[elements.corners[t]], welded[elements.corners[t + 1]],
                       welded[elements.corners[t + 2]]);
    }
    return make_mesh(xyz, triangles);
}

}  // namespace meshmark::detail
