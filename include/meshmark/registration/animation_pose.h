// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief The original's mesh at one frame of one of its animations, as the caller's reader
/// poses it (io's ShownPose without io).
struct FramePose
{
    std::string name;  ///< What the pose is, for reports ("animation 'Run' at 1/24 s").
    Positions V;  ///< The original's rows in the pose; empty: the frame does not bend the mesh.
    /// Per row: the linear map taking a displacement near the posed vertex back to the stored
    /// frame.
    std::vector<Eigen::Matrix3d> to_rest;
};

/// \brief An animated original's frames as the search sees them: frames of one animation are
/// consecutive and in time order.
struct AnimationFrames
{
    std::vector<std::size_t> animation;  ///< Per frame: the animation it belongs to.
    std::size_t frame_one = 0;  ///< The frame a copy most likely shows (Blender's frame 1).
    /// Poses the frames listed in `which`: visit(pose, k) once for each k of them.
    std::function<void(const std::vector<std::size_t>& which,
                       const std::function<void(FramePose&&, std::size_t)>& visit)>
        pose;
};

/// The frame a copy fits best (fit_animation_pose).
struct AnimationPoseFit
{
    FramePose pose;                                         ///< That frame's pose of the original.
    Eigen::Matrix4d to_pose = Eigen::Matrix4d::Identity();  ///< Suspect -> the original in it.
};

/// \brief The frame of an animated original a re-posed copy fits best, and the copy registered
/// onto the original in that pose.
/// \details The frames whose principal spread is closest to the copy's and frame_one are
/// registered in full (the coarse stage too, with a quarter to a half of a detection's samples),
/// then the frames next to the best two, started from them; the best (the smallest trimmed RMS
/// residual) is registered again with the full settings. Everything from the original and the
/// copy, nothing from a key: the choice is the same for every key. Nullopt when no frame bends
/// the mesh.
[[nodiscard]] std::optional<AnimationPoseFit> fit_animation_pose(const TriangleMesh& original,
                                                                 const TriangleMesh& suspect,
                                                                 const AnimationFrames& frames,
                                                                 int threads);

/// \brief The copy taken back to the stored frame: registered onto the posed original
/// (AnimationPoseFit::to_pose), each vertex moved back through the pose of the original's
/// vertex nearest to it (FramePose::to_rest). The suspect's triangles.
[[nodiscard]] TriangleMesh unposed(const TriangleMesh& original, const TriangleMesh& suspect,
                                   const AnimationPoseFit& fit);

}  // namespace meshmark
