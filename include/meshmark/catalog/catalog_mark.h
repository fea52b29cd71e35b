// SPDX-License-Identifier: MIT
// `catalog add` in three steps, so that the marking can run elsewhere (a Dask worker,
// docs/cluster.md) while the coordinator alone writes the catalogue: plan (the coordinator:
// which files need marking, each with everything a worker needs), mark (anywhere: the marked
// copy's files in memory, nothing recorded) and record (the coordinator: the key recorded, then
// the files written, then the asset marked complete). catalog_add runs the same steps in
// threads, writing in place.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "meshmark/catalog/catalog_add.h"

namespace meshmark
{

/// One file to mark, as catalog_plan_add plans it: everything the marking needs but the
/// catalogue. Its result is a function of its fields alone (the seed is resolved, a recorded
/// key given), so a task run twice makes the same bytes.
struct CatalogMarkTask
{
    std::size_t file = 0;  ///< Its index in the plan's outcomes.
    std::string asset;
    std::filesystem::path input;          ///< The file as found.
    std::filesystem::path original;       ///< Absolute.
    std::string original_sha256;          ///< What the original held when planned (checked).
    std::filesystem::path output_folder;  ///< Absolute: the published copy is output_folder/asset.
    std::filesystem::path published;      ///< Absolute.
    /// An interrupted add of these bytes: its recorded key, which makes the same copy again.
    std::optional<Key> key;
    /// The watermark's parameters of a new key (seed resolved: given, mixed with the asset's
    /// id; or drawn by the planner). Serialized: k, m, strength, message, seed.
    EmbedRecipientsOptions embed;

    /// {"file", "asset", "input", "original", "original_sha256", "output_folder", "published",
    /// "key"?, "embed": {...}}; parse_mark_task reads it back.
    [[nodiscard]] nlohmann::json to_json() const;
    /// A name for the task from its content (the original's hash, the asset, the key or seed and
    /// parameters): the same task, the same name (a cluster's task key).
    [[nodiscard]] std::string name() const;
};

/// \throws InvalidOption for JSON that is not a CatalogMarkTask's.
[[nodiscard]] CatalogMarkTask parse_mark_task(const nlohmann::json& json);

/// What catalog_plan_add decided: an outcome per file found (those of tasks still to do are
/// filled by catalog_record), and the tasks.
struct CatalogAddPlan
{
    std::vector<CatalogAddOutcome> outcomes;
    std::vector<CatalogMarkTask> tasks;
};

/// \brief catalog_add's first step, on the coordinator: the files under \p inputs, each either
/// decided (already in the catalogue, refused: its outcome) or a task. Changes the catalogue
/// only to remove an asset whose original changed (with options.force) or an interrupted add of
/// other bytes, as catalog_add does.
/// \throws InvalidOption for bad options or inputs (before any work).
[[nodiscard]] CatalogAddPlan catalog_plan_add(Catalog& catalog,
                                              const std::vector<std::filesystem::path>& inputs,
                                              const std::filesystem::path& output_folder,
                                              const CatalogAddOptions& options);

/// A marked asset, in memory: what catalog_record needs.
struct CatalogMarkedAsset
{
    CatalogAddOutcome outcome;  ///< Marked (key, signature and files set), or why not.
    std::optional<Key> key;
    std::vector<std::uint8_t> signature;  ///< ShapeSignature::to_bytes
    std::int64_t face_count = 0;
    /// The files to write, paths relative to the task's output folder ('/'-separated): the
    /// published copy last, what it references (materials, textures, buffers) before it.
    std::vector<std::pair<std::string, std::string>> files;

    /// {"outcome": {...}, "key"?, "signature" (hex), "faces"} without the files.
    [[nodiscard]] nlohmann::json to_json() const;
};

/// \throws InvalidOption for JSON that is not a CatalogMarkedAsset's (files not included).
[[nodiscard]] CatalogMarkedAsset parse_marked_asset(const nlohmann::json& json);

/// \brief catalog_add's second step, anywhere the original is readable (a cluster's worker):
/// reads it (refusing other bytes than the task's hash), marks it with a new family key or the
/// task's and returns the copy's files, staged in a private temporary folder and read back
/// (links to the original's files as they will be from the output folder). Records nothing.
/// A file that cannot be marked is the outcome's reason, never an exception.
[[nodiscard]] CatalogMarkedAsset catalog_mark(const CatalogMarkTask& task, int threads = 1);

/// \brief catalog_add's last step, on the coordinator: records \p marked's asset and key (one
/// transaction), writes its files under the task's output folder (atomically, the published
/// copy last), then records it complete; the outcome. An asset recorded meanwhile with the
/// same original and complete is left alone (Present): recording a task twice records once.
[[nodiscard]] CatalogAddOutcome catalog_record(Catalog& catalog, const CatalogMarkTask& task,
                                               CatalogMarkedAsset marked);

/// The outcome as `catalog add --json` shows one file, and back (a cluster's results).
[[nodiscard]] nlohmann::json to_json(const CatalogAddOutcome& outcome);
[[nodiscard]] CatalogAddOutcome parse_add_outcome(const nlohmann::json& json);

}  // namespace meshmark
