// SPDX-License-Identifier: MIT
// `meshmark catalog add|issue|scan`'s messages on stderr and exit codes, from their reports (a
// local run's or a cluster's: catalog.cpp, catalog_cluster.cpp).
#include <cstdio>

#include "catalog_args.h"
#include "meshmark/core/error.h"
#include "report.h"

namespace meshmark::cli
{

int finish_add(const std::string& catalog, const std::vector<CatalogAddOutcome>& outcomes,
               const GlobalArgs& global)
{
    int counts[4] = {0, 0, 0, 0};
    for (const CatalogAddOutcome& o : outcomes)
    {
        ++counts[static_cast<int>(o.status)];
        if (!global.quiet &&
            (o.status == CatalogAddOutcome::Status::Failed ||
             (global.verbose && o.status == CatalogAddOutcome::Status::Unmarkable)))
        {
            std::fprintf(stderr, "meshmark: %s: %s\n", to_string(o.status), o.reason.c_str());
        }
    }
    if (!global.quiet)
    {
        std::fprintf(stderr,
                     "meshmark: %zu files: %d marked, %d already in the catalogue, %d not "
                     "markable, %d failed; "
                     "catalogue %s\n",
                     outcomes.size(), counts[0], counts[1], counts[2], counts[3], catalog.c_str());
    }
    return counts[3] > 0 ? static_cast<int>(ExitCode::InvalidInput) : 0;
}

int finish_scan(const nlohmann::json& report, const GlobalArgs& global)
{
    bool any = false;
    std::size_t unreadable = 0;
    const nlohmann::json& suspects = report.at("suspects");
    const auto assets = report.at("assets").get<std::size_t>();
    for (const nlohmann::json& s : suspects)
    {
        const bool detected = s.at("detected").get<bool>();
        const std::string path = s.at("path").get<std::string>();
        const double seconds = s.contains("seconds") ? s["seconds"].value("total", 0.0) : 0.0;
        any = any || detected;
        const bool failed = s.contains("error");
        unreadable += failed ? 1U : 0U;
        if (global.quiet)
        {
            continue;
        }
        if (failed)
        {
            std::fprintf(stderr, "meshmark: %s\n", s.at("error").get<std::string>().c_str());
            continue;
        }
        if (!detected)
        {
            std::fprintf(stderr,
                         "meshmark: %s: no asset of the catalogue found (%zu tried) in %.2f s\n",
                         path.c_str(), s.at("tried").size(), seconds);
            continue;
        }
        for (const nlohmann::json& m : s.at("matches"))
        {
            std::string names;
            for (const nlohmann::json& r : m.at("recipients"))
            {
                names += (names.empty() ? "" : ", ") + r.at("name").get<std::string>();
            }
            std::fprintf(
                stderr,
                "meshmark: %s: asset %s (false-positive probability %s over the catalogue's %zu "
                "assets)%s%s in %.2f s\n",
                path.c_str(), m.at("asset").get<std::string>().c_str(),
                format_number(m.at("false_positive_probability").get<double>()).c_str(), assets,
                names.empty() ? "" : "; copy of ", names.c_str(), seconds);
        }
    }
    if (!suspects.empty() && unreadable == suspects.size())
    {
        return static_cast<int>(ExitCode::InvalidInput);
    }
    return any ? 0 : 1;
}

void finish_issue(const nlohmann::json& report, const std::string& asset, const char* where,
                  const GlobalArgs& global)
{
    if (global.quiet)
    {
        return;
    }
    int added = 0;
    for (const nlohmann::json& copy : report.at("copies"))
    {
        added += copy.at("new").get<bool>() ? 1 : 0;
    }
    std::fprintf(stderr,
                 "meshmark: issued %zu copies of %s (%d new recipients) in %.3f s%s; recorded "
                 "in %s\n",
                 report.at("copies").size(), asset.c_str(), added,
                 report.at("seconds").value("total", 0.0), where,
                 report.at("catalog").get<std::string>().c_str());
}

}  // namespace meshmark::cli
