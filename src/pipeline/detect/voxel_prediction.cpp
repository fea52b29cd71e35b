// SPDX-License-Identifier: MIT
#include "pipeline/detect/voxel_prediction.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <iterator>
#include <vector>

#include <Eigen/LU>

#include "meshmark/attacks/voxel_remeshing.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/registration/resampling.h"
#include "meshmark/watermark/detector.h"
#include "pipeline/detect/correspondence.h"

namespace meshmark::detail
{
namespace
{

// VoxelRemeshingOptions::validate's range of resolutions.
constexpr double kLowest = VoxelRemeshingOptions::kLowestResolution;
constexpr double kHighest = VoxelRemeshingOptions::kHighestResolution;

// The suspect's edge lengths (each face's three): median and coefficient of variation.
struct EdgeSpread
{
    double median = 0.0;
    double variation = 0.0;
};

EdgeSpread edge_spread(const TriangleMesh& mesh)
{
    std::vector<double> lengths;
    lengths.reserve(static_cast<std::size_t>(3 * mesh.F.rows()));
    double sum = 0.0;
    double squares = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int e = 0; e < 3; ++e)
        {
            const double length =
                (mesh.V.row(mesh.F(f, e)) - mesh.V.row(mesh.F(f, (e + 1) % 3))).norm();
            lengths.push_back(length);
            sum += length;
            squares += length * length;
        }
    }
    EdgeSpread spread;
    if (lengths.empty() || sum <= 0.0)
    {
        return spread;
    }
    const auto n = static_cast<double>(lengths.size());
    const double mean = sum / n;
    spread.variation = std::sqrt(std::max(0.0, squares / n - mean * mean)) / mean;
    const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
    std::nth_element(lengths.begin(), middle, lengths.end());
    spread.median = *middle;
    return spread;
}

TriangleMesh remeshed(const TriangleMesh& original, double resolution, int threads)
{
    VoxelRemeshingOptions options;
    options.resolution = resolution;
    return voxel_remesh(original, options, threads);
}

// 1 - sum w (n.(o - p))^2 / sum w (n.o)^2 over the rows read: the share of the suspect's
// change o along the original's normals that the prediction p accounts for.
double explained_share(const TriangleMesh& original, const SuspectInFrame& found,
                       const Positions& predicted)
{
    const Positions normals = vertex_normals(original);
    const std::vector<std::uint8_t>* kept = found.kept();
    double change = 0.0;
    double residual = 0.0;
    for (Eigen::Index i = 0; i < original.V.rows(); ++i)
    {
        if (kept != nullptr && (*kept)[static_cast<std::size_t>(i)] == 0)
        {
            continue;
        }
        const Eigen::RowVector3d observed = found.sampled.points.row(i) - original.V.row(i);
        const double weight =
            found.weight_scale > 0.0 ? row_weight(observed.norm(), found.weight_scale) : 1.0;
        const double o = observed.dot(normals.row(i));
        const double p = predicted.row(i).dot(normals.row(i));
        change += weight * o * o;
        residual += weight * (o - p) * (o - p);
    }
    return change > 0.0 ? 1.0 - residual / change : 0.0;
}

VoxelPrediction predict(const TriangleMesh& original, const TriangleMesh& suspect, double estimate,
                        bool is_cropped, int threads)
{
    VoxelPrediction prediction;
    prediction.original = &original;
    prediction.estimate = estimate;
    prediction.resolution = estimate;
    TriangleMesh remesh = remeshed(original, estimate, threads);
    // The vertex count grows as the resolution squared: one step to the suspect's count, when
    // the suspect is whole (a crop's count says nothing of the voxel).
    constexpr double kCountTolerance = 0.01;
    if (!is_cropped && remesh.V.rows() > 0)
    {
        const double refined = estimate * std::sqrt(static_cast<double>(suspect.V.rows()) /
                                                    static_cast<double>(remesh.V.rows()));
        if (std::abs(refined / estimate - 1.0) > kCountTolerance && refined >= kLowest &&
            refined <= kHighest)
        {
            prediction.resolution = refined;
            remesh = remeshed(original, refined, threads);
        }
    }
    const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
    ResamplingOptions sampling;
    sampling.threads = threads;
    Resampling own = resample(original, remesh, identity, sampling);
    prediction.plain = own.points - original.V;
    match_reference_surface(own, original, remesh, identity, threads);
    prediction.matched = own.points - original.V;
    return prediction;
}

}  // namespace

VoxelPredictor::VoxelPredictor(const DetectInputs& in, const SuspectInFrame& found,
                               VoxelCache& cache, int threads, bool enabled)
    : in_(&in), found_(&found), cache_(&cache), threads_(threads)
{
    if (!enabled || !found.is_resampled() || in.suspect.is_point_cloud() ||
        in.original.is_point_cloud())
    {
        return;
    }
    const EdgeSpread spread = edge_spread(in.suspect);
    if (spread.median <= 0.0 || spread.variation > kVoxelEdgeVariation)
    {
        return;
    }
    const double scale = std::cbrt(std::abs(found.to_original.topLeftCorner<3, 3>().determinant()));
    const double estimate = bounding_box(in.original.V).diagonal() / (spread.median * scale);
    if (std::isfinite(estimate) && estimate >= kLowest && estimate <= kHighest &&
        found.registration_rms * estimate <= kVoxelReach)
    {
        estimate_ = estimate;
    }
}

const VoxelPrediction* VoxelPredictor::prediction()
{
    if (asked_ || !is_possible())
    {
        return used_;
    }
    asked_ = true;
    // Poses of one suspect differ in scale by rounding: the same remesh serves them all.
    constexpr double kSameEstimate = 0.01;
    auto cached = std::find_if(cache_->begin(), cache_->end(),
                               [&](const VoxelPrediction& p)
                               {
                                   return p.original == &in_->original &&
                                          std::abs(p.estimate / estimate_ - 1.0) <= kSameEstimate;
                               });
    if (cached == cache_->end())
    {
        try
        {
            cache_->push_back(
                predict(in_->original, in_->suspect, estimate_, found_->is_cropped, threads_));
        }
        catch (const std::exception&)
        {
            // No OpenVDB plugin, or no surface left at this resolution: read as before.
            return nullptr;
        }
        cached = std::prev(cache_->end());
    }
    if (explained_share(in_->original, *found_, cached->plain) >= kVoxelExplained)
    {
        used_ = &*cached;
    }
    return used_;
}

}  // namespace meshmark::detail
