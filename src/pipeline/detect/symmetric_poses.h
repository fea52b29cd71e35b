// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/pipeline/detect_file.h"
#include "meshmark/watermark/watermark.h"
#include "pipeline/detect/correspondence.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/detect/voxel_prediction.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// \brief Detection's other-poses stage: a copy of a symmetric original read in every pose the
/// original's symmetries (self_symmetries) and the registration's other handedness relate, the
/// verdict the best reading's at k times its false-positive probabilities for k readings (a
/// union bound: docs/statistics.md, "Several poses").
/// \details Not for a copy read by index (in the original's order, or put in it by its
/// triangles), nor with the bits verdict. Stops at the first pose that settles the question
/// (someone accused, or a single-owner mark found).
void read_symmetric_poses(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                          const DetectInputs& in, const DetectFileOptions& options,
                          const PoseHints& hints, VoxelCache& voxel_cache);

}  // namespace meshmark::detail
