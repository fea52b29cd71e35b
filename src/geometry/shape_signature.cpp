// SPDX-License-Identifier: MIT
// Shape distributions [Osada, Funkhouser, Chazelle, Dobkin 2002] of a surface and of the parts a
// plane crop leaves of it: the catalogue's index for finding a suspect's original.
#include "meshmark/geometry/shape_signature.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>
#include <tuple>

#include <Eigen/Eigenvalues>

#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/core/rng.h"

namespace meshmark
{
namespace
{

using Vec3 = Eigen::Vector3d;

// Points drawn per surface, and pairs and triples of them for the distance and angle
// distributions (every view uses those that fall inside it). Chosen on the shape-index study
// (bench/results/2026-11-29-catalogue.md, "The shape index alone"): with 2,048 points drawn in
// the file's face order reordered copies ranked first in 11 of 24; a signature costs about 25 ms.
constexpr int kSamples = 4096;
constexpr int kPairs = 16384;
constexpr int kTriples = 16384;
// Distributions: bins and the range they cover, in RMS radii (a point is rarely more than
// 2.5 radii from the centroid, two points rarely more than 3.5 apart); last bin open-ended.
constexpr int kCentroidBins = 6;
constexpr double kCentroidRange = 2.5;
constexpr int kPairBins = 12;
constexpr double kPairRange = 3.5;
constexpr int kAngleBins = 4;  // bin counts chosen by hand; no study on record
// The angle between the normals of a pair's points, as |cos| in bins of equal width (either
// orientation: artists' models mix them). Six bins: a box's pairs are parallel or at right
// angles, a turned part's spread; chosen by hand, measured on the shape-index study
// (bench/results/2026-11-30-scan-speed.md).
constexpr int kNormalBins = 6;
// The fixed seed of the draw: a suspect and its original are drawn alike.
constexpr std::uint64_t kSeed = 0x5ea7c0de5eedULL;

// The draw: kSamples points by area (stratified over the cumulative area, so that every part of
// the surface gets its share), or the vertices of a point cloud or of a surface without area.
// The triangles are taken in an order that does not depend on the file (by their centroid's
// distance from the surface's centroid, each one's corners likewise), so a copy with its
// vertices or faces renumbered draws the same points. With each point, when \p normals is given,
// the unit normal of the triangle it lies on (zero for a vertex of a point cloud).
std::vector<Vec3> surface_points(const TriangleMesh& mesh, int count = kSamples,
                                 std::vector<Vec3>* normals = nullptr)
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
            std::sort(t.corners.begin(), t.corners.end(),
                      [&](const Vec3& p, const Vec3& q)
                      {
                          return std::make_tuple((p - centre).squaredNorm(), p.x(), p.y(), p.z()) <
                                 std::make_tuple((q - centre).squaredNorm(), q.x(), q.y(), q.z());
                      });
            t.key = ((t.corners[0] + t.corners[1] + t.corners[2]) / 3.0 - centre).squaredNorm();
        }
        std::sort(triangles.begin(), triangles.end(),
                  [](const Triangle& p, const Triangle& q)
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
            const auto f = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
                std::upper_bound(cumulative.begin(), cumulative.end(), at) - cumulative.begin(),
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
            if (normals != nullptr)
            {
                normals->push_back((b - a).cross(c - a).normalized());
            }
        }
        return points;
    }
    const auto n = static_cast<std::uint64_t>(mesh.V.rows());
    for (int i = 0; n > 0 && i < count; ++i)
    {
        points.push_back(mesh.V.row(static_cast<Eigen::Index>(rng.below(n))).transpose());
        if (normals != nullptr)
        {
            normals->push_back(Vec3::Zero());
        }
    }
    return points;
}

