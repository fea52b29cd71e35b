// SPDX-License-Identifier: MIT
#pragma once

// A suspect that was voxel-remeshed (Blender's Remesh modifier in Voxel mode, `voxel=N`) is
// read beside the original voxel-remeshed the same way: what the remesh does to the original
// (thin parts thickened, edges rounded, the surface moved to the grid's dual vertices) is most
// of what the suspect shows besides the mark, and it is known without any key
// (docs/algorithms/detection.md, "Voxel-remeshed suspects").

#include <deque>

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
/// pose; only whether it fits does). A deque: a prediction in use stays where it is.
using VoxelCache = std::deque<VoxelPrediction>;

/// A voxel remesh's edges are within a factor of about 2 of the voxel (coefficient of variation
/// 0.20-0.29 measured on 24 Blender remeshes of 12 artists' models); a suspect whose edges vary
/// more was not voxel-remeshed (or was re-worked since), and is read as before.
inline constexpr double kVoxelEdgeVariation = 0.40;

/// A voxel-remeshed copy registered on its original lies within a voxel or so of it (RMS
/// distance 0.06-1.3 voxels on those 24 remeshes); a suspect registered farther is not the
/// original's remesh (another asset tried by a catalogue scan), and no remesh is made for it.
inline constexpr double kVoxelReach = 3.0;

/// The prediction is used when it accounts for at least this share of the suspect's change
/// along the original's normals (1 - residual energy / change energy, rows weighted as read).
/// The mark is part of that change, so a fine grid's prediction of a marked copy explains less
/// (0.29-0.85 over those 24 remeshes; never-marked remeshes 0.21-0.99).
inline constexpr double kVoxelExplained = 0.2;

/// \brief The original voxel-remeshed at the resolution a suspect's edges show, made only when
/// asked for (the first reading of a clear copy claims without it).
/// \details Depends on the original and the suspect only, never on a key, so the readings that
/// use it keep the verdict's bound. The voxel edge is the suspect's median edge in the
/// original's units (a dual contouring mesh's median edge is the voxel within 8% on the
/// artists' models), then refined once so that the original's remesh has the suspect's vertex
/// count (a count that grows about as the resolution squared) unless the suspect is cropped. A
/// remesh is made once per original and resolution and kept in the cache, which the poses of
/// one detection share.
class VoxelPredictor
{
public:
    /// \param enabled  DetectFileOptions::predict_voxel. All references must outlive this.
    VoxelPredictor(const DetectInputs& in, const SuspectInFrame& found, VoxelCache& cache,
                   int threads, bool enabled);

    /// The suspect is resampled, its edges look voxel-remeshed at a resolution in range, and it
    /// lies within kVoxelReach voxels of the original: a prediction may be used (cheap: no
    /// remesh is made).
    [[nodiscard]] bool is_possible() const noexcept { return estimate_ > 0.0; }

    /// The prediction, made on the first call: null unless is_possible() and the prediction
    /// accounts for the suspect's change (kVoxelExplained), and OpenVDB's plugin is there.
    [[nodiscard]] const VoxelPrediction* prediction();

    /// The prediction made and used, or null (prediction() never called, or null).
    [[nodiscard]] const VoxelPrediction* used() const noexcept { return used_; }

private:
    const DetectInputs* in_;
    const SuspectInFrame* found_;
    VoxelCache* cache_;
    int threads_;
    double estimate_ = 0.0;  // 0: not possible
    bool asked_ = false;
    const VoxelPrediction* used_ = nullptr;
};

}  // namespace meshmark::detail
