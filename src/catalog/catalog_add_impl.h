// SPDX-License-Identifier: MIT
// Internal to `catalog add` (catalog_add.cpp: the plan and the local run; catalog_mark.cpp: the
// tasks, a worker's marking and the coordinator's recording).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include <unistd.h>

#include "meshmark/catalog/catalog_mark.h"
#include "meshmark/core/error.h"

namespace meshmark::catalog_detail
{

// A private folder under the system's temporary folder, removed with its contents.
class StagingFolder
{
public:
    StagingFolder()
    {
        std::string pattern =
            (std::filesystem::temp_directory_path() / "meshmark-stage-XXXXXX").string();
        if (::mkdtemp(pattern.data()) == nullptr)
        {
            throw IoError(std::filesystem::temp_directory_path().string() +
                          ": cannot make a staging folder for a marked copy.");
        }
        path_ = pattern;
    }
    StagingFolder(const StagingFolder&) = delete;
    StagingFolder& operator=(const StagingFolder&) = delete;
    StagingFolder(StagingFolder&&) = delete;
    StagingFolder& operator=(StagingFolder&&) = delete;
    ~StagingFolder()
    {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

private:
    std::filesystem::path path_;
};

/// The bytes of a file a marking staged. \throws IoError.
[[nodiscard]] std::string read_staged(const std::filesystem::path& path);

/// The checks of an asset before copies are issued: recorded, complete, its original there.
/// \throws InvalidOption, IoError.
[[nodiscard]] CatalogAsset issuable_asset(const Catalog& catalog, const std::string& id);

/// Writes \p bytes to \p to atomically (folders made) unless it already holds them.
void write_unless_same(const std::filesystem::path& to, const std::string& bytes);

/// An OBJ's material libraries and the textures they name, copied from beside \p input to beside
/// \p output under the same relative paths (files whose path would leave the folder are left
/// out: the writer links them back to the original's).
void copy_obj_materials(const std::filesystem::path& input, const std::filesystem::path& output);

/// The store of a marking's family key, made once the original is read (its asset's record
/// and its shape are known then).
using KeyStoreFactory =
    std::function<std::unique_ptr<FamilyKeyStore>(CatalogAsset prototype, ShapeSignature shape)>;

/// \brief Marks \p task's original with the key \p store_of gives into \p output_root / asset
/// (the task's output folder, or a worker's staging folder: links then made from the task's),
/// with \p threads threads. The outcome (Marked, Unmarkable or Failed with its reason); never
/// throws for the file's own problems.
[[nodiscard]] CatalogAddOutcome mark_asset(const CatalogMarkTask& task,
                                           const std::filesystem::path& output_root, int threads,
                                           const KeyStoreFactory& store_of);

}  // namespace meshmark::catalog_detail
