// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/pipeline/detect_file.h"
#include "meshmark/watermark/watermark.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/detect/voxel_prediction.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// \brief Detection's animated-original stage (phases "poses", "register", "unpose"): a copy of
/// an animated original (in.animated) read again through the frame of its animations it fits
/// best (fit_animation_pose), both readings at twice their false-positive probabilities (a
/// union bound) when some frame bends the mesh.
/// \details Not for a family key, the bits verdict or user point pairs. The frames are
/// Blender's (24 per second, frame 1 of the first animation always among them).
void read_animation_pose(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                         const DetectInputs& in, const DetectFileOptions& options,
                         VoxelCache& voxel_cache);

}  // namespace meshmark::detail
