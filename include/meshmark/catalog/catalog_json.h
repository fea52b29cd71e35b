// SPDX-License-Identifier: MIT
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "meshmark/catalog/catalog.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_reindex.h"
#include "meshmark/catalog/catalog_scan.h"

namespace meshmark
{

/// `catalog add --json`: {"catalog", "files": [{"path", "asset", "outcome", "reason"?,
/// "published"?, "vertices", "seconds"}], "counts": {"marked", "present", "unmarkable", "failed"}}.
[[nodiscard]] nlohmann::json catalog_add_json(const Catalog& catalog,
                                              const std::vector<CatalogAddOutcome>& outcomes);

/// `catalog reindex --json`: {"catalog", "assets": [{"asset", "outcome", "seconds", "reason"
/// (failed)}], "counts": {"current", "updated", "failed"}}.
[[nodiscard]] nlohmann::json catalog_reindex_json(
    const Catalog& catalog, const std::vector<CatalogReindexOutcome>& outcomes);

/// `catalog issue --json`: embed_recipients_report_json without "key", with "catalog" and "asset".
[[nodiscard]] nlohmann::json catalog_issue_report_json(const Catalog& catalog,
                                                       const std::string& asset,
                                                       const EmbedRecipientsReport& report);

/// One asset of `catalog list --json` (no key material): {"asset", "original", "original_sha256",
/// "published", "vertices", "faces", "added", "complete", "recipients": [names]}.
[[nodiscard]] nlohmann::json catalog_asset_json(const CatalogAsset& asset,
                                                const std::vector<CatalogRecipient>& recipients);

/// `catalog scan --json`: {"catalog", "assets", "max_false_positive", "bound", "suspects":
/// [{"path", "detected", "matches": [{"asset", "original", "score", "false_positive_probability",
/// "recipients": [{"name", "score", "false_positive_probability"}], "shape_distance", "rank",
/// "detection": (detect --json's fields)}], "tried": [...], "error"?, "seconds"}]}.
[[nodiscard]] nlohmann::json catalog_scan_json(const Catalog& catalog,
                                               const CatalogScanReport& report,
                                               const CatalogScanOptions& options);

}  // namespace meshmark
