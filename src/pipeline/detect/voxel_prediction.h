// SPDX-License-Identifier: MIT
#pragma once

// A suspect that was voxel-remeshed (Blender's Remesh modifier in Voxel mode, `voxel=N`) is
// read beside the original voxel-remeshed the same way: what the remesh does to the original
// (thin parts thickened, edges rounded, the surface moved to the grid's dual vertices) is most
// of what the suspect shows besides the mark, and it is known without any key
// (docs/algorithms/detection.md, "Voxel-remeshed suspects").

#include <vector>

#include "meshmark/core/triangle_mesh.h"
#include "pipeline/detect/inputs.h"

namespace meshmark::detail
{

struct SuspectInFrame;

/// The original's change under its own voxel remesh, sampled as the suspect's is.
struct VoxelPrediction
{
    const TriangleMesh* original = nullptr;  ///< The mesh remeshed.
    double estimate = 0.0;    ///< The resolution the suspect's edges gave (the cache's key).
    double resolution = 0.0;  ///< Voxels along the original's diagonal (VoxelRemeshingOptions).
    Positions plain;          ///< #V x 3: the closest point of the remeshed original, minus V.
    Positions matched;  ///< The same against the original's surface (match_reference_surface).
};

/// The predictions of one detection, shared by its poses (the remesh does not depend on the
/// pose; only whether it fits does).
using VoxelCache = std::vector<VoxelPrediction>;

/// A voxel remesh's edges are within a factor of about 2 of the voxel (coefficient of variation
/// 0.20-0.29 measured on 24 Blender remeshes of 12 artists' models); a suspect whose edges vary
/// more was not voxel-remeshed (or was re-worked since), and is read as before.
inline constexpr double kVoxelEdgeVariation = 0.40;

/// The prediction is used when it accounts for at least this share of the suspect's change
/// along the original's normals (1 - residual energy / change energy, rows weighted as read).
/// The mark is part of that change, so a fine grid's prediction of a marked copy explains less
/// (0.29-0.85 over those 24 remeshes; never-marked remeshes 0.21-0.99).
inline constexpr double kVoxelExplained = 0.2;

/// \brief The original voxel-remeshed at the resolution the suspect's edges show, when the
/// suspect looks voxel-remeshed and the prediction accounts for its change; null otherwise
/// (not resampled, edges too varied, a resolution out of range, OpenVDB's plugin missing, or
/// the prediction does not fit). Depends on the original and the suspect only, never on a key,
/// so the readings that use it keep the verdict's bound.
/// \details The voxel edge is the suspect's median edge in the original's units (a dual
/// contouring mesh's median edge is the voxel within 8% on the artists' models), then refined
/// once so that the original's remesh has the suspect's vertex count (a count that grows as the
/// resolution squared) unless the suspect is cropped. A remesh is made once per original and
/// resolution and kept in \p cache (the returned pointer points into it).
[[nodiscard]] const VoxelPrediction* predict_voxel_change(const DetectInputs& in,
                                                          const SuspectInFrame& found,
                                                          VoxelCache& cache, int threads);

}  // namespace meshmark::detail
