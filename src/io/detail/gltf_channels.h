// SPDX-License-Identifier: MIT
// The glTF reader's view of animation channels (gltf_animation.cpp): what a channel animates
// and how many numbers it sets, shared by the sampling of poses and the test of whether an
// animation moves only the whole asset (gltf_whole_motion.cpp).
#pragma once

#include <tiny_gltf.h>

namespace meshmark::detail
{

// What a channel animates: a node's translation, rotation or scale, a mesh's morph weights, or
// something meshmark does not read (a pointer extension's path).
enum class ChannelPath
{
    Translation,
    Rotation,
    Scale,
    Weights,
    Other
};

/// What \p channel animates.
[[nodiscard]] ChannelPath path_of(const tinygltf::AnimationChannel& channel);

/// \brief The numbers a channel of \p a sets on its node (3: translation or scale, 4: rotation,
/// one per morph target: weights), or 0 for a channel that is not read.
[[nodiscard]] int channel_components(const tinygltf::Model& model, const tinygltf::Animation& a,
                                     const tinygltf::AnimationChannel& channel);

}  // namespace meshmark::detail
