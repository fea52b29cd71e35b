// SPDX-License-Identifier: MIT
#pragma once

#include <string>
#include <vector>

#include "meshmark/catalog/catalog.h"
#include "meshmark/pipeline/progress.h"

namespace meshmark
{

/// Options of catalog_reindex.
struct CatalogReindexOptions
{
    /// Recompute every asset's signature, not only those an older build wrote (or none).
    bool all = false;
    int threads = 0;            ///< Assets read at once; 0 = one per core.
    ProgressCallback progress;  ///< ("assets", fraction of the assets done).
};

/// What catalog_reindex did with one asset.
struct CatalogReindexOutcome
{
    enum class Status
    {
        Current,  ///< its signature is this build's: left alone
        Updated,  ///< its signature recomputed from its original and stored
        Failed,   ///< its original is missing, changed since it was added, or unreadable: reason
    };
    std::string asset;
    Status status = Status::Failed;
    std::string reason;  ///< Why, for Failed.
    double seconds = 0.0;
};

/// "current", "updated" or "failed" (catalog reindex --json).
[[nodiscard]] const char* to_string(CatalogReindexOutcome::Status status) noexcept;

/// \brief Recompute the shape signatures of \p catalog's assets from their originals: those
/// written by an older build (positions' features only, or none), or all of them with
/// options.all or when Catalog::has_stale_signatures (every one then, and the mark is cleared
/// once none failed). An original that changed since it was added is not read (its signature would
/// not be the marked asset's): that asset fails and keeps the signature it has. One asset's
/// failure is its outcome, never the batch's; each signature is stored in its own transaction,
/// so an interrupted run keeps what it did.
[[nodiscard]] std::vector<CatalogReindexOutcome> catalog_reindex(
    Catalog& catalog, const CatalogReindexOptions& options);

}  // namespace meshmark
