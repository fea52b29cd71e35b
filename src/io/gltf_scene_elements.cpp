// SPDX-License-Identifier: MIT
// The glTF scene's elements before welding: world positions in transform groups, their place
// in the shown pose with the way back, and the other instances kept aside.
#include <cstdint>
#include <vector>

#include "io/detail/gltf_scene.h"

namespace meshmark::detail
{

std::int32_t SceneElements::group_of(const Eigen::Matrix4d& to_world)
{
    for (std::size_t g = 0; g < groups.size(); ++g)
    {
        if (same_matrix(groups[g], to_world))
        {
            return static_cast<std::int32_t>(g);
        }
    }
    return new_group(to_world);
}

std::int32_t SceneElements::new_group(const Eigen::Matrix4d& to_world)
{
    groups.push_back(to_world);
    return static_cast<std::int32_t>(groups.size() - 1);
}

void SceneElements::append(const std::vector<double>& local, const Placement& place,
                           std::int32_t in_group, const std::vector<double>& shown, bool with_pose)
{
    const std::size_t n = local.size() / 3;
    const std::vector<double>& in_pose = shown.empty() ? local : shown;
    for (std::size_t i = 0; i < n; ++i)
    {
        const Eigen::Vector4d p(local[3 * i], local[3 * i + 1], local[3 * i + 2], 1.0);
        const Eigen::Vector4d w = place.to_world * p;
        world.insert(world.end(), {w.x(), w.y(), w.z()});
        group.push_back(in_group);
        if (with_pose && is_posed)
        {
            add_posed(Eigen::Vector4d(in_pose[3 * i], in_pose[3 * i + 1], in_pose[3 * i + 2], 1.0),
                      place.to_world, place.posed);
        }
    }
}

void SceneElements::add_posed(const Eigen::Vector4d& local, const Eigen::Matrix4d& rest,
                              const Eigen::Matrix4d& posed)
{
    const Eigen::Vector4d w = posed * local;
    posed_world.insert(posed_world.end(), {w.x(), w.y(), w.z()});
    const Eigen::Matrix3d p = posed.topLeftCorner<3, 3>();
    // A part the pose collapses (zero scale) has no way back: its displacements read as noise.
    to_rest.push_back(keeps_volume(p) ? Eigen::Matrix3d(rest.topLeftCorner<3, 3>() * p.inverse())
                                      : Eigen::Matrix3d::Identity());
}

std::size_t SceneElements::add_instance(std::size_t first, std::size_t count,
                                        const Eigen::Matrix4d& from, const Eigen::Matrix4d& to)
{
    const Eigen::Matrix4d map = to * from.inverse();
    const std::size_t base = instance_xyz.size() / 3;
    for (std::size_t e = first; e < first + count; ++e)
    {
        const Eigen::Vector4d p(world[3 * e], world[3 * e + 1], world[3 * e + 2], 1.0);
        const Eigen::Vector4d q = map * p;
        instance_xyz.insert(instance_xyz.end(), {q.x(), q.y(), q.z()});
    }
    return base;
}

}  // namespace meshmark::detail
