// SPDX-License-Identifier: MIT
// The catalogue commands' --json reports (shared by the CLI and the Python package).
#include "meshmark/catalog/catalog_json.h"

#include <map>

#include "meshmark/catalog/catalog_mark.h"
#include "meshmark/core/error.h"
#include "meshmark/pipeline/report_json.h"

namespace meshmark
{

nlohmann::json to_json(const CatalogAddOutcome& o)
{
    nlohmann::json file = {{"path", o.path.string()},
                           {"asset", o.asset},
                           {"outcome", to_string(o.status)},
                           {"vertices", o.vertex_count},
                           {"seconds", o.seconds}};
    if (!o.reason.empty())
    {
        file["reason"] = o.reason;
    }
    if (!o.published.empty())
    {
        file["published"] = o.published.string();
    }
    return file;
}

CatalogAddOutcome parse_add_outcome(const nlohmann::json& json)
{
    CatalogAddOutcome o;
    try
    {
        o.path = json.at("path").get<std::string>();
        o.asset = json.at("asset").get<std::string>();
        const auto status = json.at("outcome").get<std::string>();
        bool known = false;
        for (const auto s :
             {CatalogAddOutcome::Status::Marked, CatalogAddOutcome::Status::Present,
              CatalogAddOutcome::Status::Unmarkable, CatalogAddOutcome::Status::Failed})
        {
            if (status == to_string(s))
            {
                o.status = s;
                known = true;
            }
        }
        if (!known)
        {
            throw InvalidOption("an add outcome '" + status +
                                "' that is not one of catalog add's.");
        }
        o.vertex_count = json.at("vertices").get<std::int64_t>();
        o.seconds = json.at("seconds").get<double>();
        o.reason = json.value("reason", std::string());
        o.published = json.value("published", std::string());
    }
    catch (const nlohmann::json::exception& e)
    {
        throw InvalidOption(std::string("an add outcome that is not catalog add's (") + e.what() +
                            ").");
    }
    return o;
}

nlohmann::json catalog_add_json(const Catalog& catalog,
                                const std::vector<CatalogAddOutcome>& outcomes)
{
    nlohmann::json files = nlohmann::json::array();
    std::map<std::string, int> counts = {
        {"marked", 0}, {"present", 0}, {"unmarkable", 0}, {"failed", 0}};
    for (const CatalogAddOutcome& o : outcomes)
    {
        ++counts[to_string(o.status)];
        files.push_back(to_json(o));
    }
    return {{"catalog", catalog.path().string()}, {"files", std::move(files)}, {"counts", counts}};
}

nlohmann::json catalog_issue_report_json(const Catalog& catalog, const std::string& asset,
                                         const EmbedRecipientsReport& report)
{
    nlohmann::json out = embed_recipients_report_json(report, asset, catalog.path().string());
    out.erase("key");
    out["catalog"] = catalog.path().string();
    out["asset"] = asset;
    return out;
}

nlohmann::json catalog_reindex_json(const Catalog& catalog,
                                    const std::vector<CatalogReindexOutcome>& outcomes)
{
    nlohmann::json assets = nlohmann::json::array();
    std::map<std::string, int> counts = {{"current", 0}, {"updated", 0}, {"failed", 0}};
    for (const CatalogReindexOutcome& o : outcomes)
    {
        nlohmann::json asset = {
            {"asset", o.asset}, {"outcome", to_string(o.status)}, {"seconds", o.seconds}};
        if (!o.reason.empty())
        {
            asset["reason"] = o.reason;
        }
        ++counts[to_string(o.status)];
        assets.push_back(std::move(asset));
    }
    return {
        {"catalog", catalog.path().string()}, {"assets", std::move(assets)}, {"counts", counts}};
}

nlohmann::json catalog_asset_json(const CatalogAsset& asset,
                                  const std::vector<CatalogRecipient>& recipients)
{
    nlohmann::json names = nlohmann::json::array();
    for (const CatalogRecipient& r : recipients)
    {
        names.push_back({{"name", r.name},
                         {"path", r.path.string()},
                         {"delivered", r.is_delivered},
                         {"issued", r.issued}});
    }
    return {{"asset", asset.id},
            {"original", asset.original.string()},
            {"original_sha256", asset.original_sha256},
            {"published", asset.published.string()},
            {"vertices", asset.vertex_count},
            {"faces", asset.face_count},
            {"added", asset.added},
            {"complete", asset.is_complete},
            {"recipients", std::move(names)}};
}

nlohmann::json catalog_scan_json(const Catalog& catalog, const CatalogScanReport& report,
                                 const CatalogScanOptions& options)
{
    nlohmann::json suspects = nlohmann::json::array();
    DetectOptions per_key = options.detect.decision;
    per_key.max_false_positive /= static_cast<double>(std::max<std::size_t>(report.assets, 1));
    for (const SuspectScan& s : report.suspects)
    {
        nlohmann::json matches = nlohmann::json::array();
        for (const CatalogMatch& m : s.matches)
        {
            nlohmann::json recipients = nlohmann::json::array();
            for (const RecipientScore& r : m.recipients)
            {
                recipients.push_back(
                    {{"name", r.name},
                     {"score", r.score},
                     {"false_positive_probability", r.false_positive_probability}});
            }
            matches.push_back({{"asset", m.asset},
                               {"original", m.original.string()},
                               {"score", m.score},
                               {"false_positive_probability", m.false_positive_probability},
                               {"recipients", std::move(recipients)},
                               {"shape_distance", m.shape_distance},
                               {"rank", m.rank},
                               {"detection", detect_report_json(m.report, per_key)}});
        }
        nlohmann::json tried = nlohmann::json::array();
        for (const CatalogTry& t : s.tried)
        {
            nlohmann::json entry = {{"asset", t.asset},
                                    {"shape_distance", t.shape_distance},
                                    {"false_positive_probability", t.false_positive_probability}};
            if (!t.error.empty())
            {
                entry["error"] = t.error;
            }
            tried.push_back(std::move(entry));
        }
        nlohmann::json suspect = {{"path", s.path.string()},
                                  {"detected", s.detected},
                                  {"matches", std::move(matches)},
                                  {"tried", std::move(tried)},
                                  {"seconds", {{"index", s.index_seconds}, {"total", s.seconds}}}};
        if (!s.error.empty())
        {
            suspect["error"] = s.error;
        }
        suspects.push_back(std::move(suspect));
    }
    return {{"catalog", catalog.path().string()},
            {"assets", report.assets},
            {"max_false_positive", report.max_false_positive},
            {"bound",
             "per suspect, the chance that an unmarked mesh is claimed for any asset of the "
             "catalogue is at "
             "most max_false_positive (each asset's key tested at max_false_positive / assets; "
             "docs/statistics.md)"},
            // Signatures of a build that fanned concave polygons: `catalog reindex` redoes them.
            {"stale_signatures", catalog.has_stale_signatures()},
            {"suspects", std::move(suspects)}};
}

}  // namespace meshmark
