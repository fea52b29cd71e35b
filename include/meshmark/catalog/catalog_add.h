// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/catalog/catalog.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/pipeline/progress.h"

namespace meshmark
{

/// Options of catalog_add.
struct CatalogAddOptions
{
    /// The watermark's parameters (EmbedMeshOptions: strength, k, m, seed, message...); the
    /// recipients are set by catalog_add. A seed given here is mixed with each asset's id, so no
    /// two assets share a key.
    EmbedRecipientsOptions embed;
    int jobs = 0;  ///< Assets marked at once; 0 = one more than the cores (each on one thread).
    /// Mark again, with a new key, an asset whose original changed since it was added (its
    /// earlier copies are then no longer traced); otherwise such a file is refused.
    bool force = false;
    ProgressCallback progress;  ///< ("N/M file", fraction of the files done).
};

/// What catalog_add did with one file.
struct CatalogAddOutcome
{
    enum class Status
    {
        Marked,      ///< marked and recorded now
        Present,     ///< already in the catalogue, unchanged: nothing done
        Unmarkable,  ///< a mesh the watermark cannot use (too small, degenerate): reason
        Failed,      ///< unreadable, refused, changed since added, or not written: reason
    };
    std::filesystem::path path;  ///< The file as found.
    std::string asset;           ///< Its asset id.
    Status status = Status::Failed;
    std::string reason;               ///< Why, for Unmarkable and Failed.
    std::filesystem::path published;  ///< The marked copy (Marked and Present).
    std::int64_t vertex_count = 0;
    double seconds = 0.0;
};

/// "marked", "present", "unmarkable" or "failed" (catalog add --json).
[[nodiscard]] const char* to_string(CatalogAddOutcome::Status status) noexcept;

/// \brief The mesh files under \p inputs (files as given; folders searched recursively for the
/// extensions meshmark reads, hidden files and folders and \p skip left out), each with its asset
/// id: its path under the folder it was found in (a file given by name: its name), '/'-separated.
/// \throws InvalidOption for an input that does not exist.
[[nodiscard]] std::vector<std::pair<std::filesystem::path, std::string>> find_mesh_files(
    const std::vector<std::filesystem::path>& inputs, const std::filesystem::path& skip = {});

/// \brief Mark every mesh file under \p inputs and record it in \p catalog (docs/catalog.md):
/// per file, its published copy is written to \p output_folder / its asset id, with the
/// materials and textures its format references, marked with a new family key (the copy is
/// the key's recipient kPublishedRecipient).
/// \details Files are marked options.jobs at a time; one file's failure is its outcome, never
/// the batch's. An asset already complete with the same original is left alone, so running
/// the same call again finishes an interrupted one; its key, recorded before its copy was
/// written, makes the same bytes again.
/// \throws InvalidOption for bad options or inputs (before any work).
[[nodiscard]] std::vector<CatalogAddOutcome> catalog_add(
    Catalog& catalog, const std::vector<std::filesystem::path>& inputs,
    const std::filesystem::path& output_folder, const CatalogAddOptions& options);

}  // namespace meshmark
