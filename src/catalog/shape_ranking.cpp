// SPDX-License-Identifier: MIT
// The rankings of `catalog scan`: the shape index's (shape_candidates) and the fit of a
// suspect's points onto the assets' (shape_fit_ranking).
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <vector>

#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/shape_fit.h"
#include "meshmark/registration/variant_fit.h"

namespace meshmark
{
namespace
{

// Each asset is fitted from its whole and its kFitStartViews crop views nearest the suspect's
// features (bench/results/2026-11-30-shape-fit.md).
constexpr std::size_t kFitStartViews = 3;
// Near-duplicates are often variants of one mesh (stretched, bent, rescanned on the same
// triangles: the same vertex and face counts); the index ranks a crop of one far below another
// it looks like. The variants of the first kSiblingsOf fitted assets are fitted too, at most
// kSiblingFits of them (bench/results/2026-11-30-variants-fitted.md).
constexpr std::size_t kSiblingsOf = 8;
constexpr std::size_t kSiblingFits = 64;
// The first `refits` of the fit's ranking are fitted again from their kRefitStartViews crop
// views nearest the suspect's features: a crop's start poses (the same study).
constexpr std::size_t kRefitStartViews = 16;
// The variants of a mesh are scored on this many points of the suspect, by this many ICP
// rounds onto each one's surface (surface_fits).
constexpr int kVariantPoints = 1024;
constexpr int kVariantRounds = 5;

// The crop views of \p views (this build's width) nearest \p scaled (features in 255ths).
std::vector<int> nearest_crop_views(const std::vector<std::uint8_t>& views,
                                    const std::array<float, kShapeFeatures>& scaled,
                                    std::size_t count)
{
    std::vector<std::pair<float, int>> by_view;
    for (int v = 1; v < kShapeViews; ++v)
    {
        float sum = 0.0F;
        for (std::size_t i = 0; i < kShapeFeatures; ++i)
        {
            const float d =
                scaled[i] -
                static_cast<float>(views[static_cast<std::size_t>(v) * kShapeFeatures + i]);
            sum += d * d;
        }
        by_view.emplace_back(sum, v);
    }
    const std::size_t kept = std::min(count, by_view.size());
    std::partial_sort(by_view.begin(), by_view.begin() + static_cast<std::ptrdiff_t>(kept),
                      by_view.end());
    std::vector<int> nearest;
    for (std::size_t k = 0; k < kept; ++k)
    {
        nearest.push_back(by_view[k].second);
    }
    return nearest;
}

}  // namespace

std::vector<std::pair<float, std::size_t>> shape_candidates(
    const std::vector<Catalog::IndexEntry>& index, const ShapeFeatures& features, std::size_t count)
{
    // Each view's features are bytes of 255ths (ShapeSignature::to_bytes), so the suspect's are
    // scaled alike and the squared differences summed in that unit.
    std::array<float, kShapeFeatures> scaled{};
    for (std::size_t i = 0; i < scaled.size(); ++i)
    {
        scaled[i] = 255.0F * features[i];
    }
    constexpr float kNone = std::numeric_limits<float>::infinity();
    std::vector<std::pair<float, std::size_t>> by_all;
    std::vector<std::pair<float, std::size_t>> by_positions;
    by_all.reserve(index.size());
    by_positions.reserve(index.size());
    for (std::size_t a = 0; a < index.size(); ++a)
    {
        const std::vector<std::uint8_t>& views = index[a].views;
        const std::size_t width =
            views.size() == static_cast<std::size_t>(kShapeViews * kShapePositionFeatures)
                ? kShapePositionFeatures
                : kShapeFeatures;
        float best_all = kNone;
        float best_positions = kNone;
        for (std::size_t at = 0; at + width <= views.size(); at += width)
        {
            float positions = 0.0F;
            for (std::size_t i = 0; i < kShapePositionFeatures; ++i)
            {
                const float d = scaled[i] - static_cast<float>(views[at + i]);
                positions += d * d;
            }
            float all = positions;
            for (std::size_t i = kShapePositionFeatures; i < width; ++i)
            {
                const float d = scaled[i] - static_cast<float>(views[at + i]);
                all += d * d;
            }
            best_positions = std::min(best_positions, positions);
            if (width == kShapeFeatures)
            {
                best_all = std::min(best_all, all);
            }
        }
        by_positions.emplace_back(std::sqrt(best_positions) / 255.0F, a);
        if (best_all < kNone)
        {
            by_all.emplace_back(std::sqrt(best_all) / 255.0F, a);
        }
    }
    count = std::min(count, index.size());
    const auto first = [count](std::vector<std::pair<float, std::size_t>>& ranked)
    {
        const std::size_t kept = std::min(count, ranked.size());
        std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(kept),
                          ranked.end());
        ranked.resize(kept);
    };
    first(by_all);
    first(by_positions);
    // In turn, by every feature first; an asset's reported distance is that of the ranking that
    // proposed it.
    std::vector<std::pair<float, std::size_t>> ranked;
    std::vector<bool> taken(index.size(), false);
    for (std::size_t r = 0; ranked.size() < count && (r < by_all.size() || r < by_positions.size());
         ++r)
    {
        for (const auto* list : {&by_all, &by_positions})
        {
            if (r < list->size() && ranked.size() < count && !taken[(*list)[r].second])
            {
                taken[(*list)[r].second] = true;
                ranked.push_back((*list)[r]);
            }
        }
    }
    return ranked;
}

