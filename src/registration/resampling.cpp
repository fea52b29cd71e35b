// SPDX-License-Identifier: MIT
#include "meshmark/registration/resampling.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/LU>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "registration/detail/surface_matcher.h"

namespace meshmark {
namespace {

/// The \p q-quantile of \p values (nearest rank), from a copy: the same value on every run.
double quantile_of(const Eigen::VectorXd& values, double q)
{
    std::vector<double> v(values.data(), values.data() + values.size());
    if (v.empty())
    {
        return 0.0;
    }
    const auto k = static_cast<std::size_t>(
        std::clamp(std::ceil(q * static_cast<double>(v.size())) - 1.0, 0.0,
                   static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

}  // namespace

void ResamplingOptions::validate() const
{
    auto require = [](bool ok, const std::string& what) {
        if (!ok)
        {
            throw InvalidOption("resampling option " + what + ".");
        }
    };
    require(edge_factor >= 0.0 && std::isfinite(edge_factor),
            "edge_factor = " + std::to_string(edge_factor) + " is not a finite number >= 0");
    require(quantile_factor >= 0.0 && std::isfinite(quantile_factor),
            "quantile_factor = " + std::to_string(quantile_factor) + " is not a finite number >= 0");
    require(quantile > 0.0 && quantile <= 1.0,
            "quantile = " + std::to_string(quantile) + " is outside (0, 1]");
    require(threads >= 0, "threads = " + std::to_string(threads) + " is negative");
}

Resampling resample(const TriangleMesh& reference, const TriangleMesh& suspect,
                    const Eigen::Matrix4d& suspect_to_reference, const ResamplingOptions& options)
{
    options.validate();
    if (suspect.V.rows() == 0)
    {
        throw InvalidMesh("resampling: the suspect mesh has no vertices.");
    }
    const ClosestPointIndex index(suspect);
    return resample(reference, index, suspect_to_reference, options);
}

Resampling resample(const TriangleMesh& reference, const ClosestPointIndex& suspect_index,
                    const Eigen::Matrix4d& suspect_to_reference, const ResamplingOptions& options)
{
    options.validate();
    if (reference.V.rows() == 0)
    {
        throw InvalidMesh("resampling: the reference mesh has no vertices.");
    }
    const Eigen::Matrix3d A = suspect_to_reference.block<3, 3>(0, 0);
    const Eigen::Vector3d t = suspect_to_reference.block<3, 1>(0, 3);
    const double det = A.determinant();
    if (!std::isfinite(det) || std::abs(det) < 1e-300 || !suspect_to_reference.allFinite())
    {
        throw InvalidOption("resampling: the suspect-to-reference transform is singular or not finite.");
    }
    const Eigen::Matrix3d A_inv = A.inverse();
    const int threads = resolve_threads(options.threads);
    const Eigen::Index n = reference.V.rows();

    // Reference vertices into the suspect's frame, where its index was built.
    Positions queries(n, 3);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        queries.row(i) = (A_inv * (reference.V.row(i).transpose() - t)).transpose();
    }
    const std::vector<ClosestPoint> closest = suspect_index.closest(queries, threads);

    // Closest points back into the reference frame; distances measured there.
    Resampling result;
    result.points.resize(n, 3);
    result.distance.resize(n);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        const Eigen::Vector3d p = A * closest[static_cast<std::size_t>(i)].point + t;
        result.points.row(i) = p.transpose();
        result.distance(i) = (p - reference.V.row(i).transpose()).norm();
    }

    // Crop marking: farther than the threshold (see ResamplingOptions) means no counterpart.
    result.mean_edge_length = mean_edge_length(reference);
    const double q = quantile_of(result.distance, options.quantile);
    result.crop_threshold = std::max(options.edge_factor * result.mean_edge_length,
                                     options.quantile_factor * q);
    result.is_cropped.resize(static_cast<std::size_t>(n));
    std::size_t cropped = 0;
    for (Eigen::Index i = 0; i < n; ++i)
    {
        const bool is_far = result.distance(i) > result.crop_threshold;
        result.is_cropped[static_cast<std::size_t>(i)] = is_far ? 1 : 0;
        cropped += is_far ? 1U : 0U;
    }
    result.cropped_fraction = static_cast<double>(cropped) / static_cast<double>(n);
    return result;
}

double mean_edge_length(const TriangleMesh& mesh)
{
    if (mesh.F.rows() == 0)
    {
        return detail::median_neighbor_spacing(mesh.V);
    }
    double sum = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            sum += (mesh.V.row(mesh.F(f, (c + 1) % 3)) - mesh.V.row(mesh.F(f, c))).norm();
        }
    }
    return sum / (3.0 * static_cast<double>(mesh.F.rows()));
}

}  // namespace meshmark
