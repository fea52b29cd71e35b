// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/pipeline/detect_file.h"
#include "meshmark/watermark/watermark.h"
#include "pipeline/detect/correspondence.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/detect/voxel_prediction.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// \brief One reading of the copy: correspondence (find_correspondence), the owner's readings
/// (read_owner_mark) and verdict (decide_owner), then with a family key the codes and the
/// tracing, into \p reading (a fresh one).
/// \param pose  A suspect -> original pose to read in instead of the one found (other poses);
///              null: found here.
/// \param hints Filled for read_symmetric_poses (null: not wanted).
/// \param voxel_cache The original's voxel remeshes made so far by this detection's poses
///              (predict_voxel_change).
void read_in_pose(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                  const DetectInputs& in, const DetectFileOptions& options,
                  const Eigen::Matrix4d* pose, PoseHints* hints, VoxelCache& voxel_cache);

}  // namespace meshmark::detail