// A fast deterministic stream for the pair and triple draws (a SplitMix64 counter and Lemire's
// multiply-shift of its high 32 bits to [0, n)): the draws are millions per asset, where
// std::mt19937_64 with rejection sampling took half the time. Biased by under n / 2^32, which
// for a view's at most kSamples points is nothing the distributions can show.
class Draw
{
public:
    explicit Draw(std::uint64_t seed) : state_(seed) {}
    std::size_t below(std::size_t n)
    {
        return static_cast<std::size_t>(((splitmix64(state_++) >> 32U) * n) >> 32U);
    }

private:
    std::uint64_t state_;
};

// The counts of \p bins bins turned into their cumulative distribution, times \p weight:
// \p bins values written from \p out. Cumulative rather than per bin, so that a distribution
// shifted by less than a bin changes the features by that little (their distance is then the
// earth mover's distance between the two).
float* cumulative(const std::vector<int>& counts, float weight, float* out)
{
    const double n = std::max(1, std::accumulate(counts.begin(), counts.end(), 0));
    int sum = 0;
    for (const int c : counts)
    {
        sum += c;
        *out++ = weight * static_cast<float>(sum / n);
    }
    return out;
}

// The bin of \p x (a distance in bin widths) among \p bins bins, the last open-ended.
std::size_t bin_of(double x, int bins)
{
    return static_cast<std::size_t>(std::min(x, bins - 0.5));
}

// The draws every view shares: pairs of sample points with their distance (in ascending order
// of it), triples with the bin of their angle. A view uses those whose points it all holds, so a
// crop view measures the draws of the whole that fall inside it (no draws of its own, and no random
// access).
struct Draws
{
    std::vector<std::array<std::int32_t, 2>> pairs;
    std::vector<double> pair_distance;
    std::vector<std::array<std::int32_t, 3>> triples;
    std::vector<std::uint8_t> triple_bin;
    std::vector<std::uint8_t> normal_bin;  ///< per pair, in the pairs' order
};

Draws draw(const std::vector<Vec3>& points, const std::vector<Vec3>& normals)
{
    Draws d;
    const std::size_t n = points.size();
    if (n < 3)
    {
        return d;
    }
    Draw stream(kSeed ^ n);
    d.pairs.reserve(kPairs);
    d.pair_distance.reserve(kPairs);
    for (int t = 0; t < kPairs; ++t)
    {
        const auto i = static_cast<std::int32_t>(stream.below(n));
        const auto j = static_cast<std::int32_t>(stream.below(n));
        d.pairs.push_back({i, j});
        d.pair_distance.push_back(
            (points[static_cast<std::size_t>(i)] - points[static_cast<std::size_t>(j)]).norm());
    }
    // By distance: a view's pairs in one bin are then a run, found by a binary search per bin
    // edge (nested_features); the counts do not depend on the order.
    std::vector<std::size_t> order(d.pairs.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b)
                     { return d.pair_distance[a] < d.pair_distance[b]; });
    Draws sorted;
    sorted.pairs.reserve(order.size());
    sorted.pair_distance.reserve(order.size());
    for (const std::size_t t : order)
    {
        sorted.pairs.push_back(d.pairs[t]);
        sorted.pair_distance.push_back(d.pair_distance[t]);
    }
    d.pairs = std::move(sorted.pairs);
    d.pair_distance = std::move(sorted.pair_distance);
    d.normal_bin.reserve(d.pairs.size());
    for (const auto& [i, j] : d.pairs)
    {
        const double cosine = std::abs(
            normals[static_cast<std::size_t>(i)].dot(normals[static_cast<std::size_t>(j)]));
        d.normal_bin.push_back(
            static_cast<std::uint8_t>(bin_of(cosine * kNormalBins, kNormalBins)));
    }
    // Angle bins by their cosines (descending with the angle): no acos per triple.
    std::array<double, kAngleBins - 1> cosine_edges{};
    for (int b = 1; b < kAngleBins; ++b)
    {
        cosine_edges[static_cast<std::size_t>(b - 1)] = std::cos(std::numbers::pi * b / kAngleBins);
    }
    for (int t = 0; t < kTriples; ++t)
    {
        const std::array<std::int32_t, 3> abc = {static_cast<std::int32_t>(stream.below(n)),
                                                 static_cast<std::int32_t>(stream.below(n)),
                                                 static_cast<std::int32_t>(stream.below(n))};
        const Vec3 u =
            points[static_cast<std::size_t>(abc[0])] - points[static_cast<std::size_t>(abc[1])];
        const Vec3 v =
            points[static_cast<std::size_t>(abc[2])] - points[static_cast<std::size_t>(abc[1])];
        const double norms = std::sqrt(u.squaredNorm() * v.squaredNorm());
        if (!(norms > 0.0))
        {
            continue;
        }
        const double cosine = u.dot(v) / norms;
        d.triples.push_back(abc);
        d.triple_bin.push_back(static_cast<std::uint8_t>(std::count_if(
            cosine_edges.begin(), cosine_edges.end(), [&](double edge) { return cosine < edge; })));
    }
    return d;
}

