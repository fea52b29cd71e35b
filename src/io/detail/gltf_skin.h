// SPDX-License-Identifier: MIT
// glTF skins (gltf_skin.cpp): each element of a skinned primitive placed by its blend of joint
// matrices, where a viewer shows it, or through its node when the rig is shown in its bind pose.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <tiny_gltf.h>

#include "gltf_pose.h"
#include "gltf_reader.h"
#include "gltf_scene.h"

namespace meshmark::detail
{

/// JOINTS_n and WEIGHTS_n of a skinned primitive, set by set, 4 values per element.
struct SkinSets
{
    std::vector<std::vector<double>> joints;
    std::vector<std::vector<double>> weights;
};

/// The JOINTS_n / WEIGHTS_n accessors of \p prim, set by set while both are there.
[[nodiscard]] SkinSets skin_sets(const GltfAccessors& accessors, const tinygltf::Primitive& prim);

/// \brief Per element (\p count), the blend of the joint matrices of skin \p skin by \p sets,
/// the joints' nodes at \p globals (weights normalized; an element without weight, or whose
/// joints collapse it, keeps \p to_world). Errors (a missing skin or joint, too few elements)
/// name the file.
[[nodiscard]] std::vector<Eigen::Matrix4d> skin_matrices(
    const SceneFile& file, const SkinSets& sets, int skin, std::size_t count,
    const Eigen::Matrix4d& to_world, const std::vector<Eigen::Matrix4d>& globals);

/// \brief A skinned primitive's elements (\p local, 3 per element) appended to \p elements,
/// placed where a viewer shows the scene (the joints at \p rest_globals, every node's stored
/// world matrix), and into \p pose (as \p shown when not empty). Returns each element's matrix,
/// or nothing when the rig is shown in its bind pose under a node placed like it (the elements
/// are then read through the node, GltfPositionAccessor::skinning).
[[nodiscard]] std::vector<Eigen::Matrix4d> place_skinned(
    const SceneFile& file, const std::vector<Eigen::Matrix4d>& rest_globals, const ScenePose& pose,
    const std::vector<double>& local, const SkinSets& sets, int skin, const Placement& place,
    const std::vector<double>& shown, SceneElements& elements);

}  // namespace meshmark::detail
