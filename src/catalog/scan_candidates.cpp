// SPDX-License-Identifier: MIT
// The candidates of `catalog scan` besides the shape rankings (scan_candidates.h).
#include "catalog/scan_candidates.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/similarity_fit.h"

namespace meshmark::catalog_detail
{
namespace
{

// A copy in its original's numbering (re-exported, moved, noised: the counts kept) has its
// vertices on the original's after a similarity, within the mark's amplitude and the noise; a
// variant of the same topology (stretched, bent) does not. Within this RMS distance, over the
// original's bounding-box diagonal, an asset of the suspect's vertex and face counts is tried
// before the shape index's ranking: the index cannot tell near-duplicates apart below its
// draw's noise (bench/results/2026-11-30-scan-speed.md). The mark moves vertices by about 1e-3
// of the diagonal, the attack suite's noise by 5e-4 to 2e-3.
constexpr double kInOrderFit = 0.01;
// Same-count assets read per suspect at most (each is an original read from its file): a
// catalogue of 100,000 near-duplicates holds about 150 variants of each mesh, all of its counts.
constexpr std::size_t kInOrderReads = 256;

// Places among the candidates that go to the closest variants of the best fit's mesh, at least.
constexpr std::size_t kVariantPlaces = 2;

}  // namespace

std::vector<std::size_t> in_order_fits(const Catalog& catalog,
                                       const std::vector<Catalog::IndexEntry>& index,
                                       const TriangleMesh& suspect, int threads)
{
    std::vector<std::size_t> same;
    std::vector<std::filesystem::path> originals;
    for (std::size_t a = 0; a < index.size() && same.size() < kInOrderReads; ++a)
    {
        if (index[a].vertex_count != suspect.V.rows() || index[a].face_count != suspect.F.rows())
        {
            continue;
        }
        same.push_back(a);
        const std::optional<CatalogAsset> asset = catalog.asset(index[a].id);
        originals.push_back(asset ? asset->original : std::filesystem::path());
    }
    const double infinity = std::numeric_limits<double>::infinity();
    std::vector<std::pair<double, std::size_t>> fits(same.size(), {infinity, 0});
    for_each_index(same.size(), threads,
                   [&](std::size_t k)
                   {
                       fits[k].second = same[k];
                       try
                       {
                           const TriangleMesh original = read_mesh(originals[k]);
                           if (original.V.rows() != suspect.V.rows())
                           {
                               return;
                           }
                           const Eigen::Matrix4d fit = fit_similarity_rows(suspect.V, original.V);
                           const Positions moved = transform_points(fit, suspect.V);
                           const double diagonal = bounding_box(original.V).diagonal();
                           const double rms =
                               std::sqrt((moved - original.V).rowwise().squaredNorm().mean());
                           if (diagonal > 0.0 && rms <= kInOrderFit * diagonal)
                           {
                               fits[k].first = rms / diagonal;
                           }
                       }
                       catch (const Error&)
                       {
                           // an original that cannot be read now is tried, if at all, through
                           // the index
                       }
                   });
    std::erase_if(fits, [](const auto& f) { return !std::isfinite(f.first); });
    std::sort(fits.begin(), fits.end());
    std::vector<std::size_t> assets;
    for (const auto& [rms, a] : fits)
    {
        assets.push_back(a);
    }
    return assets;
}

void closest_variants_first(std::vector<std::pair<float, std::size_t>>& ranked, std::size_t from,
                            std::vector<bool>& taken,
                            const std::vector<std::pair<double, std::size_t>>& variants,
                            const std::vector<float>& distance)
{
    std::vector<bool> is_variant(taken.size(), false);
    for (const auto& [score, a] : variants)
    {
        is_variant[a] = true;
    }
    std::vector<bool> is_place(ranked.size(), false);
    std::size_t places = 0;
    for (std::size_t r = from; r < ranked.size(); ++r)
    {
        if (is_variant[ranked[r].second])
        {
            is_place[r] = true;
            ++places;
        }
    }
    const std::size_t wanted = std::min(kVariantPlaces, variants.size());
    for (std::size_t r = ranked.size(); r > from && places < wanted; --r)
    {
        if (!is_place[r - 1])
        {
            is_place[r - 1] = true;
            ++places;
        }
    }
    std::vector<bool> elsewhere(taken.size(), false);
    for (std::size_t r = 0; r < ranked.size(); ++r)
    {
        taken[ranked[r].second] = false;
        elsewhere[ranked[r].second] = !is_place[r];
    }
    auto next = variants.begin();
    for (std::size_t r = 0; r < ranked.size(); ++r)
    {
        while (is_place[r] && next != variants.end() && elsewhere[next->second])
        {
            ++next;
        }
        if (is_place[r] && next != variants.end())
        {
            ranked[r] = {distance[next->second], next->second};
            ++next;
        }
        taken[ranked[r].second] = true;
    }
}

}  // namespace meshmark::catalog_detail
