// SPDX-License-Identifier: MIT
#include "registration/detail/icp.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "meshmark/core/threads.h"
#include "meshmark/registration/point_to_plane.h"
#include "meshmark/registration/similarity_fit.h"

namespace meshmark::detail
{
namespace
{

using Vec3 = Eigen::Vector3d;

// An ICP update that moves the samples by less than this fraction of the fit's standard
// error (trimmed RMS distance / sqrt(kept pairs)) counts as converged: on noisy data the
// trimmed set and the normals jitter, and the iterations would otherwise run to the limit
// without changing anything the data can tell (measured: the steps hover at 0.1-0.4 of the
// standard error on a 1%-noise copy once converged).
constexpr double kNoiseFraction = 0.5;

double standard_error(double trimmed_rms, std::size_t kept)
{
    return trimmed_rms / std::sqrt(static_cast<double>(std::max<std::size_t>(kept, 1)));
}

/// Matches of the current transform plus the trimming threshold.
struct Matching
{
    Positions Y;                        // transformed samples
    std::vector<SurfaceMatch> matches;  // their closest target points
    double threshold = 0.0;             // largest kept distance
    double trimmed_rms = 0.0;
    double overlap_fraction = 0.0;
};

// The k-th smallest distance (k = ceil(keep * n), at least 3) is the trimming threshold;
// nth_element on a copy gives the same value on every run.
double trim_threshold(const std::vector<SurfaceMatch>& matches, double keep)
{
    std::vector<double> d(matches.size());
    for (std::size_t i = 0; i < matches.size(); ++i)
    {
        d[i] = matches[i].distance;
    }
    const auto n = d.size();
    auto k = static_cast<std::size_t>(std::ceil(keep * static_cast<double>(n)));
    k = std::clamp<std::size_t>(k, std::min<std::size_t>(3, n), n);
    const auto kth = d.begin() + static_cast<std::ptrdiff_t>(k - 1);
    std::nth_element(d.begin(), kth, d.end());
    return *kth;
}

Matching match_and_trim(const Positions& X, const SurfaceMatcher& target, const Similarity& T,
                        const IcpSettings& settings)
{
    Matching m;
    m.Y = apply(T, X, settings.threads);
    target.match_all(m.Y, m.matches, settings.threads);
    m.threshold = trim_threshold(m.matches, settings.trim_keep);
    // Sums run serially in sample order: identical for any thread count.
    double sum = 0.0;
    std::size_t kept = 0;
    for (const SurfaceMatch& match : m.matches)
    {
        if (match.distance <= m.threshold)
        {
            sum += match.distance * match.distance;
            ++kept;
        }
    }
    m.trimmed_rms = kept > 0 ? std::sqrt(sum / static_cast<double>(kept)) : 0.0;
    const double overlap_limit = std::max(3.0 * m.trimmed_rms, settings.distance_floor);
    std::size_t inside = 0;
    for (const SurfaceMatch& match : m.matches)
    {
        inside += match.distance <= overlap_limit ? 1U : 0U;
    }
    m.overlap_fraction = m.matches.empty()
                             ? 0.0
                             : static_cast<double>(inside) / static_cast<double>(m.matches.size());
    return m;
}

// Size of an update: rotation angle, relative scale change and translation over the radius.
double update_size(const Eigen::Matrix3d& dR, double ds, const Vec3& dt, double radius)
{
    const double cos_angle = std::clamp((dR.trace() - 1.0) / 2.0, -1.0, 1.0);
    return std::acos(cos_angle) + std::abs(ds) + dt.norm() / radius;
}

double rms_radius(const Positions& Y)
{
    const Eigen::RowVector3d c = Y.colwise().mean();
    return std::sqrt((Y.rowwise() - c).squaredNorm() /
                     static_cast<double>(std::max<Eigen::Index>(Y.rows(), 1)));
}

IcpOutcome outcome_of(const Matching& m, const Similarity& T, int iterations, bool done)
{
    return {T, m.trimmed_rms, m.overlap_fraction, iterations, done};
}

}  // namespace

Positions apply(const Similarity& T, const Positions& X, int threads)
{
    Positions Y(X.rows(), 3);
    const Eigen::Matrix3d A = T.scale * T.rotation;
    const auto n = static_cast<std::int64_t>(X.rows());
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads)) if (threads != 1)
    for (std::int64_t i = 0; i < n; ++i)
    {
        const auto r = static_cast<Eigen::Index>(i);
        Y.row(r) = (A * X.row(r).transpose() + T.translation).transpose();
    }
    return Y;
}

