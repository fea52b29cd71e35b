// SPDX-License-Identifier: MIT
// Internal to `catalog add` (catalog_add.cpp: the plan and the local run; catalog_mark.cpp: the
// tasks, a worker's marking and the coordinator's recording).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "meshmark/catalog/catalog_mark.h"

namespace meshmark::catalog_detail
{

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
