// SPDX-License-Identifier: MIT
#include "registration/detail/coarse_alignment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "meshmark/core/rng.h"

namespace meshmark::detail
{
namespace
{

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// Crop hypotheses: plane normals, kept area fractions, and how many parts become candidates
// (32 of 256 parts; fewer missed 1-2 of 8 half-crops of real meshes, see the docs).
constexpr int kCropDirections = 64;
constexpr std::array<double, 4> kCropFractions = {0.5, 0.625, 0.75, 0.875};
constexpr std::size_t kCropHypotheses = 32;
// Reference triangles (points) sampled for the parts' moments: a fixed sample, so that the crop
// hypotheses cost the same on any mesh size.
constexpr std::size_t kCropElements = 8000;
// Principal axes count as interchangeable when their relative eigenvalue gap is below this.
constexpr double kAxisGap = 0.1;

/// A small piece of the reference (a triangle, or a point) and its moment contributions.
struct Element
{
    double weight = 0.0;         // area (1 for a point)
    Vec3 first = Vec3::Zero();   // weight * centroid
    Mat3 second = Mat3::Zero();  // weight * E[x x^T]
    Vec3 centroid = Vec3::Zero();
};

// A seeded subsample of the reference's triangles (or points), relative to \p o.
std::vector<Element> reference_elements(const TriangleMesh& reference, bool use_area,
                                        const std::vector<std::int32_t>& rows, const Vec3& o,
                                        std::uint64_t seed)
{
    std::vector<Element> elements;
    if (use_area)
    {
        std::vector<std::int32_t> faces(static_cast<std::size_t>(reference.F.rows()));
        std::iota(faces.begin(), faces.end(), 0);
        faces = shuffled(std::move(faces), seed);
        faces.resize(std::min(faces.size(), kCropElements));
        for (const std::int32_t f : faces)
        {
            const Vec3 a = reference.V.row(reference.F(f, 0)).transpose() - o;
            const Vec3 b = reference.V.row(reference.F(f, 1)).transpose() - o;
            const Vec3 c = reference.V.row(reference.F(f, 2)).transpose() - o;
            const double w = 0.5 * (b - a).cross(c - a).norm();
            const Vec3 sum = a + b + c;
            elements.push_back({w, (w / 3.0) * sum,
                                (w / 12.0) * (a * a.transpose() + b * b.transpose() +
                                              c * c.transpose() + sum * sum.transpose()),
                                sum / 3.0});
        }
        return elements;
    }
    std::vector<std::int32_t> order = shuffled(rows, seed);
    order.resize(std::min(order.size(), kCropElements));
    for (const std::int32_t r : order)
    {
        const Vec3 x = reference.V.row(r).transpose() - o;
        elements.push_back({1.0, x, x * x.transpose(), x});
    }
    return elements;
}

/// Eigenvalues of a covariance divided by their sum, largest first: a scale-free shape
/// signature.
Vec3 shape_signature(const Mat3& covariance)
{
    const Eigen::SelfAdjointEigenSolver<Mat3> solver(covariance, Eigen::EigenvaluesOnly);
    const Vec3 l = solver.eigenvalues().reverse();
    return l / l.sum();
}

/// Moments of a part from its elements' summed weight \p w, first and second moments about \p o.
Moments part_moments(const Vec3& o, double w, const Vec3& first, const Mat3& second)
{
    Moments m;
    const Vec3 mean = first / w;
    m.centroid = o + mean;
    m.covariance = second / w - mean * mean.transpose();
    return m;
}

}  // namespace

// Crop hypotheses: a copy cropped by a plane has the moments of the part of the reference on
// one side of that plane, not those of the whole. For planes normal to evenly spread
// directions, keeping several fractions of the reference's area, compute the part's moments
// and keep the parts whose scale-free shape signature is closest to the suspect's.
std::vector<Moments> crop_hypotheses(const TriangleMesh& reference, bool use_area,
                                     const std::vector<std::int32_t>& rows, const Moments& whole,
                                     const Moments& suspect, std::uint64_t seed)
{
    const Vec3 o = whole.centroid;
    const std::vector<Element> elements = reference_elements(reference, use_area, rows, o, seed);
    double total = 0.0;
    for (const Element& e : elements)
    {
        total += e.weight;
    }
    const Vec3 target = shape_signature(suspect.covariance);
    std::vector<std::pair<double, Moments>> parts;
    std::vector<std::pair<double, std::size_t>> order(elements.size());
    const int directions = kCropDirections;
    for (int d = 0; d < directions; ++d)
    {
        // Fibonacci sphere: evenly spread unit normals.
        const double z = 1.0 - (2.0 * d + 1.0) / directions;
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        const double angle = d * std::numbers::pi * (3.0 - std::sqrt(5.0));
        const Vec3 n(r * std::cos(angle), r * std::sin(angle), z);
        for (std::size_t i = 0; i < elements.size(); ++i)
        {
            order[i] = {elements[i].centroid.dot(n), i};  // the index breaks ties: deterministic
        }
        std::sort(order.begin(), order.end());
        double w = 0.0;
        Vec3 first = Vec3::Zero();
        Mat3 second = Mat3::Zero();
        std::size_t next = 0;
        for (const auto& [h, i] : order)
        {
            w += elements[i].weight;
            first += elements[i].first;
            second += elements[i].second;
            while (next < kCropFractions.size() && w >= kCropFractions[next] * total)
            {
                const Moments m = part_moments(o, w, first, second);
                parts.emplace_back((shape_signature(m.covariance) - target).lpNorm<1>(), m);
                ++next;
            }
        }
    }
    std::stable_sort(parts.begin(), parts.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Moments> result;
    for (std::size_t i = 0; i < std::min(parts.size(), kCropHypotheses); ++i)
    {
        result.push_back(parts[i].second);
    }
    // The halves on either side of the bounding box's centre plane along each coordinate axis
    // (of the sampled elements' centroids), always: a tool's bisection through the centre, which
    // the signature ranking can miss on an asset of many parts (docs/algorithms/registration.md).
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 hi = -lo;
    for (const Element& e : elements)
    {
        lo = lo.cwiseMin(e.centroid);
        hi = hi.cwiseMax(e.centroid);
    }
    const Vec3 centre = 0.5 * (lo + hi);
    for (int axis = 0; axis < 3; ++axis)
    {
        for (const double side : {1.0, -1.0})
        {
            double w = 0.0;
            Vec3 first = Vec3::Zero();
            Mat3 second = Mat3::Zero();
            for (const Element& e : elements)
            {
                if (side * (e.centroid(axis) - centre(axis)) >= 0.0)
                {
                    w += e.weight;
                    first += e.first;
                    second += e.second;
                }
            }
            if (w > 0.0)
            {
                result.push_back(part_moments(o, w, first, second));
            }
        }
    }
    return result;
}

// Moments of the uniform distribution on the triangles (area-weighted), so that remeshing
// and simplification, which change where vertices sit but not the surface, barely move them.
// Accumulated relative to the first vertex, serially in face order.
Moments area_moments(const TriangleMesh& mesh)
{
    const Vec3 o = mesh.V.row(mesh.F(0, 0)).transpose();
    double area = 0.0;
    Vec3 first = Vec3::Zero();
    Mat3 second = Mat3::Zero();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Vec3 a = mesh.V.row(mesh.F(f, 0)).transpose() - o;
        const Vec3 b = mesh.V.row(mesh.F(f, 1)).transpose() - o;
        const Vec3 c = mesh.V.row(mesh.F(f, 2)).transpose() - o;
        const double w = 0.5 * (b - a).cross(c - a).norm();
        const Vec3 s = a + b + c;
        area += w;
        first += (w / 3.0) * s;
        // E[x x^T] over a triangle = (a a^T + b b^T + c c^T + s s^T) / 12.
        second += (w / 12.0) *
                  (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
    }
    Moments m;
    if (!(area > 0.0))
    {
        return m;
    }
    m.weight = area;
    const Vec3 mean = first / area;
    m.centroid = o + mean;
    m.covariance = second / area - mean * mean.transpose();
    return m;
}

Moments vertex_moments(const Positions& V, const std::vector<std::int32_t>& rows)
{
    const Vec3 o = V.row(rows.front()).transpose();
    Vec3 first = Vec3::Zero();
    Mat3 second = Mat3::Zero();
    for (const std::int32_t r : rows)
    {
        const Vec3 x = V.row(r).transpose() - o;
        first += x;
        second += x * x.transpose();
    }
    const auto n = static_cast<double>(rows.size());
    Moments m;
    m.weight = n;
    const Vec3 mean = first / n;
    m.centroid = o + mean;
    m.covariance = second / n - mean * mean.transpose();
    return m;
}

/// Principal axes as the columns of a proper rotation, largest variance first.
Mat3 principal_frame(const Mat3& covariance)
{
    const Eigen::SelfAdjointEigenSolver<Mat3> solver(covariance);
    Mat3 E;
    E << solver.eigenvectors().col(2), solver.eigenvectors().col(1), solver.eigenvectors().col(0);
    if (E.determinant() < 0.0)
    {
        E.col(2) = -E.col(2);
    }
    return E;
}

/// The 24 rotations that map coordinate axes to signed coordinate axes.
std::vector<Mat3> axis_rotations()
{
    std::vector<Mat3> result;
    std::array<int, 3> perm = {0, 1, 2};
    do
    {
        for (unsigned signs = 0; signs < 8; ++signs)
        {
            Mat3 P = Mat3::Zero();
            for (int i = 0; i < 3; ++i)
            {
                P(i, perm[static_cast<std::size_t>(i)]) =
                    ((signs >> static_cast<unsigned>(i)) & 1U) != 0U ? -1.0 : 1.0;
            }
            if (P.determinant() > 0.0)
            {
                result.push_back(P);
            }
        }
    } while (std::next_permutation(perm.begin(), perm.end()));
    return result;
}

// The rotations worth trying between two principal frames: the four sign flips when both
// shapes have well separated axes (relative eigenvalue gaps above kAxisGap), all 24 axis
// rotations when some axes are nearly interchangeable.
std::vector<Mat3> frame_rotations(const Mat3& a, const Mat3& b)
{
    auto gap = [](const Mat3& covariance)
    {
        const Eigen::SelfAdjointEigenSolver<Mat3> solver(covariance, Eigen::EigenvaluesOnly);
        const Vec3 l = solver.eigenvalues();
        return std::min(l(2) - l(1), l(1) - l(0)) / l(2);
    };
    std::vector<Mat3> all = axis_rotations();
    if (std::min(gap(a), gap(b)) < kAxisGap)
    {
        return all;
    }
    std::vector<Mat3> flips;
    for (const Mat3& P : all)
    {
        if (P.isDiagonal())
        {
            flips.push_back(P);
        }
    }
    return flips;
}

// A seeded random order of the usable vertices. Nested prefixes of it are the subsamples of
// every stage, so each stage sees the previous stage's points plus new ones. Deterministic
// because it depends only on the seed and the vertex count.
std::vector<std::int32_t> shuffled(std::vector<std::int32_t> rows, std::uint64_t seed)
{
    Rng rng(seed);
    for (std::size_t i = rows.size(); i > 1; --i)
    {
        const auto j = static_cast<std::size_t>(rng.below(i));
        std::swap(rows[i - 1], rows[j]);
    }
    return rows;
}

}  // namespace meshmark::detail
