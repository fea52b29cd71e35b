// SPDX-License-Identifier: MIT
// Shape distributions [Osada, Funkhouser, Chazelle, Dobkin 2002] of a surface and of the parts a
// plane crop leaves of it: the catalogue's index for finding a suspect's original.
#include "meshmark/geometry/shape_signature.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <span>

#include <Eigen/Eigenvalues>

#include "geometry/shape_draw.h"

namespace meshmark
{
namespace
{

using namespace shape_detail;

// Distributions: bins and the range they cover, in RMS radii (a point is rarely more than
// 2.5 radii from the centroid, two points rarely more than 3.5 apart); last bin open-ended.
constexpr int kCentroidBins = 6;
constexpr double kCentroidRange = 2.5;
constexpr int kPairBins = 12;
constexpr double kPairRange = 3.5;
// The nested views of one sample (the crop fractions of a direction, or the whole): a point's
// level is the number of them it lies in.
constexpr std::size_t kFractions = kShapeCropFractions.size();
constexpr std::size_t kLevels = kFractions + 1;

// The counts of \p bins bins turned into their cumulative distribution, times \p weight:
// \p bins values written from \p out. Cumulative rather than per bin, so that a distribution
// shifted by less than a bin changes the features by that little (their distance is then the
// earth mover's distance between the two).
float* cumulative(std::span<const int> counts, float weight, float* out)
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

// Buffers of nested_features, kept from view to view (a signature takes 65 calls).
struct Scratch
{
    std::vector<double> x, y, z;      ///< the points by level, highest first
    std::vector<std::uint64_t> code;  ///< per point, kLevelCode of its level
};

// A point's level as a code whose 16-bit field v is 1 when the point lies in view v: the AND of
// two or three points' codes is that of the views holding them all, so summing codes counts the
// pairs and triples of every view at once, and without branches (16 bits hold kPairs and
// kTriples; the counts per level and per view they replace took a fifth of the time).
constexpr std::array<std::uint64_t, kLevels> kLevelCode = {0, 0x1, 0x10001, 0x100010001,
                                                           0x1000100010001};
static_assert(kLevels == kLevelCode.size());
int field(std::uint64_t counts, std::size_t v)
{
    return static_cast<int>((counts >> (16U * v)) & 0xffffU);
}

// The sum of the codes of draws [from, to), each the AND of its points' codes. Left scalar: GCC
// vectorizes the loop into gathers made of shuffles, 5% slower over the signature.
#if defined(__GNUC__) && !defined(__clang__)
#define MESHMARK_SCALAR_LOOPS __attribute__((optimize("no-tree-vectorize")))
#else
#define MESHMARK_SCALAR_LOOPS
#endif
template <std::size_t K>
MESHMARK_SCALAR_LOOPS std::uint64_t sum_codes(
    const std::vector<std::array<std::uint16_t, K>>& draws, std::size_t from, std::size_t to,
    const std::vector<std::uint64_t>& code)
{
    std::uint64_t sum = 0;
    for (std::size_t t = from; t < to; ++t)
    {
        std::uint64_t all = ~std::uint64_t{0};
        for (const std::uint16_t i : draws[t])
        {
            all &= code[i];
        }
        sum += all;
    }
    return sum;
}

// The features of nested views of one sample: point i belongs to views 0 .. level[i] - 1 (each
// view a subset of the one before). Writes \p views features, one per view, from \p out.
void nested_features(const std::vector<Vec3>& points, const Draws& draws,
                     const std::vector<std::int32_t>& level, std::size_t count, ShapeFeatures* out,
                     Scratch& s)
{
    const std::size_t n = points.size();
    // The points by level, highest first, in their order within a level: view v holds the
    // first end[v + 1] of them, and each level's moments are summed in the points' order.
    std::array<std::size_t, kLevels + 1> end{};  // end[l]: the points of level l or above
    for (std::size_t i = 0; i < n; ++i)
    {
        ++end[static_cast<std::size_t>(level[i])];
    }
    for (std::size_t l = count; l-- > 0;)
    {
        end[l] += end[l + 1];
    }
    std::array<std::size_t, kLevels> at{};
    for (std::size_t l = 0; l <= count; ++l)
    {
        at[l] = end[l + 1];
    }
    s.x.resize(n);
    s.y.resize(n);
    s.z.resize(n);
    s.code.resize(n);
    for (std::size_t i = 0; i < n; ++i)
    {
        const auto l = static_cast<std::size_t>(level[i]);
        const std::size_t p = at[l]++;
        s.x[p] = points[i].x();
        s.y[p] = points[i].y();
        s.z[p] = points[i].z();
        s.code[i] = kLevelCode[l];
    }
    // Moments per level, then summed over the levels at or above each view (view v holds the
    // points of level >= v + 1). The sums are those of the points in order, as Eigen's p p^T
    // and += gave them.
    std::array<double, kLevels> weight{};
    std::array<Vec3, kLevels> first;
    std::array<Eigen::Matrix3d, kLevels> second;
    for (std::size_t l = 1; l <= count; ++l)
    {
        std::array<double, 9> m{};  // x, y, z, xx, xy, xz, yy, yz, zz
        for (std::size_t p = end[l + 1]; p < end[l]; ++p)
        {
            const double x = s.x[p];
            const double y = s.y[p];
            const double z = s.z[p];
            m[0] += x;
            m[1] += y;
            m[2] += z;
            m[3] += x * x;
            m[4] += x * y;
            m[5] += x * z;
            m[6] += y * y;
            m[7] += y * z;
            m[8] += z * z;
        }
        weight[l] = static_cast<double>(end[l] - end[l + 1]);
        first[l] = Vec3(m[0], m[1], m[2]);
        second[l] << m[3], m[4], m[5], m[4], m[6], m[7], m[5], m[7], m[8];
    }
    for (std::size_t l = count; l > 1; --l)
    {
        weight[l - 1] += weight[l];
        first[l - 1] += first[l];
        second[l - 1] += second[l];
    }
    // Per view (index v + 1 of the per-level arrays).
    std::array<Vec3, kFractions> centroid;
    std::array<Eigen::Matrix3d, kFractions> covariance;
    std::array<double, kFractions> radius{};
    // Bins of equal width: a bin is a product and a conversion (no search, no branch).
    std::array<double, kFractions> centroid_scale{};
    std::array<double, kFractions> pair_scale{};
    for (std::size_t v = 0; v < count; ++v)
    {
        out[v] = ShapeFeatures{};
        if (weight[v + 1] < 3.0)
        {
            continue;
        }
        centroid[v] = first[v + 1] / weight[v + 1];
        covariance[v] = second[v + 1] / weight[v + 1] - centroid[v] * centroid[v].transpose();
        radius[v] = std::sqrt(std::max(0.0, covariance[v].trace()));
        centroid_scale[v] = kCentroidBins / (kCentroidRange * radius[v]);
        pair_scale[v] = kPairBins / (kPairRange * radius[v]);
    }
    const auto usable = [&](std::size_t v) { return radius[v] > 0.0 && std::isfinite(radius[v]); };
    // Distances to the centroid, binned as before by the floor of sqrt(s) * scale (Eigen's norm:
    // the root of s = (x^2 + y^2) + z^2), counted as the number at or above each bin edge. Both
    // roundings are monotone, so a point reaches edge b exactly when s reaches the least s that
    // does (found next to b^2 / scale^2): no root per point (the loop with a root per point took
    // an eighth of the time). Counted in doubles (exact), which the compiler vectorizes.
    std::array<std::array<int, kCentroidBins>, kFractions> to_centroid{};
    for (std::size_t v = 0; v < count; ++v)
    {
        if (!usable(v))
        {
            continue;
        }
        const double scale = centroid_scale[v];
        std::array<double, kCentroidBins> edge{};
        for (int b = 1; b < kCentroidBins; ++b)
        {
            const auto reaches = [&](double x) { return std::sqrt(x) * scale >= b; };
            double& e = edge[static_cast<std::size_t>(b)];
            e = (b / scale) * (b / scale);
            while (e > 0.0 && reaches(std::nextafter(e, 0.0)))
            {
                e = std::nextafter(e, 0.0);
            }
            while (!reaches(e))
            {
                e = std::nextafter(e, std::numeric_limits<double>::infinity());
            }
        }
        std::array<double, kCentroidBins> at_least{};  // [b]: the points of bin b or above
        const Vec3 c = centroid[v];
        for (std::size_t p = 0; p < end[v + 1]; ++p)
        {
            const double dx = s.x[p] - c.x();
            const double dy = s.y[p] - c.y();
            const double dz = s.z[p] - c.z();
            const double squared = dx * dx + dy * dy + dz * dz;
            for (std::size_t b = 1; b < kCentroidBins; ++b)
            {
                at_least[b] += squared >= edge[b] ? 1.0 : 0.0;
            }
        }
        at_least[0] = static_cast<double>(end[v + 1]);
        for (std::size_t b = 0; b < kCentroidBins; ++b)
        {
            to_centroid[v][b] = static_cast<int>(at_least[b]) -
                                (b + 1 < kCentroidBins ? static_cast<int>(at_least[b + 1]) : 0);
        }
    }
    // The pairs by distance: in view v, the pairs of bin b or below are those before the first
    // whose distance reaches bin b + 1 (the same product bin_of takes the floor of, so the counts
    // are those of binning each pair) and whose points the view holds. Those edges of every view
    // in ascending order; then, per normals' bin, its pairs' codes summed up to each edge (where
    // it falls among them: normal_below), one pass over the pairs for both distributions.
    std::array<std::pair<std::size_t, std::size_t>, kFractions*(kPairBins - 1)> edges{};
    std::size_t edge_count = 0;
    for (std::size_t v = 0; v < count; ++v)
    {
        std::size_t from = 0;
        for (int b = 0; usable(v) && b + 1 < kPairBins; ++b)
        {
            from = static_cast<std::size_t>(
                std::partition_point(
                    draws.pair_distance.begin() + static_cast<std::ptrdiff_t>(from),
                    draws.pair_distance.end(),
                    [&](double d) { return d * pair_scale[v] < b + 1; }) -
                draws.pair_distance.begin());
            edges[edge_count++] = {from, v * kPairBins + static_cast<std::size_t>(b)};
        }
    }
    std::sort(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(edge_count));
    // Per view and bin, the pairs below the bin's upper edge; per normals' bin, all its pairs.
    std::array<std::uint64_t, kFractions * kPairBins> below{};
    std::array<std::uint64_t, kNormalBins> normal{};
    for (std::size_t b = 0; b < kNormalBins; ++b)
    {
        std::uint64_t sum = 0;
        std::size_t t = draws.normal_from[b];
        for (std::size_t e = 0; e < edge_count; ++e)
        {
            const std::size_t to = draws.normal_from[b] + draws.normal_below[edges[e].first][b];
            sum += sum_codes(draws.pairs, t, to, s.code);
            t = to;
            below[edges[e].second] += sum;
        }
        normal[b] = sum + sum_codes(draws.pairs, t, draws.normal_from[b + 1], s.code);
    }
    const std::uint64_t sum = std::accumulate(normal.begin(), normal.end(), std::uint64_t{0});
    std::array<std::uint64_t, kAngleBins> angle{};
    for (std::size_t b = 0; b < kAngleBins; ++b)
    {
        angle[b] = sum_codes(draws.triples, draws.triple_from[b], draws.triple_from[b + 1], s.code);
    }
    for (std::size_t v = 0; v < count; ++v)
    {
        if (!usable(v))
        {
            continue;
        }
        std::array<int, kPairBins> pairs{};
        std::array<int, kAngleBins> angles{};
        std::array<int, kNormalBins> normals{};
        int previous = 0;
        for (std::size_t b = 0; b < kPairBins; ++b)
        {
            const int upto = field(b + 1 < kPairBins ? below[v * kPairBins + b] : sum, v);
            pairs[b] = upto - previous;
            previous = upto;
        }
        for (std::size_t b = 0; b < kAngleBins; ++b)
        {
            angles[b] = field(angle[b], v);
        }
        for (std::size_t b = 0; b < kNormalBins; ++b)
        {
            normals[b] = field(normal[b], v);
        }
        // Each block weighted by 1 / sqrt(its length): a block that differs entirely counts
        // about as much as another, whatever its number of values.
        float* at_feature = out[v].data();
        at_feature = cumulative(to_centroid[v], 1.0F / std::sqrt(float{kCentroidBins}), at_feature);
        at_feature = cumulative(pairs, 1.0F / std::sqrt(float{kPairBins}), at_feature);
        at_feature = cumulative(angles, 1.0F / std::sqrt(float{kAngleBins}), at_feature);
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance[v],
                                                                    Eigen::EigenvaluesOnly);
        const Vec3 l = solver.eigenvalues().cwiseMax(0.0);  // ascending
        const float eigen_weight = 1.0F / std::sqrt(2.0F);
        *at_feature++ = eigen_weight * static_cast<float>(l(2) > 0.0 ? l(1) / l(2) : 0.0);
        *at_feature++ = eigen_weight * static_cast<float>(l(2) > 0.0 ? l(0) / l(2) : 0.0);
        // After the features of positions (kShapePositionFeatures), which catalogues of older
        // builds hold alone: at half a block's weight, the normals rank crops far better without
        // ranking noised, smoothed and remeshed copies much worse (the study of kNormalBins).
        at_feature = cumulative(normals, 0.5F / std::sqrt(float{kNormalBins}), at_feature);
    }
}

// The heights of the points along a direction in kBuckets buckets of equal width: a monotone map,
// so the k-th smallest height lies in the bucket where the counts below reach k.
constexpr std::size_t kBuckets = 1024;

// The order statistics \p rank (ascending) of \p heights, as nth_element gives them, found
// among few: nth_element on the heights of the bucket (\p bucket, per height) each lies in
// alone. (A quarter of the signature's time went to nth_element on all 4,096.) Without buckets
// (heights not all finite, or spread too little): nth_element on all, as before.
std::array<double, kFractions> order_statistics(const std::vector<double>& heights,
                                                const std::vector<std::int32_t>& bucket,
                                                const std::array<std::size_t, kFractions>& rank,
                                                std::vector<double>& scratch)
{
    std::array<double, kFractions> value{};
    if (bucket.empty())
    {
        scratch = heights;
        std::size_t settled = 0;  // the heights before it are at most the last value
        for (std::size_t f = 0; f < kFractions; ++f)
        {
            // The ranks grow with f: each selection searches only above the one before.
            std::nth_element(scratch.begin() + static_cast<std::ptrdiff_t>(settled),
                             scratch.begin() + static_cast<std::ptrdiff_t>(rank[f]), scratch.end());
            value[f] = scratch[rank[f]];
            settled = rank[f];
        }
        return value;
    }
    std::array<std::uint32_t, kBuckets + 1> below{};  // [k]: the heights in the buckets below k
    for (const std::int32_t k : bucket)
    {
        ++below[static_cast<std::size_t>(k) + 1];
    }
    std::partial_sum(below.begin(), below.end(), below.begin());
    // The heights of the buckets of the ranks, each bucket's together (a bucket's end after).
    std::array<std::int32_t, kBuckets> end;
    end.fill(-1);
    std::array<std::size_t, kFractions> in{};
    std::int32_t size = 0;
    for (std::size_t f = 0; f < kFractions; ++f)
    {
        in[f] = static_cast<std::size_t>(std::upper_bound(below.begin(), below.end(), rank[f]) -
                                         below.begin()) -
                1;
        if (end[in[f]] < 0)
        {
            end[in[f]] = size;
            size += static_cast<std::int32_t>(below[in[f] + 1] - below[in[f]]);
        }
    }
    scratch.resize(static_cast<std::size_t>(size));
    for (std::size_t i = 0; i < heights.size(); ++i)
    {
        std::int32_t& at = end[static_cast<std::size_t>(bucket[i])];
        if (at >= 0)
        {
            scratch[static_cast<std::size_t>(at++)] = heights[i];
        }
    }
    for (std::size_t f = 0; f < kFractions; ++f)
    {
        const auto to = scratch.begin() + end[in[f]];
        const auto from = to - static_cast<std::ptrdiff_t>(below[in[f] + 1] - below[in[f]]);
        const auto nth = from + static_cast<std::ptrdiff_t>(rank[f] - below[in[f]]);
        std::nth_element(from, nth, to);
        value[f] = *nth;
    }
    return value;
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

ShapeFeatures shape_features(const TriangleMesh& mesh)
{
    std::vector<Vec3> normals;
    const std::vector<Vec3> points = surface_points(mesh, sorted_surface(mesh), kSamples, &normals);
    ShapeFeatures whole;
    Scratch scratch;
    nested_features(points, draw(points, normals), std::vector<std::int32_t>(points.size(), 1), 1,
                    &whole, scratch);
    return whole;
}

ShapeSignature shape_signature(const TriangleMesh& mesh)
{
    const Surface surface = sorted_surface(mesh);
    std::vector<Vec3> normals;
    const std::vector<Vec3> points = surface_points(mesh, surface, kSamples, &normals);
    const Draws draws = draw(points, normals);
    const std::size_t n = points.size();
    ShapeSignature signature;
    signature.points = sample_of(mesh, surface, kShapePoints, &signature.normals);
    signature.views.resize(kShapeViews);
    Scratch scratch;
    nested_features(points, draws, std::vector<std::int32_t>(n, 1), 1, signature.views.data(),
                    scratch);
    // Per direction, the crop views are nested (a smaller kept fraction keeps a subset): each
    // point's level is the number of them it lies in, from the fractions' height quantiles.
    std::array<std::size_t, kFractions> drop{};  // largest fraction first
    for (std::size_t f = 0; f < kFractions && n > 0; ++f)
    {
        const double fraction = kShapeCropFractions[kFractions - 1 - f];
        drop[f] = std::min(
            static_cast<std::size_t>(std::lround((1.0 - fraction) * static_cast<double>(n))),
            n - 1);
    }
    // The points' coordinates apart (the loops below vectorize), and their box: along a
    // direction the heights lie in the box's (the buckets' range; up to rounding, which the
    // buckets' clamp takes).
    std::array<std::vector<double>, 3> coordinate;
    for (int k = 0; k < 3; ++k)
    {
        for (const Vec3& p : points)
        {
            coordinate[static_cast<std::size_t>(k)].push_back(p(k));
        }
    }
    const auto& [x, y, z] = coordinate;
    Vec3 box_min = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 box_max = -box_min;
    bool tame = true;  // finite and far from overflowing: so are the heights
    for (const Vec3& p : points)
    {
        box_min = box_min.cwiseMin(p);
        box_max = box_max.cwiseMax(p);
        tame = tame && (p.array().abs() < 1e300).all();
    }
    std::vector<std::int32_t> level(n);
    std::vector<double> heights(n);
    std::vector<std::int32_t> bucket;
    std::vector<double> selected;
    ShapeFeatures* out = signature.views.data() + 1;
    for (const Vec3& d : shape_crop_directions())
    {
        const double lo = box_min.cwiseProduct(d).cwiseMin(box_max.cwiseProduct(d)).sum();
        const double hi = box_min.cwiseProduct(d).cwiseMax(box_max.cwiseProduct(d)).sum();
        const double scale = static_cast<double>(kBuckets) / (hi - lo);
        const bool buckets = tame && hi > lo && std::isfinite(scale);
        bucket.resize(buckets ? n : 0);
        for (std::size_t i = 0; i < n; ++i)
        {
            // points[i].dot(d), as Eigen sums it
            heights[i] = x[i] * d.x() + y[i] * d.y() + z[i] * d.z();
        }
        for (std::size_t i = 0; i < bucket.size(); ++i)
        {
            bucket[i] = static_cast<std::int32_t>(
                std::clamp((heights[i] - lo) * scale, 0.0, kBuckets - 1.0));
        }
        const std::array<double, kFractions> threshold =
            n > 0 ? order_statistics(heights, bucket, drop, selected)
                  : std::array<double, kFractions>{};
        // The thresholds at or below each height, counted in doubles (which vectorize).
        const auto& [t0, t1, t2, t3] = threshold;
        for (std::size_t i = 0; i < n; ++i)
        {
            const double h = heights[i];
            level[i] = static_cast<std::int32_t>((h >= t0 ? 1.0 : 0.0) + (h >= t1 ? 1.0 : 0.0) +
                                                 (h >= t2 ? 1.0 : 0.0) + (h >= t3 ? 1.0 : 0.0));
        }
        // Views come out largest fraction first; the signature lists them by kShapeCropFractions.
        std::array<ShapeFeatures, kFractions> nested{};
        nested_features(points, draws, level, kFractions, nested.data(), scratch);
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
