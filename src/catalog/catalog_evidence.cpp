// SPDX-License-Identifier: MIT
// `catalog scan --report` (the program) and Catalog.scan(report=...) (Python): a suspect's
// evidence report against the asset the scan found, or the nearest it tried.
#include "meshmark/catalog/catalog_evidence.h"

#include <algorithm>
#include <optional>
#include <set>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/report_json.h"

namespace meshmark
{
namespace fs = std::filesystem;

namespace
{

// \p report with every probability taken over the catalogue's \p assets keys, as the scan
// states them (the union bound over every key it could have tried: docs/statistics.md).
DetectReport over_the_catalogue(DetectReport report, std::size_t assets)
{
    const auto scaled = [assets](double& p) { p = std::min(1.0, p * static_cast<double>(assets)); };
    scaled(report.decision.false_positive_probability);
    scaled(report.decision.score_false_positive_probability);
    scaled(report.decision.bits_false_positive_probability);
    scaled(report.owner_false_positive_probability);
    for (RecipientScore& r : report.accused)
    {
        scaled(r.false_positive_probability);
    }
    return report;
}

}  // namespace

std::vector<fs::path> scan_report_paths(const std::string& pattern,
                                        const std::vector<fs::path>& suspects,
                                        const fs::path& catalog)
{
    (void)evidence_format(pattern);
    std::vector<fs::path> paths;
    std::set<fs::path> seen;
    for (const fs::path& suspect : suspects)
    {
        std::string path = pattern;
        const std::string name = suspect.stem().string();
        for (std::size_t at = path.find("{suspect}"); at != std::string::npos;
             at = path.find("{suspect}", at + name.size()))
        {
            path.replace(at, 9, name);
        }
        if (!seen.insert(path).second)
        {
            throw InvalidOption("--report " + pattern +
                                " names one file for several suspects; put {suspect} "
                                "(the suspect's file name without its extension) in it.");
        }
        if (is_same_file(path, suspect) || is_same_file(path, catalog))
        {
            throw InvalidOption("--report " + path + " would overwrite an input file.");
        }
        paths.emplace_back(path);
    }
    return paths;
}

bool write_scan_evidence(const fs::path& path, const Catalog& catalog,
                         const CatalogScanReport& report, const SuspectScan& scan,
                         const CatalogScanOptions& options, DetectionReportOptions evidence)
{
    std::optional<CatalogAsset> asset;
    DetectReport found;
    if (!scan.matches.empty())
    {
        asset = catalog.asset(scan.matches.front().asset);
        found = scan.matches.front().report;
    }
    else
    {
        for (const CatalogTry& tried : scan.tried)
        {
            if (tried.error.empty() && (asset = catalog.asset(tried.asset)))
            {
                DetectFileOptions detect = options.detect;
                detect.decision.max_false_positive /=
                    static_cast<double>(std::max<std::size_t>(1, report.assets));
                found = detect_against_original(read_mesh(scan.path), asset->original, asset->key,
                                                detect);
                break;
            }
        }
    }
    if (!asset)
    {
        return false;
    }
    DetectOptions decision;
    decision.max_false_positive = options.detect.decision.max_false_positive;
    const std::string key_text = to_json(asset->key);
    const EvidenceFile key{"the key of asset " + asset->id + " (catalog export)", key_text.size(),
                           bytes_sha256(key_text)};
    write_detection_report(
        path, scan.path, asset->original, key,
        detect_report_json(over_the_catalogue(std::move(found), report.assets), decision),
        evidence);
    return true;
}

}  // namespace meshmark
