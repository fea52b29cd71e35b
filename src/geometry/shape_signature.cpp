// SPDX-License-Identifier: MIT
// Shape distributions [Osada, Funkhouser, Chazelle, Dobkin 2002] of a surface and of the parts a
// plane crop leaves of it: the catalogue's index for finding a suspect's original.
#include "meshmark/geometry/shape_signature.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <tuple>

#include <Eigen/Eigenvalues>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"

namespace meshmark {
namespace {

using Vec3 = Eigen::Vector3d;

// Points drawn per surface: enough that two draws of one surface differ by about 1% of a
// distribution's step (measured on the shared meshes), few enough to index 100,000 assets in
// minutes. Pairs and triples drawn per view for the distance and angle distributions.
constexpr int kSamples = 8192;
constexpr int kPairs = 32768;
constexpr int kTriples = 16384;
// A crop view draws fewer: there are kShapeViews - 1 of them.
constexpr int kCropPairs = 8192;
constexpr int kCropTriples = 4096;
// Distributions: bins and the range they cover, in RMS radii (a point is rarely more than
// 2.5 radii from the centroid, two points rarely more than 3.5 apart); last bin open-ended.
constexpr int kCentroidBins = 6;
constexpr double kCentroidRange = 2.5;
constexpr int kPairBins = 12;
constexpr double kPairRange = 3.5;
constexpr int kAngleBins = 4;
// The fixed seed of the draw: a suspect and its original are drawn alike.
constexpr std::uint64_t kSeed = 0x5ea7c0de5eedULL;

// The draw: kSamples points by area (stratified over the cumulative area, so that every part of
// the surface gets its share), or the vertices of a point cloud or of a surface without area.
// The triangles are taken in an order that does not depend on the file (by their centroid's
// distance from the surface's centroid, each one's corners likewise), so a copy with its
// vertices or faces renumbered draws the same points.
std::vector<Vec3> surface_points(const TriangleMesh& mesh, int count = kSamples)
{
    struct Triangle
    {
        double key = 0.0;
        double area = 0.0;
        std::array<Vec3, 3> corners;
    };
    std::vector<Triangle> triangles;
    triangles.reserve(static_cast<std::size_t>(mesh.F.rows()));
    Vec3 weighted = Vec3::Zero();
    double total = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        Triangle t;
        for (int k = 0; k < 3; ++k)
        {
            t.corners[static_cast<std::size_t>(k)] = mesh.V.row(mesh.F(f, k)).transpose();
        }
        const auto& [a, b, c] = t.corners;
        t.area = 0.5 * (b - a).cross(c - a).norm();
        if (!(t.area > 0.0) || !std::isfinite(t.area))
        {
            continue;
        }
        weighted += t.area * (a + b + c) / 3.0;
        total += t.area;
        triangles.push_back(t);
    }
    std::vector<Vec3> points;
    points.reserve(static_cast<std::size_t>(count));
    Rng rng(kSeed);
    if (total > 0.0)
    {
        const Vec3 centre = weighted / total;
        for (Triangle& t : triangles)
        {
            std::sort(t.corners.begin(), t.corners.end(), [&](const Vec3& p, const Vec3& q)
                      { return std::make_tuple((p - centre).squaredNorm(), p.x(), p.y(), p.z()) <
                               std::make_tuple((q - centre).squaredNorm(), q.x(), q.y(), q.z()); });
            t.key = ((t.corners[0] + t.corners[1] + t.corners[2]) / 3.0 - centre).squaredNorm();
        }
        std::sort(triangles.begin(), triangles.end(), [](const Triangle& p, const Triangle& q)
                  { return std::tie(p.key, p.area) < std::tie(q.key, q.area); });
        std::vector<double> cumulative;
        cumulative.reserve(triangles.size());
        double sum = 0.0;
        for (const Triangle& t : triangles)
        {
            sum += t.area;
            cumulative.push_back(sum);
        }
        for (int i = 0; i < count; ++i)
        {
            const double at = (static_cast<double>(i) + rng.uniform()) / count * sum;
            const auto f = static_cast<std::size_t>(
                std::min<std::ptrdiff_t>(std::upper_bound(cumulative.begin(), cumulative.end(), at) - cumulative.begin(),
                                         static_cast<std::ptrdiff_t>(cumulative.size()) - 1));
            double u = rng.uniform();
            double v = rng.uniform();
            if (u + v > 1.0)
            {
                u = 1.0 - u;
                v = 1.0 - v;
            }
            const auto& [a, b, c] = triangles[f].corners;
            points.push_back(a + u * (b - a) + v * (c - a));
        }
        return points;
    }
    const auto n = static_cast<std::uint64_t>(mesh.V.rows());
    for (int i = 0; n > 0 && i < count; ++i)
    {
        points.push_back(mesh.V.row(static_cast<Eigen::Index>(rng.below(n))).transpose());
    }
    return points;
}

// The cumulative distribution of \p values over \p bins equal bins of [0, range) (the last also
// takes everything beyond), times \p weight: \p bins values written from \p out. Cumulative
// rather than per bin, so that a distribution shifted by less than a bin changes the features
// by that little (their distance is then the earth mover's distance between the two).
float* cumulative(const std::vector<double>& values, int bins, double range, float weight, float* out)
{
    std::vector<double> counts(static_cast<std::size_t>(bins), 0.0);
    for (const double x : values)
    {
        const int bin = std::clamp(static_cast<int>(x / range * bins), 0, bins - 1);
        counts[static_cast<std::size_t>(bin)] += 1.0;
    }
    double sum = 0.0;
    const double n = std::max<double>(1.0, static_cast<double>(values.size()));
    for (int b = 0; b < bins; ++b)
    {
        sum += counts[static_cast<std::size_t>(b)];
        *out++ = weight * static_cast<float>(sum / n);
    }
    return out;
}

// The features of the points \p points[i] for i in \p chosen.
ShapeFeatures features_of(const std::vector<Vec3>& points, const std::vector<std::int32_t>& chosen, int pair_count,
                          int triple_count)
{
    ShapeFeatures features{};
    const auto n = static_cast<std::uint64_t>(chosen.size());
    if (n < 3)
    {
        return features;
    }
    Vec3 centroid = Vec3::Zero();
    for (const std::int32_t i : chosen)
    {
        centroid += points[static_cast<std::size_t>(i)];
    }
    centroid /= static_cast<double>(n);
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const std::int32_t i : chosen)
    {
        const Vec3 d = points[static_cast<std::size_t>(i)] - centroid;
        covariance += d * d.transpose();
    }
    covariance /= static_cast<double>(n);
    const double radius = std::sqrt(covariance.trace());
    if (!(radius > 0.0) || !std::isfinite(radius))
    {
        return features;
    }
    Rng rng(kSeed ^ n);
    std::vector<double> to_centroid;
    to_centroid.reserve(chosen.size());
    for (const std::int32_t i : chosen)
    {
        to_centroid.push_back((points[static_cast<std::size_t>(i)] - centroid).norm() / radius);
    }
    auto pick = [&]() -> const Vec3& { return points[static_cast<std::size_t>(chosen[rng.below(n)])]; };
    std::vector<double> pairs;
    pairs.reserve(static_cast<std::size_t>(pair_count));
    for (int t = 0; t < pair_count; ++t)
    {
        const Vec3& a = pick();
        pairs.push_back((a - pick()).norm() / radius);
    }
    std::vector<double> angles;
    angles.reserve(static_cast<std::size_t>(triple_count));
    for (int t = 0; t < triple_count; ++t)
    {
        const Vec3& a = pick();
        const Vec3& b = pick();
        const Vec3& c = pick();
        const Vec3 u = a - b;
        const Vec3 v = c - b;
        const double norms = u.norm() * v.norm();
        if (norms > 0.0)
        {
            angles.push_back(std::acos(std::clamp(u.dot(v) / norms, -1.0, 1.0)));
        }
    }
    // Each block weighted by 1 / sqrt(its length): a block that differs entirely counts about
    // as much as another, whatever its number of values.
    float* out = features.data();
    out = cumulative(to_centroid, kCentroidBins, kCentroidRange, 1.0F / std::sqrt(float{kCentroidBins}), out);
    out = cumulative(pairs, kPairBins, kPairRange, 1.0F / std::sqrt(float{kPairBins}), out);
    out = cumulative(angles, kAngleBins, std::numbers::pi, 1.0F / std::sqrt(float{kAngleBins}), out);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance, Eigen::EigenvaluesOnly);
    const Vec3 l = solver.eigenvalues();  // ascending
    const float eigen_weight = 1.0F / std::sqrt(2.0F);
    *out++ = eigen_weight * static_cast<float>(l(1) / l(2));
    *out++ = eigen_weight * static_cast<float>(l(0) / l(2));
    return features;
}