IcpOutcome icp_point_to_point(const Positions& X, const SurfaceMatcher& target,
                              const Similarity& start, const IcpSettings& settings)
{
    Similarity T = start;
    const double radius = std::max(rms_radius(X), 1e-300);
    Matching m;
    for (int iteration = 1; iteration <= settings.max_iterations; ++iteration)
    {
        m = match_and_trim(X, target, T, settings);
        // Closed-form similarity between the kept sources and their matches (fit_similarity).
        std::vector<Eigen::Index> kept;
        kept.reserve(m.matches.size());
        for (std::size_t i = 0; i < m.matches.size(); ++i)
        {
            if (m.matches[i].distance <= m.threshold)
            {
                kept.push_back(static_cast<Eigen::Index>(i));
            }
        }
        if (kept.size() < 3)
        {
            return outcome_of(m, T, iteration, false);
        }
        Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(kept.size()));
        Eigen::Matrix3Xd dst(3, static_cast<Eigen::Index>(kept.size()));
        for (std::size_t j = 0; j < kept.size(); ++j)
        {
            src.col(static_cast<Eigen::Index>(j)) = X.row(kept[j]).transpose();
            dst.col(static_cast<Eigen::Index>(j)) =
                m.matches[static_cast<std::size_t>(kept[j])].point;
        }
        Similarity next = similarity_parts(fit_similarity(src, dst));
        if (!(next.scale > 0.0) || !std::isfinite(next.scale))
        {
            return outcome_of(m, T, iteration, false);
        }
        if (next.scale < settings.min_scale || next.scale > settings.max_scale)
        {
            // Keep the rotation, clamp the scale and re-fit the translation to the centroids.
            next.scale = std::clamp(next.scale, settings.min_scale, settings.max_scale);
            next.translation =
                dst.rowwise().mean() - next.scale * next.rotation * src.rowwise().mean();
        }
        const double size =
            update_size(next.rotation * T.rotation.transpose(), next.scale / T.scale - 1.0,
                        (next.translation - T.translation) / T.scale, radius);
        T = next;
        if (size < settings.tolerance ||
            size * radius * T.scale < kNoiseFraction * standard_error(m.trimmed_rms, kept.size()))
        {
            return outcome_of(m, T, iteration, true);
        }
    }
    return outcome_of(m, T, settings.max_iterations, false);
}

IcpOutcome icp_point_to_plane(const Positions& X, const SurfaceMatcher& target,
                              const Similarity& start, const IcpSettings& settings)
{
    using Vec7 = Eigen::Matrix<double, 7, 1>;
    Similarity T = start;
    Matching m;
    for (int iteration = 1; iteration <= settings.max_iterations; ++iteration)
    {
        m = match_and_trim(X, target, T, settings);
        std::vector<Eigen::Index> kept;  // in sample order, so the sums are too
        for (std::size_t i = 0; i < m.matches.size(); ++i)
        {
            if (m.matches[i].distance <= m.threshold)
            {
                kept.push_back(static_cast<Eigen::Index>(i));
            }
        }
        if (kept.size() < 7)
        {
            return outcome_of(m, T, iteration, false);
        }
        // Rotation, scale and translation, the first four times the kept samples' RMS radius L
        // about their centre c (point_to_plane_step).
        const std::optional<PointToPlaneStep<7>> update =
            point_to_plane_step<7>(m.Y, m.matches, kept);
        if (!update)
        {
            return outcome_of(m, T, iteration, false);
        }
        const Vec3& c = update->centre;
        const double L = update->radius;
        const Vec7& delta = update->delta;
        const Vec3 omega = delta.head<3>() / L;
        const double sigma = delta(3) / L;
        const Vec3 tau = delta.tail<3>();
        const double angle = omega.norm();
        const Eigen::Matrix3d dR = angle > 0.0
                                       ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                                       : Eigen::Matrix3d::Identity();
        const double k = 1.0 + sigma;
        if (!(k > 0.0))
        {
            return outcome_of(m, T, iteration, false);
        }
        // y' = c + k dR (y - c) + tau, composed with y = s R x + t.
        T.scale *= k;
        // Re-orthonormalize so that rounding does not accumulate over the iterations.
        T.rotation = Eigen::Quaterniond(dR * T.rotation).normalized().toRotationMatrix();
        T.translation = c + k * dR * (T.translation - c) + tau;
        // Stop when the update is negligible, or below the fit's standard error (noisy data:
        // further updates only chase the trimming's jitter).
        const double step = (angle + std::abs(sigma)) * L + tau.norm();
        if (step < settings.tolerance * L ||
            step < kNoiseFraction * standard_error(m.trimmed_rms, kept.size()))
        {
            return outcome_of(m, T, iteration, true);
        }
    }
    return outcome_of(m, T, settings.max_iterations, false);
}

IcpOutcome evaluate(const Positions& X, const SurfaceMatcher& target, const Similarity& T,
                    const IcpSettings& settings)
{
    const Matching m = match_and_trim(X, target, T, settings);
    return outcome_of(m, T, 0, true);
}

}  // namespace meshmark::detail