// The features of nested views of one sample: point i belongs to views 0 .. level[i] - 1 (each
// view a subset of the one before). Writes \p views features, one per view, from \p out.
void nested_features(const std::vector<Vec3>& points, const Draws& draws,
                     const std::vector<std::uint8_t>& level, int views, ShapeFeatures* out)
{
    const auto count = static_cast<std::size_t>(views);
    // Moments per view: the points of level >= v + 1.
    // (Summed per level, then over the levels at or above each view: one pass, no per-view work
    // per point.)
    std::vector<double> weight(count + 1, 0.0);
    std::vector<Vec3> first(count + 1, Vec3::Zero());
    std::vector<Eigen::Matrix3d> second(count + 1, Eigen::Matrix3d::Zero());
    for (std::size_t i = 0; i < points.size(); ++i)
    {
        const std::size_t l = level[i];
        weight[l] += 1.0;
        first[l] += points[i];
        second[l].noalias() += points[i] * points[i].transpose();
    }
    for (std::size_t l = count; l > 1; --l)
    {
        weight[l - 1] += weight[l];
        first[l - 1] += first[l];
        second[l - 1] += second[l];
    }
    // View v holds the points of level >= v + 1.
    weight.erase(weight.begin());
    first.erase(first.begin());
    second.erase(second.begin());
    std::vector<Vec3> centroid(count);
    std::vector<Eigen::Matrix3d> covariance(count);
    std::vector<double> radius(count, 0.0);
    // Bins of equal width: a bin is a product and a conversion (no search, no branch).
    std::vector<double> centroid_scale(count, 0.0);
    std::vector<double> pair_scale(count, 0.0);
    for (std::size_t v = 0; v < count; ++v)
    {
        out[v] = ShapeFeatures{};
        if (weight[v] < 3.0)
        {
            continue;
        }
        centroid[v] = first[v] / weight[v];
        covariance[v] = second[v] / weight[v] - centroid[v] * centroid[v].transpose();
        radius[v] = std::sqrt(std::max(0.0, covariance[v].trace()));
        centroid_scale[v] = kCentroidBins / (kCentroidRange * radius[v]);
        pair_scale[v] = kPairBins / (kPairRange * radius[v]);
    }
    const auto usable = [&](std::size_t v) { return radius[v] > 0.0 && std::isfinite(radius[v]); };
    std::vector<std::vector<int>> to_centroid(count, std::vector<int>(kCentroidBins, 0));
    for (std::size_t i = 0; i < points.size(); ++i)
    {
        for (std::size_t v = 0; v < level[i]; ++v)
        {
            if (usable(v))
            {
                ++to_centroid[v][bin_of((points[i] - centroid[v]).norm() * centroid_scale[v],
                                        kCentroidBins)];
            }
        }
    }
    // The pairs by distance: in view v, the pairs of bin b or below are those before the first
    // whose distance reaches bin b + 1 (the same product bin_of takes the floor of, so the counts
    // are those of binning each pair) and whose points the view holds. A pair lies in the views
    // below the smaller of its points' levels.
    const std::size_t pair_count = draws.pairs.size();
    std::vector<std::uint8_t> pair_in(pair_count);
    for (std::size_t t = 0; t < pair_count; ++t)
    {
        const auto& [i, j] = draws.pairs[t];
        pair_in[t] =
            std::min(level[static_cast<std::size_t>(i)], level[static_cast<std::size_t>(j)]);
    }
    std::vector<std::vector<int>> pairs(count, std::vector<int>(kPairBins, 0));
    for (std::size_t v = 0; v < count; ++v)
    {
        if (!usable(v))
        {
            continue;
        }
        std::size_t from = 0;
        int below = 0;  // pairs of the view before `from`
        int previous = 0;
        for (int b = 0; b < kPairBins; ++b)
        {
            const auto to =
                b + 1 < kPairBins
                    ? static_cast<std::size_t>(
                          std::partition_point(
                              draws.pair_distance.begin() + static_cast<std::ptrdiff_t>(from),
                              draws.pair_distance.end(),
                              [&](double d) { return d * pair_scale[v] < b + 1; }) -
                          draws.pair_distance.begin())
                    : pair_count;
            for (std::size_t t = from; t < to; ++t)
            {
                below += pair_in[t] > v ? 1 : 0;
            }
            pairs[v][static_cast<std::size_t>(b)] = below - previous;
            previous = below;
            from = to;
        }
    }
    // Triples by the smallest level of their points and their angle's bin, pairs by theirs and
    // their normals' bin (neither bin depends on the view), then summed over the levels above
    // each view.
    const auto by_view = [count](const std::vector<std::vector<int>>& by_level)
    {
        std::vector<std::vector<int>> per_view(count, std::vector<int>(by_level[0].size(), 0));
        for (std::size_t v = 0; v < count; ++v)
        {
            for (std::size_t l = v + 1; l <= count; ++l)
            {
                for (std::size_t b = 0; b < per_view[v].size(); ++b)
                {
                    per_view[v][b] += by_level[l][b];
                }
            }
        }
        return per_view;
    };
    std::vector<std::vector<int>> triple_level(count + 1, std::vector<int>(kAngleBins, 0));
    for (std::size_t t = 0; t < draws.triples.size(); ++t)
    {
        const auto& [i, j, k] = draws.triples[t];
        const std::size_t in =
            std::min({level[static_cast<std::size_t>(i)], level[static_cast<std::size_t>(j)],
                      level[static_cast<std::size_t>(k)]});
        ++triple_level[in][draws.triple_bin[t]];
    }
    const std::vector<std::vector<int>> angles = by_view(triple_level);
    std::vector<std::vector<int>> normal_level(count + 1, std::vector<int>(kNormalBins, 0));
    for (std::size_t t = 0; t < pair_count; ++t)
    {
        ++normal_level[pair_in[t]][draws.normal_bin[t]];
    }
    const std::vector<std::vector<int>> normals = by_view(normal_level);
    for (std::size_t v = 0; v < count; ++v)
    {
        if (!usable(v))
        {
            continue;
        }
        // Each block weighted by 1 / sqrt(its length): a block that differs entirely counts
        // about as much as another, whatever its number of values.
        float* at = out[v].data();
        at = cumulative(to_centroid[v], 1.0F / std::sqrt(float{kCentroidBins}), at);
        at = cumulative(pairs[v], 1.0F / std::sqrt(float{kPairBins}), at);
        at = cumulative(angles[v], 1.0F / std::sqrt(float{kAngleBins}), at);
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance[v],
                                                                    Eigen::EigenvaluesOnly);
        const Vec3 l = solver.eigenvalues().cwiseMax(0.0);  // ascending
        const float eigen_weight = 1.0F / std::sqrt(2.0F);
        *at++ = eigen_weight * static_cast<float>(l(2) > 0.0 ? l(1) / l(2) : 0.0);
        *at++ = eigen_weight * static_cast<float>(l(2) > 0.0 ? l(0) / l(2) : 0.0);
        // After the features of positions (kShapePositionFeatures), which catalogues of older
        // builds hold alone: at half a block's weight, the normals rank crops far better without
        // ranking noised, smoothed and remeshed copies much worse (the study above).
        at = cumulative(normals[v], 0.5F / std::sqrt(float{kNormalBins}), at);
    }
}

}  // namespace

