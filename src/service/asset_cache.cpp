// SPDX-License-Identifier: MIT
#include "asset_cache.h"

#include <system_error>
#include <utility>

#include "meshmark/core/error.h"

namespace meshmark::service
{

std::string WarmAsset::format_problem(MeshFormat format) const
{
    const std::lock_guard lock(formats_mutex_);
    if (const auto it = formats_.find(format); it != formats_.end())
    {
        return it->second;
    }
    std::string problem;
    try
    {
        (void)mesh_file_bytes(file, file.mesh.V, format);
    }
    catch (const std::exception& e)
    {
        problem = e.what();
    }
    formats_.emplace(format, problem);
    return problem;
}

AssetCache::AssetCache(const Catalog& catalog, std::size_t budget)
    : catalog_(catalog), budget_(budget)
{
}

std::shared_ptr<const WarmAsset> AssetCache::build(const std::string& id) const
{
    std::optional<CatalogAsset> record = catalog_.asset(id);
    if (!record)
    {
        throw InvalidOption("no asset '" + id + "' in the catalogue.");
    }
    if (!record->is_complete)
    {
        throw InvalidOption(
            "asset '" + id +
            "' was interrupted while being added; run `meshmark catalog add` again.");
    }
    std::error_code error;
    if (!std::filesystem::is_regular_file(record->original, error))
    {
        throw IoError(record->original.string() + ": the original of asset '" + id +
                      "' is no longer there; copies are made from the original.");
    }
    if (file_sha256(record->original) != record->original_sha256)
    {
        throw IoError(
            record->original.string() + ": the original of asset '" + id +
            "' changed since it was added; run `meshmark catalog add --force` to mark it again.");
    }
    auto warm = std::make_shared<WarmAsset>();
    warm->id = id;
    warm->file_name = record->original.filename().string();
    warm->file = read_mesh_file(record->original);
    Key key = std::move(record->key);
    if (key.recipients)
    {
        key.recipients->recipients
            .clear();  // only its parameters are used; the names stay in the catalogue
    }
    if (fingerprint(warm->file.mesh) != key.original)
    {
        throw IoError(record->original.string() + ": this is not the original the key of asset '" +
                      id + "' was made for (vertex count, face count or positions differ).");
    }
    warm->copies = std::make_unique<FamilyCopies>(warm->file, key, record->original, 1);
    const auto n = static_cast<std::size_t>(warm->file.mesh.V.rows());
    const auto f = static_cast<std::size_t>(warm->file.mesh.F.rows());
    // The original's bytes (kept to rewrite), its positions and triangles, the family's part.
    warm->bytes = static_cast<std::size_t>(std::filesystem::file_size(record->original)) + 24 * n +
                  12 * f + warm->copies->memory_bytes();
    return warm;
}

std::shared_ptr<const WarmAsset> AssetCache::get(const std::string& id)
{
    std::shared_future<std::shared_ptr<const WarmAsset>> future;
    std::promise<std::shared_ptr<const WarmAsset>> promise;
    bool builds = false;
    {
        const std::lock_guard lock(mutex_);
        if (const auto it = slots_.find(id); it != slots_.end())
        {
            ++hits_;
            recency_.splice(recency_.begin(), recency_, it->second.place);
            future = it->second.future;
        }
        else
        {
            ++misses_;
            builds = true;
            future = promise.get_future().share();
            recency_.push_front(id);
            slots_.emplace(id, Slot{future, recency_.begin(), 0});
        }
    }
    if (!builds)
    {
        return future.get();  // waits for a build in progress; rethrows its failure
    }
    try
    {
        std::shared_ptr<const WarmAsset> warm = build(id);
        promise.set_value(warm);
        const std::lock_guard lock(mutex_);
        if (const auto it = slots_.find(id); it != slots_.end())
        {
            it->second.bytes = warm->bytes;
            bytes_ += warm->bytes;
            evict_locked(id);
        }
        return warm;
    }
    catch (...)
    {
        promise.set_exception(std::current_exception());
        const std::lock_guard lock(mutex_);
        if (const auto it = slots_.find(id); it != slots_.end())
        {
            recency_.erase(it->second.place);
            slots_.erase(it);  // the next request tries again (the original may be back)
        }
        throw;
    }
}

void AssetCache::evict_locked(const std::string& keep)
{
    // Least recently used first; never the asset just built, nor one still building.
    auto it = recency_.end();
    while (bytes_ > budget_ && it != recency_.begin())
    {
        --it;
        const auto slot = slots_.find(*it);
        if (*it == keep || slot->second.bytes == 0)
        {
            continue;
        }
        bytes_ -= slot->second.bytes;
        ++evictions_;
        slots_.erase(slot);
        it = recency_.erase(it);
    }
}

CacheStats AssetCache::stats() const
{
    const std::lock_guard lock(mutex_);
    return {hits_, misses_, evictions_, bytes_, slots_.size()};
}

}  // namespace meshmark::service
