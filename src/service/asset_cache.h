// SPDX-License-Identifier: MIT
// The service's warm assets: each original read and its family's shared part built once, kept
// under a memory budget, least recently used dropped first.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "meshmark/catalog/catalog.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/family_copies.h"

namespace meshmark::service
{

/// One asset ready to issue copies: its original in memory and its family's shared part.
struct WarmAsset
{
    std::string id;
    std::string file_name;  ///< The original's file name (copies are named after it).
    MeshFile file;
    std::unique_ptr<FamilyCopies> copies;  ///< Built on `file`, which must stay put.
    std::size_t bytes = 0;                 ///< Its share of the memory budget (an estimate).

    /// Empty when a copy can be written as one file in \p format, else why not (checked once
    /// per format by writing the original's positions).
    [[nodiscard]] std::string format_problem(MeshFormat format) const;

private:
    mutable std::mutex formats_mutex_;
    mutable std::map<MeshFormat, std::string> formats_;
};

/// Counters of AssetCache (for /metrics).
struct CacheStats
{
    std::uint64_t hits = 0;
    std::uint64_t misses = 0;
    std::uint64_t evictions = 0;
    std::size_t bytes = 0;
    std::size_t assets = 0;
};

/// \brief The warm assets of one catalogue. get() builds an asset on first use (requests for an
/// asset being built wait for that one build) and keeps it while the total stays within the
/// budget; assets in use by a request stay alive until it ends even when dropped.
class AssetCache
{
public:
    AssetCache(const Catalog& catalog, std::size_t budget);

    /// \brief The warm asset \p id. \throws InvalidOption (no such asset, incomplete), IoError
    /// (the original missing, changed or unreadable), InvalidMesh, NumericalError.
    [[nodiscard]] std::shared_ptr<const WarmAsset> get(const std::string& id);

    [[nodiscard]] CacheStats stats() const;
    [[nodiscard]] std::size_t budget() const noexcept { return budget_; }

private:
    [[nodiscard]] std::shared_ptr<const WarmAsset> build(const std::string& id) const;
    void evict_locked(const std::string& keep);

    struct Slot
    {
        std::shared_future<std::shared_ptr<const WarmAsset>> future;
        std::list<std::string>::iterator place;  ///< In recency_ (front: most recent).
        std::size_t bytes = 0;                   ///< 0 while building.
    };
    const Catalog& catalog_;
    std::size_t budget_;
    mutable std::mutex mutex_;
    std::unordered_map<std::string, Slot> slots_;
    std::list<std::string> recency_;
    std::size_t bytes_ = 0;
    std::uint64_t hits_ = 0;
    std::uint64_t misses_ = 0;
    std::uint64_t evictions_ = 0;
};

}  // namespace meshmark::service