std::vector<std::pair<double, std::size_t>> shape_fit_ranking(
    const std::vector<Catalog::IndexEntry>& index,
    const std::vector<std::pair<float, std::size_t>>& by_shape, const std::vector<bool>& taken,
    const TriangleMesh& suspect, const ShapeFeatures& features, std::size_t count,
    std::size_t refits, int threads)
{
    std::vector<std::size_t> shortlist;
    for (std::size_t r = 0; r < by_shape.size() && shortlist.size() < count; ++r)
    {
        const std::size_t a = by_shape[r].second;
        if (!taken[a] && !index[a].points.empty())
        {
            shortlist.push_back(a);
        }
    }
    if (shortlist.empty())
    {
        return {};
    }
    std::array<float, kShapeFeatures> scaled{};
    for (std::size_t i = 0; i < scaled.size(); ++i)
    {
        scaled[i] = 255.0F * features[i];
    }
    const Positions points = shape_sample(suspect, kShapePoints);
    const auto fit_all = [&](const std::vector<std::size_t>& assets, std::size_t views)
    {
        std::vector<std::pair<double, std::size_t>> fits(assets.size());
        for_each_index(assets.size(), threads,
                       [&](std::size_t k)
                       {
                           const Catalog::IndexEntry& entry = index[assets[k]];
                           double error = std::numeric_limits<double>::infinity();
                           try
                           {
                               Positions asset;
                               Positions normals;
                               ShapeSignature::points_from_bytes(entry.points, asset, normals);
                               const PointKdTree tree(asset);
                               error = shape_fit(points, asset, normals, tree,
                                                 nearest_crop_views(entry.views, scaled, views));
                           }
                           catch (const Error&)
                           {
                               // shape_index checked the size; nothing else can fail: ranks last
                           }
                           fits[k] = {error, assets[k]};
                       });
        return fits;
    };
    const auto by_error = [](const auto& x, const auto& y) { return x.first < y.first; };
    std::vector<std::pair<double, std::size_t>> fits = fit_all(shortlist, kFitStartViews);
    std::stable_sort(fits.begin(), fits.end(), by_error);
    // The variants of the mesh of each of the best fits (same vertex and face counts) that the
    // index left out: fitted too, ranked with the rest.
    std::vector<bool> fitted(index.size(), false);
    for (const std::size_t a : shortlist)
    {
        fitted[a] = true;
    }
    std::vector<std::size_t> siblings;
    for (std::size_t k = 0; k < fits.size() && k < kSiblingsOf; ++k)
    {
        const Catalog::IndexEntry& best = index[fits[k].second];
        for (std::size_t a = 0; a < index.size() && siblings.size() < kSiblingFits; ++a)
        {
            if (!fitted[a] && !taken[a] && !index[a].points.empty() &&
                index[a].vertex_count == best.vertex_count &&
                index[a].face_count == best.face_count)
            {
                fitted[a] = true;
                siblings.push_back(a);
            }
        }
    }
    if (!siblings.empty())
    {
        const std::vector<std::pair<double, std::size_t>> more = fit_all(siblings, kFitStartViews);
        fits.insert(fits.end(), more.begin(), more.end());
        std::stable_sort(fits.begin(), fits.end(), by_error);
    }
    // The best fitted again from more crop views (the better fit kept).
    const std::size_t again = std::min(refits, fits.size());
    std::vector<std::size_t> best(again);
    for (std::size_t k = 0; k < again; ++k)
    {
        best[k] = fits[k].second;
    }
    const std::vector<std::pair<double, std::size_t>> fits_again = fit_all(best, kRefitStartViews);
    for (std::size_t k = 0; k < again; ++k)
    {
        fits[k].first = std::min(fits[k].first, fits_again[k].first);
    }
    std::stable_sort(fits.begin(), fits.begin() + static_cast<std::ptrdiff_t>(again), by_error);
    return fits;
}

