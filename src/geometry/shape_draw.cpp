// SPDX-License-Identifier: MIT
// The draws of a shape signature (shape_draw.h): points by area on a surface, in an order of its
// triangles that does not depend on the file, and the pairs and triples of them its views count.
#include "geometry/shape_draw.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <numeric>

#include <Eigen/Geometry>

#include "meshmark/core/hash.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shape_signature.h"

namespace meshmark
{
namespace shape_detail
{
namespace
{

// The fixed seed of the draw: a suspect and its original are drawn alike.
constexpr std::uint64_t kSeed = 0x5ea7c0de5eedULL;

// std::tie(p...) < std::tie(q...) for doubles, without the three-way comparisons C++20's tuples
// make of it (the same answers: a NaN compares unordered, and so neither less).
template <std::size_t N>
bool lexicographic(const std::array<double, N>& p, const std::array<double, N>& q)
{
    for (std::size_t k = 0; k < N; ++k)
    {
        if (!(p[k] == q[k]))
        {
            return p[k] < q[k];
        }
    }
    return false;
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

// The bin of \p x (a distance in bin widths) among \p bins bins, the last open-ended.
std::size_t bin_of(double x, int bins)
{
    return static_cast<std::size_t>(std::min(x, bins - 0.5));
}

// The order of \p keys (non-negative, no NaN) ascending, ties in their order, as std::stable_sort
// would give it: a radix sort of their bits, which for such doubles order as their values (an
// eighth of std::stable_sort's time on 16,384 keys).
std::vector<std::uint32_t> ascending(const std::vector<double>& keys)
{
    constexpr unsigned kDigit = 11U;
    std::vector<std::uint32_t> order(keys.size());
    std::vector<std::uint32_t> next(keys.size());
    std::iota(order.begin(), order.end(), std::uint32_t{0});
    for (unsigned shift = 0; shift < 64U; shift += kDigit)
    {
        const auto digit = [&](std::uint32_t t)
        { return (std::bit_cast<std::uint64_t>(keys[t]) >> shift) & ((1U << kDigit) - 1U); };
        std::array<std::uint32_t, (1U << kDigit) + 1> from{};
        for (const std::uint32_t t : order)
        {
            ++from[digit(t) + 1];
        }
        if (std::ranges::count(from, 0U) == from.size() - 1)
        {
            continue;  // one digit for all
        }
        std::partial_sum(from.begin(), from.end(), from.begin());
        for (const std::uint32_t t : order)
        {
            next[from[digit(t)]++] = t;
        }
        order.swap(next);
    }
    return order;
}

}  // namespace

Surface sorted_surface(const TriangleMesh& mesh)
{
    struct Key
    {
        double key = 0.0;
        double area = 0.0;
        std::array<std::int32_t, 3> corners{};  // vertices, in the face's order, then sorted
    };
    std::vector<Key> keys;
    keys.reserve(static_cast<std::size_t>(mesh.F.rows()));
    const auto corner = [&](std::int32_t vertex) -> Vec3 { return mesh.V.row(vertex).transpose(); };
    Vec3 weighted = Vec3::Zero();
    double total = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Vec3 a = corner(mesh.F(f, 0));
        const Vec3 b = corner(mesh.F(f, 1));
        const Vec3 c = corner(mesh.F(f, 2));
        const double area = 0.5 * (b - a).cross(c - a).norm();
        if (!(area > 0.0) || !std::isfinite(area))
        {
            continue;
        }
        weighted += area * (a + b + c) / 3.0;
        total += area;
        keys.push_back({0.0, area, {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)}});
    }
    Surface surface;
    if (!(total > 0.0))
    {
        return surface;
    }
    const Vec3 centre = weighted / total;
    std::vector<double> key_bits(keys.size());
    for (std::size_t t = 0; t < keys.size(); ++t)
    {
        // Corners that compare equal are equal: any sort of the three gives them alike.
        std::array<std::pair<std::array<double, 4>, std::int32_t>, 3> by;
        for (std::size_t k = 0; k < 3; ++k)
        {
            const Vec3 p = corner(keys[t].corners[k]);
            by[k] = {{(p - centre).squaredNorm(), p.x(), p.y(), p.z()}, keys[t].corners[k]};
        }
        std::sort(by.begin(), by.end(),
                  [](const auto& p, const auto& q) { return lexicographic(p.first, q.first); });
        for (std::size_t k = 0; k < 3; ++k)
        {
            keys[t].corners[k] = by[k].second;
        }
        const auto& [a, b, c] = keys[t].corners;
        keys[t].key = ((corner(a) + corner(b) + corner(c)) / 3.0 - centre).squaredNorm();
        key_bits[t] = keys[t].key;
    }
    // By key, then area. Where no two triangles tie, that order is the only one, and a radix sort
    // of the keys finds it in a fraction of the comparison sort's time (checked: each triangle
    // strictly after the one before). Where some tie (mirror images: a quarter of the real files
    // of the catalogue-add run), std::sort on the faces' order as before: its moves depend only
    // on its comparisons, so the tied ones keep the order they always had.
    const auto before = [](const Key& p, const Key& q) {
        return lexicographic(std::array{p.key, p.area}, std::array{q.key, q.area});
    };
    std::vector<Key> sorted;
    if (std::ranges::none_of(key_bits, [](double k) { return std::isnan(k); }))
    {
        sorted.reserve(keys.size());
        for (const std::uint32_t t : ascending(key_bits))
        {
            if (!sorted.empty() && !before(sorted.back(), keys[t]))
            {
                sorted.clear();
                break;
            }
            sorted.push_back(keys[t]);
        }
    }
    if (sorted.empty())
    {
        std::sort(keys.begin(), keys.end(), before);
        sorted = std::move(keys);
    }
    surface.corners.reserve(sorted.size());
    surface.cumulative.reserve(sorted.size());
    double sum = 0.0;
    for (const Key& k : sorted)
    {
        surface.corners.push_back(k.corners);
        sum += k.area;
        surface.cumulative.push_back(sum);
    }
    return surface;
}

std::vector<Vec3> surface_points(const TriangleMesh& mesh, const Surface& surface, int count,
                                 std::vector<Vec3>* normals)
{
    std::vector<Vec3> points;
    points.reserve(static_cast<std::size_t>(count));
    Rng rng(kSeed);
    const std::vector<double>& cumulative = surface.cumulative;
    const std::size_t size = cumulative.size();
    std::size_t last = 0;  // the triangle of the point before: the points' areas ascend
    for (int i = 0; size > 0 && i < count; ++i)
    {
        const double at = (static_cast<double>(i) + rng.uniform()) / count * cumulative.back();
        // std::upper_bound's triangle, searched from the last one's by steps that double.
        std::size_t from = last;
        std::size_t to = last;
        for (std::size_t step = 1; to < size && !(at < cumulative[to]); step *= 2)
        {
            from = to + 1;
            to += step;
        }
        last = static_cast<std::size_t>(
            std::upper_bound(cumulative.begin() + static_cast<std::ptrdiff_t>(from),
                             cumulative.begin() + static_cast<std::ptrdiff_t>(std::min(to, size)),
                             at) -
            cumulative.begin());
        const std::size_t f = std::min(last, size - 1);
        double u = rng.uniform();
        double v = rng.uniform();
        if (u + v > 1.0)
        {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        const Vec3 a = mesh.V.row(surface.corners[f][0]).transpose();
        const Vec3 b = mesh.V.row(surface.corners[f][1]).transpose();
        const Vec3 c = mesh.V.row(surface.corners[f][2]).transpose();
        points.push_back(a + u * (b - a) + v * (c - a));
        if (normals != nullptr)
        {
            normals->push_back((b - a).cross(c - a).normalized());
        }
    }
    if (size > 0)
    {
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

namespace
{

Positions as_rows(const std::vector<Vec3>& points)
{
    Positions rows(static_cast<Eigen::Index>(points.size()), 3);
    for (std::size_t i = 0; i < points.size(); ++i)
    {
        rows.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    }
    return rows;
}

}  // namespace

Positions sample_of(const TriangleMesh& mesh, const Surface& surface, int count, Positions* normals)
{
    std::vector<Vec3> drawn_normals;
    const Positions sample = as_rows(
        surface_points(mesh, surface, count, normals != nullptr ? &drawn_normals : nullptr));
    if (normals != nullptr)
    {
        *normals = as_rows(drawn_normals);
    }
    return sample;
}

Draws draw(const std::vector<Vec3>& points, const std::vector<Vec3>& normals)
{
    Draws d;
    const std::size_t n = points.size();
    if (n < 3)
    {
        return d;
    }
    Draw stream(kSeed ^ n);
    std::vector<std::array<std::uint16_t, 2>> pairs;
    std::vector<double> distance;
    pairs.reserve(kPairs);
    distance.reserve(kPairs);
    for (int t = 0; t < kPairs; ++t)
    {
        const std::size_t i = stream.below(n);
        const std::size_t j = stream.below(n);
        pairs.push_back({static_cast<std::uint16_t>(i), static_cast<std::uint16_t>(j)});
        distance.push_back((points[i] - points[j]).norm());
    }
    // By distance: a view's pairs in one bin are then a run, found by a binary search per bin
    // edge (nested_features). (A NaN, of a point cloud with one, has no place in the bits'
    // order: then the comparison sort as ever.)
    std::vector<std::uint32_t> order;
    if (std::ranges::any_of(distance, [](double x) { return std::isnan(x); }))
    {
        order.resize(pairs.size());
        std::iota(order.begin(), order.end(), std::uint32_t{0});
        std::stable_sort(order.begin(), order.end(),
                         [&](std::uint32_t a, std::uint32_t b)
                         { return distance[a] < distance[b]; });
    }
    else
    {
        order = ascending(distance);
    }
    d.pair_distance.reserve(order.size());
    std::array<std::vector<std::array<std::uint16_t, 2>>, kNormalBins> by_normal;
    d.normal_below.resize(order.size() + 1);
    for (std::size_t r = 0; r < order.size(); ++r)
    {
        const auto& [i, j] = pairs[order[r]];
        const double cosine = std::abs(normals[i].dot(normals[j]));
        const std::size_t b = bin_of(cosine * kNormalBins, kNormalBins);
        by_normal[b].push_back(pairs[order[r]]);
        d.pair_distance.push_back(distance[order[r]]);
        d.normal_below[r + 1] = d.normal_below[r];
        ++d.normal_below[r + 1][b];
    }
    for (std::size_t b = 0; b < by_normal.size(); ++b)
    {
        d.pairs.insert(d.pairs.end(), by_normal[b].begin(), by_normal[b].end());
        d.normal_from[b + 1] = d.pairs.size();
    }
    // Angle bins by their cosines (descending with the angle): no acos per triple.
    std::array<double, kAngleBins - 1> cosine_edges{};
    for (int b = 1; b < kAngleBins; ++b)
    {
        cosine_edges[static_cast<std::size_t>(b - 1)] = std::cos(std::numbers::pi * b / kAngleBins);
    }
    std::array<std::vector<std::array<std::uint16_t, 3>>, kAngleBins> by_bin;
    for (int t = 0; t < kTriples; ++t)
    {
        const std::array<std::uint16_t, 3> abc = {static_cast<std::uint16_t>(stream.below(n)),
                                                  static_cast<std::uint16_t>(stream.below(n)),
                                                  static_cast<std::uint16_t>(stream.below(n))};
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
        by_bin[static_cast<std::size_t>(
                   std::ranges::count_if(cosine_edges, [&](double edge) { return cosine < edge; }))]
            .push_back(abc);
    }
    for (std::size_t b = 0; b < by_bin.size(); ++b)
    {
        d.triples.insert(d.triples.end(), by_bin[b].begin(), by_bin[b].end());
        d.triple_from[b + 1] = d.triples.size();
    }
    return d;
}

}  // namespace shape_detail

Positions shape_sample(const TriangleMesh& mesh, int count, Positions* normals)
{
    return shape_detail::sample_of(mesh, shape_detail::sorted_surface(mesh), count, normals);
}

}  // namespace meshmark
