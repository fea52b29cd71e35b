// SPDX-License-Identifier: MIT
// The pose a viewer shows of an animated glTF scene (gltf_pose.cpp: which animations count,
// every node's matrices and morph weights at a time) and the blend of a primitive's morph
// targets in it (gltf_morph.cpp).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <tiny_gltf.h>

#include "gltf_reader.h"
#include "gltf_scene.h"

namespace meshmark::detail
{

/// \brief The shown pose of an animated asset at one time: every node's local and world matrix
/// and morph weights in it. Empty when nothing is posed (no time asked for, a malformed
/// animation, or nothing moves at that time).
struct ScenePose
{
    std::string name;  ///< "animation 'Run' at 10/24 s" (ShownPose::name).
    std::vector<Eigen::Matrix4d> locals;
    std::vector<Eigen::Matrix4d> globals;
    std::vector<std::vector<double>> weights;

    [[nodiscard]] bool empty() const { return globals.empty(); }
};

/// \brief The span of every animation of \p model that animates a node or morph weights
/// (MeshFile::animations), appended to \p spans; a malformed one is left out. A file whose
/// meshes show a blend of their morph targets that no animation changes gets one more, of no
/// length, past the file's animations: its pose is that blend.
void add_animation_spans(const tinygltf::Model& model, const GltfAccessors& accessors,
                         std::vector<AnimationSpan>& spans);

/// \brief The pose of animation \p animation (one past the file's animations: the stored
/// morph weights) at time \p t, or an empty pose when it is malformed, not finite, moves no
/// node and blends no morph target, or \p animation is further past.
[[nodiscard]] ScenePose scene_pose(const tinygltf::Model& model, const GltfAccessors& accessors,
                                   std::size_t animation, double t);

/// \brief Every node's world matrix from every node's local one, down the forest from each
/// parentless node; a node left unvisited (on a cycle, which walk_scene reports) keeps the
/// identity.
[[nodiscard]] std::vector<Eigen::Matrix4d> world_matrices(
    const tinygltf::Model& model, const std::vector<Eigen::Matrix4d>& locals);

/// \brief \p local (3 per element) with the morph targets of \p prim blended in by the weights
/// \p pose gives node \p node (the specification's base + sum of weight x POSITION delta), or
/// empty when there is no pose or no target with a weight and a readable POSITION of as many
/// elements. \p where names the primitive in messages.
[[nodiscard]] std::vector<double> morphed(const GltfAccessors& accessors, const ScenePose& pose,
                                          int node, const tinygltf::Primitive& prim,
                                          const std::vector<double>& local,
                                          const std::string& where);

}  // namespace meshmark::detail