// The crop directions: kShapeCropDirections points of a Fibonacci lattice on the sphere
// [Gonzalez 2010], nearly even; no direction is more than about 180 / sqrt(directions) degrees
// from one of them.
std::vector<Eigen::Vector3d> shape_crop_directions()
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

Positions shape_sample(const TriangleMesh& mesh, int count, Positions* normals)
{
    std::vector<Vec3> drawn_normals;
    const std::vector<Vec3> points =
        surface_points(mesh, count, normals != nullptr ? &drawn_normals : nullptr);
    Positions sample(static_cast<Eigen::Index>(points.size()), 3);
    for (std::size_t i = 0; i < points.size(); ++i)
    {
        sample.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    }
    if (normals != nullptr)
    {
        normals->resize(sample.rows(), 3);
        for (std::size_t i = 0; i < drawn_normals.size(); ++i)
        {
            normals->row(static_cast<Eigen::Index>(i)) = drawn_normals[i].transpose();
        }
    }
    return sample;
}

ShapeFeatures shape_features(const TriangleMesh& mesh)
{
    std::vector<Vec3> normals;
    const std::vector<Vec3> points = surface_points(mesh, kSamples, &normals);
    ShapeFeatures whole;
    nested_features(points, draw(points, normals), std::vector<std::uint8_t>(points.size(), 1), 1,
                    &whole);
    return whole;
}

