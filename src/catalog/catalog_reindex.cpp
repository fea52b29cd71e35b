// SPDX-License-Identifier: MIT
// `catalog reindex`: the shape signatures an older build wrote, recomputed from the originals.
#include "meshmark/catalog/catalog_reindex.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <optional>
#include <thread>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

const char* to_string(CatalogReindexOutcome::Status status) noexcept
{
    switch (status)
    {
        case CatalogReindexOutcome::Status::Current:
            return "current";
        case CatalogReindexOutcome::Status::Updated:
            return "updated";
        case CatalogReindexOutcome::Status::Failed:
            break;
    }
    return "failed";
}

std::vector<CatalogReindexOutcome> catalog_reindex(Catalog& catalog,
                                                   const CatalogReindexOptions& options)
{
    // A catalogue an older build wrote read polygons differently: every signature is redone.
    const bool stale = catalog.has_stale_signatures();
    const bool all = options.all || stale;
    const std::vector<Catalog::IndexEntry> index = catalog.shape_index();
    constexpr std::size_t kCurrentSize = static_cast<std::size_t>(kShapeViews) * kShapeFeatures;
    std::vector<CatalogReindexOutcome> outcomes(index.size());

    const auto reindex_one = [&](std::size_t a)
    {
        const auto start = std::chrono::steady_clock::now();
        CatalogReindexOutcome outcome;
        outcome.asset = index[a].id;
        try
        {
            if (!all && index[a].views.size() == kCurrentSize && !index[a].points.empty())
            {
                outcome.status = CatalogReindexOutcome::Status::Current;
                return outcome;
            }
            const std::optional<CatalogAsset> asset = catalog.asset(index[a].id);
            if (!asset)  // removed meanwhile (add --force from another process)
            {
                throw InvalidOption("asset '" + index[a].id + "' is no longer in the catalogue.");
            }
            std::error_code error;
            if (!std::filesystem::is_regular_file(asset->original, error))
            {
                throw IoError(asset->original.string() + ": the original of asset '" + asset->id +
                              "' is missing.");
            }
            if (file_sha256(asset->original) != asset->original_sha256)
            {
                throw InvalidOption(asset->original.string() +
                                    ": the original changed since it was added as asset '" +
                                    asset->id + "'; its signature is left as it is.");
            }
            catalog.set_shape(asset->id, shape_signature(read_mesh_file(asset->original).mesh));
            outcome.status = CatalogReindexOutcome::Status::Updated;
        }
        catch (const std::exception& e)
        {
            outcome.status = CatalogReindexOutcome::Status::Failed;
            outcome.reason = e.what();
        }
        outcome.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return outcome;
    };

    std::atomic<std::size_t> done{0};
    std::mutex progress_mutex;
    for_each_index(index.size(), resolve_threads(options.threads),
                   [&](std::size_t a)
                   {
                       outcomes[a] = reindex_one(a);
                       const std::size_t finished = ++done;
                       if (options.progress)
                       {
                           const std::lock_guard lock(progress_mutex);
                           options.progress("assets", static_cast<double>(finished) /
                                                          static_cast<double>(index.size()));
                       }
                   });
    const bool failed =
        std::any_of(outcomes.begin(), outcomes.end(),
                    [](const auto& outcome)
                    { return outcome.status == CatalogReindexOutcome::Status::Failed; });
    if (stale && !failed)
    {
        catalog.set_signatures_stale(false);
    }
    return outcomes;
}

}  // namespace meshmark
