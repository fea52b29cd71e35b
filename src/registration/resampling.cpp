// SPDX-License-Identifier: MIT
#include "meshmark/registration/resampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>
#include <utility>

#include <Eigen/LU>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/point_triangle.h"
#include "registration/detail/surface_matcher.h"

namespace meshmark
{
namespace
{

/// The \p q-quantile of \p values (nearest rank), from a copy: the same value on every run.
double quantile_of(const Eigen::VectorXd& values, double q)
{
    std::vector<double> v(values.data(), values.data() + values.size());
    if (v.empty())
    {
        return 0.0;
    }
    const auto k =
        static_cast<std::size_t>(std::clamp(std::ceil(q * static_cast<double>(v.size())) - 1.0, 0.0,
                                            static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

/// Barycentric coordinates of \p p (a point of the triangle) in (\p a, \p b, \p c): the
/// least-squares solution in the triangle's plane, clamped to the triangle. A degenerate
/// triangle (no plane) gives all the weight to its corner nearest to \p p.
Eigen::Vector3d barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, const Eigen::Vector3d& c)
{
    const Eigen::Vector3d ab = b - a;
    const Eigen::Vector3d ac = c - a;
    const Eigen::Vector3d ap = p - a;
    const double d00 = ab.dot(ab);
    const double d01 = ab.dot(ac);
    const double d11 = ac.dot(ac);
    const double det = d00 * d11 - d01 * d01;
    if (!(det > 1e-24 * d00 * d11) || !std::isfinite(det))
    {
        const std::array<double, 3> d{ap.squaredNorm(), (p - b).squaredNorm(),
                                      (p - c).squaredNorm()};
        const auto k = std::min_element(d.begin(), d.end()) - d.begin();
        return Eigen::Vector3d::Unit(k);
    }
    const double d20 = ap.dot(ab);
    const double d21 = ap.dot(ac);
    const double v = std::clamp((d11 * d20 - d01 * d21) / det, 0.0, 1.0);
    const double w = std::clamp((d00 * d21 - d01 * d20) / det, 0.0, 1.0);
    const double sum = v + w;
    return sum > 1.0 ? Eigen::Vector3d(0.0, v / sum, w / sum) : Eigen::Vector3d(1.0 - sum, v, w);
}

}  // namespace

void ResamplingOptions::validate() const
{
    auto require = [](bool ok, const std::string& what)
    {
        if (!ok)
        {
            throw InvalidOption("resampling option " + what + ".");
        }
    };
    require(edge_factor >= 0.0 && std::isfinite(edge_factor),
            "edge_factor = " + std::to_string(edge_factor) + " is not a finite number >= 0");
    require(
        quantile_factor >= 0.0 && std::isfinite(quantile_factor),
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
        throw InvalidOption(
            "resampling: the suspect-to-reference transform is singular or not finite.");
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
    result.element.resize(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        const ClosestPoint& c = closest[static_cast<std::size_t>(i)];
        const Eigen::Vector3d p = A * c.point + t;
        result.points.row(i) = p.transpose();
        result.distance(i) = (p - reference.V.row(i).transpose()).norm();
        result.element[static_cast<std::size_t>(i)] = c.face >= 0 ? c.face : c.vertex;
    }

    // Crop marking: farther than the threshold (see ResamplingOptions) means no counterpart.
    result.mean_edge_length = mean_edge_length(reference);
    const double q = quantile_of(result.distance, options.quantile);
    result.crop_threshold =
        std::max(options.edge_factor * result.mean_edge_length, options.quantile_factor * q);
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

namespace
{

/// The faces around each point of \p mesh in compressed rows, vertices at the same position
/// taken as one point (seams, split normals, welded-by-position parts): `point[v]` is the
/// lowest-indexed vertex at v's position, and the faces around it are `faces[offsets[point[v]]
/// .. offsets[point[v] + 1])`, in face order.
struct PointFaces
{
    std::vector<std::int32_t> point;
    std::vector<std::uint32_t> offsets;
    std::vector<std::int32_t> faces;
};

PointFaces point_faces(const TriangleMesh& mesh)
{
    PointFaces result;
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    result.point = position_ids(mesh.V);
    result.offsets.assign(n + 1, 0);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int k = 0; k < 3; ++k)
        {
            ++result.offsets[static_cast<std::size_t>(
                                 result.point[static_cast<std::size_t>(mesh.F(f, k))]) +
                             1];
        }
    }
    for (std::size_t v = 1; v < result.offsets.size(); ++v)
    {
        result.offsets[v] += result.offsets[v - 1];
    }
    result.faces.resize(result.offsets.back());
    std::vector<std::uint32_t> next(result.offsets.begin(), result.offsets.end() - 1);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int k = 0; k < 3; ++k)
        {
            const auto p =
                static_cast<std::size_t>(result.point[static_cast<std::size_t>(mesh.F(f, k))]);
            result.faces[next[p]++] = static_cast<std::int32_t>(f);
        }
    }
    return result;
}

/// The closest point to \p q on the faces of \p mesh around \p start, walking on: the faces
/// around the three corners of the best face so far, while that face changes (at most kSteps
/// rounds). Exact when the closest point lies within a ring of a face the walk visits; a
/// start at the vertex nearest to \p q makes that the rule.
Eigen::Vector3d closest_near(const Eigen::Vector3d& q, std::int32_t start, const TriangleMesh& mesh,
                             const PointFaces& around)
{
    constexpr int kSteps = 32;  // a bound on the walk: a round without a closer face ends it sooner
    Eigen::Vector3d best = mesh.V.row(start).transpose();
    double best2 = (best - q).squaredNorm();
    std::int32_t best_face = -1;
    auto visit = [&](std::int32_t v)
    {
        const auto p = static_cast<std::size_t>(around.point[static_cast<std::size_t>(v)]);
        for (std::uint32_t k = around.offsets[p]; k < around.offsets[p + 1]; ++k)
        {
            const std::int32_t f = around.faces[k];
            const TriangleCorners t{mesh.V.row(mesh.F(f, 0)).transpose(),
                                    mesh.V.row(mesh.F(f, 1)).transpose(),
                                    mesh.V.row(mesh.F(f, 2)).transpose()};
            const Eigen::Vector3d c =
                closest_point_on_triangle(q, t, is_sliver_triangle(t.a, t.b, t.c));
            const double d2 = (c - q).squaredNorm();
            if (d2 < best2 || (d2 == best2 && best_face >= 0 && f < best_face))
            {
                best = c;
                best2 = d2;
                best_face = f;
            }
        }
    };
    visit(start);
    for (int step = 0; step < kSteps && best_face >= 0; ++step)
    {
        const std::int32_t face = best_face;
        for (int k = 0; k < 3; ++k)
        {
            visit(mesh.F(face, k));
        }
        if (best_face == face)
        {
            break;
        }
    }
    return best;
}

}  // namespace

void match_reference_surface(Resampling& sampled, const TriangleMesh& reference,
                             const TriangleMesh& suspect,
                             const Eigen::Matrix4d& suspect_to_reference, int threads)
{
    const Eigen::Index n = reference.V.rows();
    if (sampled.points.rows() != n || sampled.element.size() != static_cast<std::size_t>(n))
    {
        throw InvalidOption(
            "match_reference_surface: the resampling was not made for this reference.");
    }
    threads = resolve_threads(threads);
    const bool is_cloud = suspect.F.rows() == 0;
    const Eigen::Matrix3d A = suspect_to_reference.block<3, 3>(0, 0);
    const Eigen::Vector3d t = suspect_to_reference.block<3, 1>(0, 3);

    // The suspect's vertices that some point lies on (a triangle's corners, or the cloud's
    // point), in the reference's frame.
    std::vector<std::int32_t> slot(static_cast<std::size_t>(suspect.V.rows()), -1);
    std::vector<std::int32_t> used;
    const int corner_count = is_cloud ? 1 : 3;
    for (const std::int32_t e : sampled.element)
    {
        for (int k = 0; k < corner_count; ++k)
        {
            const std::int32_t v = is_cloud ? e : suspect.F(e, k);
            if (slot[static_cast<std::size_t>(v)] < 0)
            {
                slot[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(used.size());
                used.push_back(v);
            }
        }
    }
    Positions corners(static_cast<Eigen::Index>(used.size()), 3);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index j = 0; j < corners.rows(); ++j)
    {
        corners.row(j) =
            (A * suspect.V.row(used[static_cast<std::size_t>(j)]).transpose() + t).transpose();
    }
    // Each corner's offset from the reference surface: its closest point, found by a walk
    // from the nearest reference vertex (on the right part of a mesh made of several).
    {
        const PointKdTree vertices(reference.V);
        const bool has_faces = reference.F.rows() > 0;
        const PointFaces around = has_faces ? point_faces(reference) : PointFaces{};
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
        for (Eigen::Index j = 0; j < corners.rows(); ++j)
        {
            const Eigen::Vector3d q = corners.row(j).transpose();
            double squared = 0.0;
            const auto s = static_cast<std::int32_t>(vertices.nearest(q, squared));
            const Eigen::Vector3d on_reference =
                has_faces ? closest_near(q, s, reference, around)
                          : Eigen::Vector3d(reference.V.row(s).transpose());
            corners.row(j) = (q - on_reference).transpose();
        }
    }

#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        const std::int32_t e = sampled.element[static_cast<std::size_t>(i)];
        const Eigen::Vector3d p = sampled.points.row(i).transpose();
        Eigen::Vector3d offset;
        if (is_cloud)
        {
            offset = corners.row(slot[static_cast<std::size_t>(e)]).transpose();
        }
        else
        {
            std::array<std::int32_t, 3> j{};
            std::array<Eigen::Vector3d, 3> x;
            for (int k = 0; k < 3; ++k)
            {
                const std::int32_t v = suspect.F(e, k);
                j[static_cast<std::size_t>(k)] = slot[static_cast<std::size_t>(v)];
                x[static_cast<std::size_t>(k)] = A * suspect.V.row(v).transpose() + t;
            }
            const Eigen::Vector3d w = barycentric(p, x[0], x[1], x[2]);
            offset = w(0) * corners.row(j[0]).transpose() + w(1) * corners.row(j[1]).transpose() +
                     w(2) * corners.row(j[2]).transpose();
        }
        sampled.points.row(i) = reference.V.row(i) + offset.transpose();
    }
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