std::vector<std::pair<double, std::size_t>> variant_ranking(
    const Catalog& catalog, const std::vector<Catalog::IndexEntry>& index, std::size_t best,
    const TriangleMesh& suspect, const ShapeFeatures& features, std::size_t count, int threads)
{
    if (best >= index.size() || index[best].points.empty())
    {
        return {};
    }
    // The best first, then its variants in the index's order; their originals' paths (the
    // catalogue is asked from this thread only), then the meshes read in parallel.
    std::vector<std::size_t> family{best};
    for (std::size_t a = 0; a < index.size() && family.size() < count; ++a)
    {
        if (a != best && index[a].vertex_count == index[best].vertex_count &&
            index[a].face_count == index[best].face_count)
        {
            family.push_back(a);
        }
    }
    if (family.size() < 2)
    {
        return {};
    }
    std::vector<std::filesystem::path> originals(family.size());
    for (std::size_t k = 0; k < family.size(); ++k)
    {
        if (const std::optional<CatalogAsset> asset = catalog.asset(index[family[k]].id))
        {
            originals[k] = asset->original;
        }
    }
    std::vector<TriangleMesh> meshes(family.size());
    for_each_index(family.size(), threads,
                   [&](std::size_t k)
                   {
                       try
                       {
                           meshes[k] = read_mesh(originals[k]);
                       }
                       catch (const Error&)
                       {
                           // no faces: scored infinity, left out below
                       }
                   });
    // The suspect's pose on the best: shape_fit from the crop views nearest the suspect's
    // features, as the fit ranked it; its variants lie in nearly the same frame.
    std::array<float, kShapeFeatures> scaled{};
    for (std::size_t i = 0; i < scaled.size(); ++i)
    {
        scaled[i] = 255.0F * features[i];
    }
    Positions asset;
    Positions normals;
    ShapeSignature::points_from_bytes(index[best].points, asset, normals);
    const PointKdTree tree(asset);
    ShapeFitPose pose;
    const double fit =
        shape_fit(shape_sample(suspect, kShapePoints), asset, normals, tree,
                  nearest_crop_views(index[best].views, scaled, kRefitStartViews), {}, &pose);
    if (!std::isfinite(fit))
    {
        return {};
    }
    const std::vector<double> scores =
        surface_fits(shape_sample(suspect, kVariantPoints), meshes, pose, kVariantRounds, threads);
    std::vector<std::pair<double, std::size_t>> ranked;
    for (std::size_t k = 0; k < family.size(); ++k)
    {
        if (std::isfinite(scores[k]))
        {
            ranked.emplace_back(scores[k], family[k]);
        }
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    return ranked;
}

}  // namespace meshmark