// The crop directions: kShapeCropDirections points of a Fibonacci lattice on the sphere
// [Gonzalez 2010], nearly even; no direction is more than about 180 / sqrt(directions) degrees
// from one of them.
std::vector<Vec3> crop_directions()
{
    std::vector<Vec3> directions;
    const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < kShapeCropDirections; ++i)
    {
        const double z = 1.0 - (2.0 * i + 1.0) / kShapeCropDirections;
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        const double phi = golden_angle * i;
        directions.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
    }
    return directions;
}

// The points of \p order (sorted by their height along a direction) kept by a crop that leaves
// \p fraction of them on the high side.
std::vector<std::int32_t> kept(const std::vector<std::int32_t>& order, double fraction)
{
    const auto count = static_cast<std::size_t>(std::lround(fraction * static_cast<double>(order.size())));
    return {order.end() - static_cast<std::ptrdiff_t>(count), order.end()};
}

}  // namespace

Positions shape_sample(const TriangleMesh& mesh, int count)
{
    const std::vector<Vec3> points = surface_points(mesh, count);
    Positions sample(static_cast<Eigen::Index>(points.size()), 3);
    for (std::size_t i = 0; i < points.size(); ++i)
    {
        sample.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    }
    return sample;
}

ShapeFeatures shape_features(const TriangleMesh& mesh)
{
    const std::vector<Vec3> points = surface_points(mesh);
    std::vector<std::int32_t> all(points.size());
    std::iota(all.begin(), all.end(), 0);
    return features_of(points, all, kPairs, kTriples);
}

