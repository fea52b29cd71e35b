// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/report/evidence_report.h"

namespace meshmark
{

/// \brief The evidence report files of `catalog scan --report PATTERN` (docs/evidence.md): per
/// suspect, \p pattern with every `{suspect}` replaced by its file name without the extension.
/// \throws InvalidOption (before any work) for an extension other than .html/.htm/.pdf, one file
/// for several suspects, or a report that would overwrite a suspect or the catalogue \p catalog.
[[nodiscard]] std::vector<std::filesystem::path> scan_report_paths(
    const std::string& pattern, const std::vector<std::filesystem::path>& suspects,
    const std::filesystem::path& catalog);

/// \brief Writes \p path, the evidence report of one suspect of a scan: against its strongest
/// match, or, matched by none, against the nearest asset the scan tried (detected again there,
/// under the scan's bound), every probability taken over the catalogue's keys as the scan
/// states them. False (nothing written) when no asset could be compared.
/// \throws IoError, InvalidMesh (the suspect or the original unreadable).
bool write_scan_evidence(const std::filesystem::path& path, const Catalog& catalog,
                         const CatalogScanReport& report, const SuspectScan& scan,
                         const CatalogScanOptions& options, DetectionReportOptions evidence);

}  // namespace meshmark