ShapeSignature shape_signature(const TriangleMesh& mesh)
{
    std::vector<Vec3> normals;
    const std::vector<Vec3> points = surface_points(mesh, kSamples, &normals);
    const Draws draws = draw(points, normals);
    const std::size_t n = points.size();
    ShapeSignature signature;
    signature.points = shape_sample(mesh, kShapePoints, &signature.normals);
    signature.views.resize(kShapeViews);
    nested_features(points, draws, std::vector<std::uint8_t>(n, 1), 1, signature.views.data());
    // Per direction, the crop views are nested (a smaller kept fraction keeps a subset): each
    // point's level is the number of them it lies in, from the fractions' height quantiles.
    constexpr std::size_t kFractions = kShapeCropFractions.size();
    std::vector<std::uint8_t> level(n);
    std::vector<double> heights(n);
    std::vector<double> sorted(n);
    ShapeFeatures* out = signature.views.data() + 1;
    for (const Vec3& d : shape_crop_directions())
    {
        for (std::size_t i = 0; i < n; ++i)
        {
            heights[i] = points[i].dot(d);
        }
        std::array<double, kFractions> threshold{};  // largest fraction first
        sorted = heights;
        std::size_t settled = 0;  // the heights before it are at most the last threshold
        for (std::size_t f = 0; f < kFractions; ++f)
        {
            const double fraction = kShapeCropFractions[kFractions - 1 - f];
            const auto drop = std::min(
                static_cast<std::size_t>(std::lround((1.0 - fraction) * static_cast<double>(n))),
                n - 1);
            // The drops grow with f: each selection searches only above the one before.
            std::nth_element(sorted.begin() + static_cast<std::ptrdiff_t>(settled),
                             sorted.begin() + static_cast<std::ptrdiff_t>(drop), sorted.end());
            threshold[f] = sorted[drop];
            settled = drop;
        }
        for (std::size_t i = 0; i < n; ++i)
        {
            level[i] = static_cast<std::uint8_t>(std::count_if(
                threshold.begin(), threshold.end(), [&](double t) { return heights[i] >= t; }));
        }
        // Views come out largest fraction first; the signature lists them by kShapeCropFractions.
        std::array<ShapeFeatures, kFractions> nested{};
        nested_features(points, draws, level, static_cast<int>(kFractions), nested.data());
        for (std::size_t f = 0; f < kFractions; ++f)
        {
            *out++ = nested[kFractions - 1 - f];
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

}  // namespace meshmark
