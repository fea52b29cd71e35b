// SPDX-License-Identifier: MIT
// `meshmark catalog`'s arguments and what its files share (catalog.cpp, catalog_cluster.cpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_scan.h"

namespace meshmark::cli
{

struct CatalogArgs
{
    std::string catalog;
    std::vector<std::string> inputs;  // add: files and folders; scan: suspects
    std::string output;
    std::string asset;
    std::vector<std::string> recipients;
    std::string recipients_file;
    std::string key;
    std::string report;  // scan: --report PATTERN (.html or .pdf, {suspect} with several suspects)
    bool json = false;
    bool force = false;
    int jobs = 0;
    int candidates = CatalogScanOptions{}.candidates;
    int more_candidates = CatalogScanOptions{}.more_candidates;
    bool all_candidates = false;
    bool all = false;  // reindex: every asset
    double max_false_positive = DetectOptions{}.max_false_positive;
    double lock_timeout = std::chrono::duration<double>(kDefaultLockTimeout).count();
    // add: the watermark's parameters
    double strength = -1.0;
    std::string message;
    std::uint64_t seed = 0;
    bool has_seed = false;
    std::string scheduler;  // add, scan: a Dask scheduler's address (docs/cluster.md)
    EmbedOptions options;
};

/// \brief `catalog add|issue|scan --scheduler`: the command run by meshmark.cluster (python3 -m
/// meshmark.cluster) on the Dask cluster at args.scheduler (docs/cluster.md); its --json report.
/// \p command: "add", "issue" or "scan". \throws the error meshmark.cluster reported, as its type.
[[nodiscard]] nlohmann::json run_on_cluster(const char* command, const CatalogArgs& args,
                                            const GlobalArgs& global);

/// `catalog add`'s messages for \p outcomes on stderr (unless quiet) and its exit code.
[[nodiscard]] int finish_add(const std::string& catalog,
                             const std::vector<CatalogAddOutcome>& outcomes,
                             const GlobalArgs& global);

/// `catalog scan`'s messages for its --json \p report on stderr (unless quiet) and its exit code.
[[nodiscard]] int finish_scan(const nlohmann::json& report, const GlobalArgs& global);

/// `catalog issue`'s message for its --json \p report (\p where: "" or " on the cluster").
void finish_issue(const nlohmann::json& report, const std::string& asset, const char* where,
                  const GlobalArgs& global);

}  // namespace meshmark::cli
