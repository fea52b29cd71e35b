// SPDX-License-Identifier: MIT
// glTF skins: each element of a skinned primitive placed by its blend of joint matrices (joint
// world matrix x inverse bind matrix, weighted), where a viewer shows the scene and into its
// pose; a rig shown in its bind pose is read through its node instead.
#include "io/detail/gltf_skin.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "io/detail/support.h"

namespace meshmark::detail
{

namespace
{

// A skinned primitive whose joints place every vertex within this fraction of its extent of
// where its node's transform does is read through the node (the bind pose): the float32
// rounding of inverse bind matrices leaves ~1e-7 of the extent; keys made before skins were
// applied then still match.
constexpr double kBindPoseTolerance = 1e-6;

}  // namespace

SkinSets skin_sets(const GltfAccessors& accessors, const tinygltf::Primitive& prim)
{
    SkinSets sets;
    for (int set = 0;; ++set)
    {
        const auto j = prim.attributes.find("JOINTS_" + std::to_string(set));
        const auto w = prim.attributes.find("WEIGHTS_" + std::to_string(set));
        if (j == prim.attributes.end() || w == prim.attributes.end())
        {
            return sets;
        }
        sets.joints.push_back(
            accessors.values(j->second, 4, "JOINTS_" + std::to_string(set), true));
        sets.weights.push_back(
            accessors.values(w->second, 4, "WEIGHTS_" + std::to_string(set), false));
    }
}

std::vector<Eigen::Matrix4d> skin_matrices(const SceneFile& file, const SkinSets& sets, int skin,
                                           std::size_t count, const Eigen::Matrix4d& to_world,
                                           const std::vector<Eigen::Matrix4d>& globals)
{
    const tinygltf::Model& model = file.model;
    if (static_cast<std::size_t>(skin) >= model.skins.size())
    {
        fail_io(file.path, "a node refers to missing skin " + std::to_string(skin));
    }
    const auto& s = model.skins[static_cast<std::size_t>(skin)];
    std::vector<double> inverse_binds;
    if (s.inverseBindMatrices >= 0)
    {
        inverse_binds =
            file.accessors.values(s.inverseBindMatrices, 16, "inverseBindMatrices", false);
        if (inverse_binds.size() < 16 * s.joints.size())
        {
            fail_io(file.path, "skin " + std::to_string(skin) +
                                   " has fewer inverse bind matrices than joints");
        }
    }
    std::vector<Eigen::Matrix4d> joint(s.joints.size(), Eigen::Matrix4d::Identity());
    for (std::size_t k = 0; k < s.joints.size(); ++k)
    {
        const int node = s.joints[k];
        if (node < 0 || static_cast<std::size_t>(node) >= model.nodes.size())
        {
            fail_io(file.path, "skin " + std::to_string(skin) + " has joint node " +
                                   std::to_string(node) + " out of range");
        }
        Eigen::Matrix4d inverse_bind = Eigen::Matrix4d::Identity();
        if (!inverse_binds.empty())
        {
            inverse_bind =
                Eigen::Map<const Eigen::Matrix4d>(inverse_binds.data() + 16 * k);  // column-major
        }
        joint[k] = globals[static_cast<std::size_t>(node)] * inverse_bind;
    }
    std::vector<Eigen::Matrix4d> result(count, Eigen::Matrix4d::Zero());
    std::vector<double> total(count, 0.0);
    for (std::size_t set = 0; set < sets.joints.size(); ++set)
    {
        const std::vector<double>& joints = sets.joints[set];
        const std::vector<double>& weights = sets.weights[set];
        if (joints.size() < 4 * count || weights.size() < 4 * count)
        {
            fail_io(file.path, "JOINTS_" + std::to_string(set) + " or WEIGHTS_" +
                                   std::to_string(set) + " has fewer elements than POSITION");
        }
        for (std::size_t e = 0; e < count; ++e)
        {
            for (std::size_t c = 0; c < 4; ++c)
            {
                const double weight = weights[4 * e + c];
                if (weight == 0.0)
                {
                    continue;
                }
                const double index = joints[4 * e + c];
                // (glTF's joints are unsigned; a signed accessor's negative index is refused too)
                if (index < 0.0 || index >= static_cast<double>(joint.size()))
                {
                    fail_io(file.path, "JOINTS_" + std::to_string(set) + " element " +
                                           std::to_string(e) + " refers to joint " +
                                           std::to_string(static_cast<long long>(index)) +
                                           ", but skin " + std::to_string(skin) + " has " +
                                           std::to_string(joint.size()) + " joint(s)");
                }
                result[e] += weight * joint[static_cast<std::size_t>(index)];
                total[e] += weight;
            }
        }
    }
    // Weights that do not sum to 1 are normalized, as Blender's armature and three.js do; an
    // element without weight or whose joints collapse it (no inverse, so no displacement can
    // be written back) keeps the node's transform.
    for (std::size_t e = 0; e < count; ++e)
    {
        if (total[e] > 0.0)
        {
            result[e] /= total[e];
        }
        if (!(total[e] > 0.0) || !result[e].allFinite() ||
            !keeps_volume(result[e].topLeftCorner<3, 3>()))
        {
            result[e] = to_world;
        }
    }
    return result;
}

// Each element by its own blend of joint matrices, in a group of its own (positions of other
// parts that meet it within float rounding are welded to it, its own distinct positions
// never), and into the shown pose. A rig shown in its bind pose under a node placed like it
// (what most exporters write) puts every vertex where the node's transform does, up to the
// float32 rounding of its inverse bind matrices: it is read through the node, to the bit as
// before skins were applied, so that keys made then still match.
std::vector<Eigen::Matrix4d> place_skinned(const SceneFile& file,
                                           const std::vector<Eigen::Matrix4d>& rest_globals,
                                           const ScenePose& pose, const std::vector<double>& local,
                                           const SkinSets& sets, int skin, const Placement& place,
                                           const std::vector<double>& shown,
                                           SceneElements& elements)
{
    const Eigen::Matrix4d& to_world = place.to_world;
    const std::size_t count = local.size() / 3;
    const auto at = [&](std::size_t e)
    { return Eigen::Vector4d(local[3 * e], local[3 * e + 1], local[3 * e + 2], 1.0); };
    std::vector<Eigen::Matrix4d> scene =
        skin_matrices(file, sets, skin, count, to_world, rest_globals);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    double largest = 0.0;
    for (std::size_t e = 0; e < count; ++e)
    {
        const Eigen::Vector3d by_node = (to_world * at(e)).head<3>();
        lo = lo.cwiseMin(by_node);
        hi = hi.cwiseMax(by_node);
        largest = std::max(largest, ((scene[e] * at(e)).head<3>() - by_node).norm());
    }
    if (count == 0 || largest <= kBindPoseTolerance * (hi - lo).norm())
    {
        scene.clear();
    }
    if (!pose.empty())
    {
        // Animated: every element's own way into the pose.
        const std::vector<Eigen::Matrix4d> posed =
            skin_matrices(file, sets, skin, count, place.posed, pose.globals);
        for (std::size_t e = 0; e < count; ++e)
        {
            const Eigen::Vector4d in_pose =
                shown.empty()
                    ? at(e)
                    : Eigen::Vector4d(shown[3 * e], shown[3 * e + 1], shown[3 * e + 2], 1.0);
            elements.add_posed(in_pose, scene.empty() ? to_world : scene[e], posed[e]);
        }
    }
    if (scene.empty())
    {
        elements.append(local, place, elements.group_of(to_world), {}, false);
        return scene;
    }
    const std::int32_t group = elements.new_group(to_world);
    for (std::size_t e = 0; e < count; ++e)
    {
        const Eigen::Vector4d w = scene[e] * at(e);
        elements.world.insert(elements.world.end(), {w.x(), w.y(), w.z()});
        elements.group.push_back(group);
    }
    return scene;
}

}  // namespace meshmark::detail
