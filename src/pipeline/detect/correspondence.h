// SPDX-License-Identifier: MIT
#pragma once

// Detection's correspondence stage: the suspect put in the original's frame, row for row
// (docs/algorithms/detection.md): in the original's vertex order (as it is, renumbered by its
// triangles or where it stands), registered and read vertex for vertex, or registered and
// resampled at the original's vertices.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "meshmark/pipeline/correspondence.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/registration/resampling.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// What the first reading of a copy learns for its other poses (read_symmetric_poses).
struct PoseHints
{
    /// The registration's fit of the other handedness.
    std::optional<Eigen::Matrix4d> other_handedness;
    /// The original's symmetries when they were searched right after the registration, over its
    /// closest-point structure (kept for that, and dropped before the correspondence: about
    /// 150 MB of arrays on a 1M-vertex original).
    std::optional<std::vector<Eigen::Matrix4d>> symmetries;
    /// The copy's vertices were put in the original's order by its triangles alone
    /// (renumbered_by_triangles): like a copy in that order, it has no other pose.
    bool is_numbered_by_triangles = false;
};

/// The suspect in the original's frame, as the readings take it.
struct SuspectInFrame
{
    Correspondence kind = Correspondence::None;
    // What the report states of it.
    Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  ///< Suspect -> original.
    double registration_rms = 0.0;                            ///< RMS distance / the diagonal.
    double cropped_fraction = 0.0;
    double outlier_fraction = 0.0;
    // What the readings read.
    Positions aligned;   ///< Read in order: the original's rows.
    Resampling sampled;  ///< Resampled: the suspect at the original's vertices.
    Eigen::Matrix4d to_original =
        Eigen::Matrix4d::Identity();  ///< Resampled: the registration's transform.
    std::vector<std::uint8_t> kept_rows;
    bool has_kept_rows = false;  ///< Only kept_rows are read.
    bool is_cropped = false;     ///< Resampled and cropped (the code is then read apart).
    double weight_scale = 0.0;   ///< Resampled: the rows' weights (kWeightScale amplitudes).

    [[nodiscard]] bool is_resampled() const noexcept
    {
        return kind == Correspondence::Registered || kind == Correspondence::RegisteredNotConverged;
    }
    [[nodiscard]] const std::vector<std::uint8_t>* kept() const noexcept
    {
        return has_kept_rows ? &kept_rows : nullptr;
    }
    [[nodiscard]] const Positions& points() const noexcept
    {
        return is_resampled() ? sampled.points : aligned;
    }
};

/// \brief The correspondence stage (phases "correspondence", "register", "symmetry").
/// \details Everything geometric (pose, correspondence, crop) is decided against the ORIGINAL,
/// never against the watermarked mesh: that keeps every step before the correlation
/// independent of the key's signs, which is what makes the false-positive bound of the verdict
/// hold for an unmarked suspect (docs/statistics.md).
/// \param amplitude The mark's RMS amplitude (mark_amplitude), the original's units.
/// \param pose      A suspect -> original pose to read in (another pose of a symmetric or
///                  animated original) instead of registering; null: found here.
/// \param hints     Filled for read_symmetric_poses (null: not wanted).
/// \throws InvalidOption when the suspect does not correspond as it is and registration is off.
[[nodiscard]] SuspectInFrame find_correspondence(PhaseTimer& timer, const DetectInputs& in,
                                                 double amplitude, const DetectFileOptions& options,
                                                 const Eigen::Matrix4d* pose, PoseHints* hints);

/// The same triangles over the same vertex numbers: a copy in the original's vertex order.
[[nodiscard]] bool has_same_triangles(const TriangleMesh& a, const TriangleMesh& b);

}  // namespace meshmark::detail
