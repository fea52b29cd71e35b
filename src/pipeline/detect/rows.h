// SPDX-License-Identifier: MIT
#pragma once

// Which of the original's rows a reading uses, and the mark's amplitude they are measured in
// (detection's row selection: docs/algorithms/detection.md, "Rows left out").

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/watermark/key.h"

namespace meshmark::detail
{

// The far-rows rule's floor, in mark amplitudes (mark_amplitude): 10 x 0.059% = 0.59% of the
// diagonal at the defaults. A copy that only carries the mark (distances of the order of the
// strength) loses no row. Also the reach of the vertex correspondences.
inline constexpr double kOutlierFloor = 10.0;

// The rows that are kept are weighted by how close the suspect's surface came to them
// (Detector::extract_resampled: w = 1 / (1 + (d / s)^2) for a row at distance d), with s this
// many times the mark's amplitude (0.18% of the diagonal at the defaults). The far-rows rule
// is all or nothing at a large distance; an attack that refits the surface (remeshing, voxel
// remeshing, a cut) also leaves rows at a few mark amplitudes, and their error, not the mark,
// dominates their reading. A copy that only carries the mark loses almost nothing (w >= 0.9 at
// one amplitude). Like the far-rows rule the weights come from distances to the original only.
// Measured on the robustness grid (bench/results/2026-11-25-rows-weighted-by-distance.md): 3
// gains the most claims after remeshing and loses none; 2 starts to lose simplified copies, 5
// and 10 gain less.
inline constexpr double kWeightScale = 3.0;

/// The mark's RMS displacement in reference units: the additive rule's strength (a fraction
/// of the diagonal) or, for the paper's rule, the default mark's.
[[nodiscard]] double mark_amplitude(const EmbedOptions& options, double diagonal);

/// The rows a cropped suspect still covers: \p is_cropped (resample's flags) grown by a few
/// rings of neighbours (the band along the cut carries a bias, not the mark), inverted.
[[nodiscard]] std::vector<std::uint8_t> kept_after_crop(
    const TriangleMesh& original, const std::vector<std::uint8_t>& is_cropped);

/// The rows to read: \p kept_by_crop (null: all) minus the rows farther from the suspect than
/// 3 x the median \p distance and \p floor; \p outliers gets their number. Serial nearest-rank
/// median, so the result is the same on every run. Distances to the original only, never the
/// key's signs: the false-positive bound holds as for crops (docs/statistics.md).
[[nodiscard]] std::vector<std::uint8_t> kept_without_outliers(
    const Eigen::VectorXd& distance, const std::vector<std::uint8_t>* kept_by_crop, double floor,
    std::size_t& outliers);

}  // namespace meshmark::detail
