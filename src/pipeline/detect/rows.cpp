// SPDX-License-Identifier: MIT
#include "pipeline/detect/rows.h"

#include <algorithm>
#include <utility>

#include "meshmark/core/median.h"
#include "meshmark/geometry/adjacency.h"

namespace meshmark::detail
{
namespace
{

// Next to a cut, the original's vertices that are just beyond the crop threshold get the closest
// point on the cut's border instead of their own: they carry no watermark, only a bias. Growing
// the cropped region by this many rings of neighbours drops that band (measured on half crops
// of rocker-arm.obj: R 0.29 with no growth, 0.71 with 2 rings, 0.79 with 4; see
// docs/robustness.md).
constexpr int kCropDilationRings = 4;

// Rows of the original whose resampled point is farther than this many times the median
// distance from it, and farther than kOutlierFloor times the mark's strength, are left out of
// the reading (no dilation, and they do not make the suspect "cropped"). A coarse resampling of
// the surface (a 25% remesh, a voxel remesh that merges thin walls, the band along a cut that
// the crop threshold misses) leaves some rows several mark amplitudes away from any surface
// that carries the mark: they measure the attack's error, not the mark, and in a least-squares
// reading they swamp it. The rule looks only at distances to the ORIGINAL, never at the key's
// signs, so the false-positive bound holds as for crops (docs/statistics.md). Measured on the
// robustness grid (bench/results/2026-11-25-rows-far-from-surface.md).
constexpr double kOutlierMedianFactor = 3.0;
// The amplitude of keys whose strength is not a distance (the paper's rule), as a fraction of
// the diagonal: the default mark's.
constexpr double kPaperRuleAmplitude = 0.00059;

}  // namespace

double mark_amplitude(const EmbedOptions& options, double diagonal)
{
    return (options.rule == EmbeddingRule::Additive ? options.resolved_strength()
                                                    : kPaperRuleAmplitude) *
           diagonal;
}

std::vector<std::uint8_t> kept_after_crop(const TriangleMesh& original,
                                          const std::vector<std::uint8_t>& is_cropped)
{
    std::vector<std::uint8_t> cropped = is_cropped;
    if (!original.is_point_cloud())
    {
        const VertexAdjacency adjacency = vertex_adjacency(original);
        for (int ring = 0; ring < kCropDilationRings; ++ring)
        {
            std::vector<std::uint8_t> grown = cropped;
            for (std::size_t v = 0; v < cropped.size(); ++v)
            {
                if (cropped[v] != 0)
                {
                    for (const auto u : adjacency.of(v))
                    {
                        grown[static_cast<std::size_t>(u)] = 1;
                    }
                }
            }
            cropped = std::move(grown);
        }
    }
    std::vector<std::uint8_t> kept(cropped.size());
    for (std::size_t i = 0; i < kept.size(); ++i)
    {
        kept[i] = cropped[i] == 0 ? 1 : 0;
    }
    return kept;
}

std::vector<std::uint8_t> kept_without_outliers(const Eigen::VectorXd& distance,
                                                const std::vector<std::uint8_t>* kept_by_crop,
                                                double floor, std::size_t& outliers)
{
    const auto n = static_cast<std::size_t>(distance.size());
    std::vector<double> sorted(distance.data(), distance.data() + n);
    const double threshold = std::max(kOutlierMedianFactor * median_in_place(sorted), floor);
    std::vector<std::uint8_t> kept =
        kept_by_crop != nullptr ? *kept_by_crop : std::vector<std::uint8_t>(n, 1);
    outliers = 0;
    for (std::size_t i = 0; i < n; ++i)
    {
        if (kept[i] != 0 && distance(static_cast<Eigen::Index>(i)) > threshold)
        {
            kept[i] = 0;
            ++outliers;
        }
    }
    return kept;
}

}  // namespace meshmark::detail