ShapeSignature shape_signature(const TriangleMesh& mesh)
{
    const std::vector<Vec3> points = surface_points(mesh);
    std::vector<std::int32_t> all(points.size());
    std::iota(all.begin(), all.end(), 0);
    ShapeSignature signature;
    signature.views.reserve(kShapeViews);
    signature.views.push_back(features_of(points, all, kPairs, kTriples));
    for (const Vec3& d : crop_directions())
    {
        std::vector<std::int32_t> order = all;
        std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b)
                         { return points[static_cast<std::size_t>(a)].dot(d) < points[static_cast<std::size_t>(b)].dot(d); });
        for (const double fraction : kShapeCropFractions)
        {
            signature.views.push_back(features_of(points, kept(order, fraction), kCropPairs, kCropTriples));
        }
    }
    return signature;
}

float shape_distance(const ShapeFeatures& a, const ShapeFeatures& b) noexcept
{
    float sum = 0.0F;
    for (int i = 0; i < kShapeFeatures; ++i)
    {
        const float d = a[static_cast<std::size_t>(i)] - b[static_cast<std::size_t>(i)];
        sum += d * d;
    }
    return std::sqrt(sum);
}

std::vector<std::uint8_t> ShapeSignature::to_bytes() const
{
    std::vector<std::uint8_t> bytes;
    bytes.reserve(views.size() * kShapeFeatures);
    for (const ShapeFeatures& view : views)
    {
        for (const float x : view)
        {
            bytes.push_back(static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0F, 1.0F) * 255.0F)));
        }
    }
    return bytes;
}

ShapeSignature ShapeSignature::from_bytes(std::span<const std::uint8_t> bytes)
{
    constexpr std::size_t kViewBytes = kShapeFeatures;
    if (bytes.size() % kViewBytes != 0)
    {
        throw InvalidOption("a shape signature of " + std::to_string(bytes.size()) +
                            " bytes is not a whole number of views.");
    }
    ShapeSignature signature;
    signature.views.resize(bytes.size() / kViewBytes);
    for (std::size_t v = 0; v < signature.views.size(); ++v)
    {
        for (std::size_t i = 0; i < kShapeFeatures; ++i)
        {
            signature.views[v][i] = static_cast<float>(bytes[v * kViewBytes + i]) / 255.0F;
        }
    }
    return signature;
}

}  // namespace meshmark
