// SPDX-License-Identifier: MIT
// The catalogue's shape index searched exactly (shape_candidates, what `catalog scan` does)
// against an approximate nearest-neighbour graph (hnswlib's HNSW, Debian's libhnswlib-dev) over
// every view of every asset, for 1,000, 10,000 and 100,000 assets: the graph's build, its query
// and its recall of the exact search's first 8 assets.
//
// The assets: the signatures of 48 generated shapes (tori, ellipsoids, boxes of varied
// proportions), each repeated with every stored byte moved by up to +-3 (near-duplicates, as
// variants of one object are), so that the search has neighbours to tell apart. The suspects: 16
// of the assets' whole views moved likewise.
#include <algorithm>
#include <array>
#include <map>
#include <memory>

#include <benchmark/benchmark.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/registration/shape_fit.h"

#if __has_include(<hnswlib/hnswlib.h>)
#include <hnswlib/hnswlib.h>
#define MESHMARK_HAVE_HNSWLIB 1
#endif

namespace
{

using namespace meshmark;

constexpr std::size_t kCandidates = 8;
constexpr int kSuspects = 16;

std::vector<std::vector<std::uint8_t>> base_signatures()
{
    std::vector<std::vector<std::uint8_t>> signatures;
    for (int s = 0; s < 48; ++s)
    {
        TriangleMesh mesh = s % 3 == 0   ? torus(1.0, 0.15 + 0.02 * s / 3, 32, 16)
                            : s % 3 == 1 ? lumpy_ellipsoid(3)
                                         : icosphere(3);
        mesh.V.col(0) *= 1.0 + 0.05 * s;
        mesh.V.col(2) *= s % 3 == 2 ? 0.3 + 0.04 * s : 1.0;
        signatures.push_back(index_entry("", shape_signature(mesh).to_bytes()).views);
    }
    return signatures;
}

std::uint8_t moved(std::uint8_t byte, Rng& rng)
{
    return static_cast<std::uint8_t>(
        std::clamp(static_cast<int>(byte) + static_cast<int>(rng.below(7)) - 3, 0, 255));
}

struct Data
{
    std::vector<Catalog::IndexEntry> index;
    std::vector<ShapeFeatures> suspects;
};

const Data& data_of(std::size_t assets)
{
    static std::map<std::size_t, Data> all;
    auto found = all.find(assets);
    if (found != all.end())
    {
        return found->second;
    }
    static const std::vector<std::vector<std::uint8_t>> base = base_signatures();
    Data d;
    Rng rng(assets);
    for (std::size_t a = 0; a < assets; ++a)
    {
        std::vector<std::uint8_t> views = base[a % base.size()];
        for (std::uint8_t& byte : views)
        {
            byte = moved(byte, rng);
        }
        d.index.push_back({std::to_string(a), std::move(views), 0, 0, {}});
    }
    for (int s = 0; s < kSuspects; ++s)
    {
        const std::vector<std::uint8_t>& views = d.index[rng.below(assets)].views;
        ShapeFeatures features{};
        for (int i = 0; i < kShapeFeatures; ++i)
        {
            features[static_cast<std::size_t>(i)] =
                static_cast<float>(moved(views[static_cast<std::size_t>(i)], rng)) / 255.0F;
        }
        d.suspects.push_back(features);
    }
    return all.emplace(assets, std::move(d)).first->second;
}

void BM_ShapeIndexExact(benchmark::State& state)
{
    const Data& d = data_of(static_cast<std::size_t>(state.range(0)));
    std::size_t s = 0;
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(
            shape_candidates(d.index, d.suspects[s++ % d.suspects.size()], kCandidates));
    }
}
BENCHMARK(BM_ShapeIndexExact)
    ->ArgName("assets")
    ->Arg(1'000)
    ->Arg(10'000)
    ->Arg(100'000)
    ->Unit(benchmark::kMillisecond);

// One check of a candidate by the fit of points (shape_fit, as `catalog scan` runs it on each
// of the index's first 128 assets): a remeshed and moved copy of a generated surface onto the
// asset's stored points, from its whole and its 3 crop views nearest the copy's features.
void BM_ShapeFit(benchmark::State& state)
{
    const TriangleMesh asset = lumpy_ellipsoid(4);
    const ShapeSignature signature = shape_signature(asset);
    const PointKdTree tree(signature.points);
    const TriangleMesh copy =
        apply_attacks(asset, parse_attack_spec("remesh=0.8,similarity"), 3, 1).mesh;
    const Positions points = shape_sample(copy, kShapePoints);
    const ShapeFeatures features = shape_features(copy);
    std::vector<std::pair<float, int>> by_view;
    for (int v = 1; v < kShapeViews; ++v)
    {
        by_view.emplace_back(shape_distance(features, signature.views[static_cast<std::size_t>(v)]),
                             v);
    }
    std::partial_sort(by_view.begin(), by_view.begin() + 3, by_view.end());
    const std::array<int, 3> views{by_view[0].second, by_view[1].second, by_view[2].second};
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(
            shape_fit(points, signature.points, signature.normals, tree, views));
    }
}
BENCHMARK(BM_ShapeFit)->Unit(benchmark::kMillisecond);

#ifdef MESHMARK_HAVE_HNSWLIB
// Every view of every asset a point of the graph, labelled by asset: an asset's distance is that
// of its nearest view, as in the exact search. Queried for 64 views, collapsed to assets.
struct Graph
{
    hnswlib::L2Space space{kShapeFeatures};
    std::unique_ptr<hnswlib::HierarchicalNSW<float>> hnsw;
};

std::unique_ptr<Graph> build(const Data& d)
{
    auto g = std::make_unique<Graph>();
    const std::size_t views = d.index.size() * kShapeViews;
    g->hnsw = std::make_unique<hnswlib::HierarchicalNSW<float>>(&g->space, views, 16, 100);
    std::array<float, kShapeFeatures> point{};
    for (std::size_t a = 0; a < d.index.size(); ++a)
    {
        for (int v = 0; v < kShapeViews; ++v)
        {
            for (int i = 0; i < kShapeFeatures; ++i)
            {
                point[static_cast<std::size_t>(i)] =
                    static_cast<float>(
                        d.index[a].views[static_cast<std::size_t>(v * kShapeFeatures + i)]) /
                    255.0F;
            }
            g->hnsw->addPoint(point.data(), a * kShapeViews + static_cast<std::size_t>(v));
        }
    }
    g->hnsw->setEf(128);
    return g;
}

std::vector<std::size_t> query(const Graph& g, const ShapeFeatures& features)
{
    auto found = g.hnsw->searchKnn(features.data(), 64);
    std::vector<std::pair<float, std::size_t>> views;
    while (!found.empty())
    {
        views.emplace_back(found.top().first, found.top().second / kShapeViews);
        found.pop();
    }
    std::sort(views.begin(), views.end());
    std::vector<std::size_t> assets;
    for (const auto& [distance, a] : views)
    {
        if (std::find(assets.begin(), assets.end(), a) == assets.end() &&
            assets.size() < kCandidates)
        {
            assets.push_back(a);
        }
    }
    return assets;
}

void BM_ShapeIndexHnswBuild(benchmark::State& state)
{
    const Data& d = data_of(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(build(d));
    }
}
BENCHMARK(BM_ShapeIndexHnswBuild)
    ->ArgName("assets")
    ->Arg(1'000)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

void BM_ShapeIndexHnswQuery(benchmark::State& state)
{
    const Data& d = data_of(static_cast<std::size_t>(state.range(0)));
    const std::unique_ptr<Graph> g = build(d);
    std::size_t s = 0;
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(query(*g, d.suspects[s++ % d.suspects.size()]));
    }
    // Recall: of the exact search's first 8 by every feature, the share the graph returns.
    double found = 0.0;
    double asked = 0.0;
    for (const ShapeFeatures& suspect : d.suspects)
    {
        std::vector<std::pair<float, std::size_t>> exact;
        for (std::size_t a = 0; a < d.index.size(); ++a)
        {
            float best = 1e30F;
            for (int v = 0; v < kShapeViews; ++v)
            {
                float sum = 0.0F;
                for (int i = 0; i < kShapeFeatures; ++i)
                {
                    const float x =
                        static_cast<float>(
                            d.index[a].views[static_cast<std::size_t>(v * kShapeFeatures + i)]) /
                            255.0F -
                        suspect[static_cast<std::size_t>(i)];
                    sum += x * x;
                }
                best = std::min(best, sum);
            }
            exact.emplace_back(best, a);
        }
        std::partial_sort(exact.begin(), exact.begin() + kCandidates, exact.end());
        const std::vector<std::size_t> approximate = query(*g, suspect);
        for (std::size_t k = 0; k < kCandidates; ++k)
        {
            found += std::find(approximate.begin(), approximate.end(), exact[k].second) !=
                             approximate.end()
                         ? 1.0
                         : 0.0;
            asked += 1.0;
        }
    }
    state.counters["recall_at_8"] = found / asked;
}
BENCHMARK(BM_ShapeIndexHnswQuery)->ArgName("assets")->Arg(1'000)->Unit(benchmark::kMillisecond);
#endif

}  // namespace
