// SPDX-License-Identifier: MIT
// `catalog issue` in three steps, so that recipients' copies can be made on Dask workers
// (docs/cluster.md) while the coordinator alone writes the catalogue: plan (the coordinator
// records every new name with its code, then splits the copies into tasks), make (a worker:
// the copies' files in memory, nothing recorded) and deliver (the coordinator writes them and
// records them delivered). Recorded before released, as catalog_issue.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "meshmark/catalog/catalog_scan.h"

namespace meshmark
{

/// Some of one asset's recipients' copies to make: everything but the catalogue. Its key holds
/// every name of its copies (recorded), so making them records nothing and, run twice, makes
/// the same bytes.
struct CatalogCopyTask
{
    std::size_t first = 0;  ///< Index of its first copy among the plan's.
    std::string asset;
    std::filesystem::path original;  ///< Absolute.
    std::string original_sha256;
    Key key;
    std::vector<IssuedCopy> copies;  ///< name, index, final path (absolute), is_new

    /// {"first", "asset", "original", "original_sha256", "key", "copies": [{"name", "index",
    /// "path", "new"}]}; parse_copy_task reads it back.
    [[nodiscard]] nlohmann::json to_json() const;
    /// A name from its content (a cluster's task key): "meshmark-issue-<sha256>-<hash>".
    [[nodiscard]] std::string name() const;
};

/// \throws InvalidOption for JSON that is not a CatalogCopyTask's.
[[nodiscard]] CatalogCopyTask parse_copy_task(const nlohmann::json& json);

/// What catalog_plan_issue recorded and split.
struct CatalogIssuePlan
{
    Key key;                         ///< The family key as recorded, every name included.
    std::vector<IssuedCopy> copies;  ///< This call's copies, in the order named (no stats yet).
    std::vector<CatalogCopyTask> tasks;
};

/// The plan without its tasks: {"key" (key file JSON), "copies": [{"name", "index", "path",
/// "new"}]}; parse_issue_plan reads it back (no tasks).
[[nodiscard]] nlohmann::json to_json(const CatalogIssuePlan& plan);
[[nodiscard]] CatalogIssuePlan parse_issue_plan(const nlohmann::json& json);

/// \brief catalog_issue's first step, on the coordinator: checks as catalog_issue does, records
/// every new name of options.recipients with its code (one transaction, durable before this
/// returns) and splits the copies into tasks of at most \p per_task (>= 1).
/// \throws as catalog_issue.
[[nodiscard]] CatalogIssuePlan catalog_plan_issue(Catalog& catalog, const std::string& asset,
                                                  const std::string& output_pattern,
                                                  const CatalogIssueOptions& options,
                                                  std::size_t per_task);

/// A task's copies, made: their stats and files.
struct CatalogMadeCopies
{
    std::vector<IssuedCopy> copies;  ///< with their stats
    std::int64_t vertex_count = 0;
    std::int64_t face_count = 0;
    /// Absolute paths and bytes: what a copy's format carries beside it first, the copies last.
    std::vector<std::pair<std::filesystem::path, std::string>> files;

    /// {"copies": [{"name", "index", "path", "new", "stats": {...}}], "vertices", "faces"}
    /// without the files.
    [[nodiscard]] nlohmann::json to_json() const;
};

/// \throws InvalidOption for JSON that is not a CatalogMadeCopies' (files not included).
[[nodiscard]] CatalogMadeCopies parse_made_copies(const nlohmann::json& json);

/// \brief A worker's step: the task's copies made from its original (refused when its SHA-256
/// is not the task's) in a private staging folder and read back (links to the original's files
/// as from each copy's final folder). Records nothing.
/// \throws as embed_recipients (the task failed: the call fails, the names stay recorded).
[[nodiscard]] CatalogMadeCopies catalog_make_copies(const CatalogCopyTask& task, int threads = 1);

/// \brief The coordinator's last step: writes \p made's files atomically (the copies last) and
/// records the copies delivered. \throws IoError.
void catalog_deliver(Catalog& catalog, const CatalogCopyTask& task, const CatalogMadeCopies& made);

/// \brief `catalog issue --json`'s report of a plan whose tasks were made: \p made in the
/// tasks' order.
[[nodiscard]] nlohmann::json catalog_issue_json(const Catalog& catalog, const std::string& asset,
                                                const CatalogIssuePlan& plan,
                                                const std::vector<CatalogMadeCopies>& made,
                                                double seconds);

}  // namespace meshmark
