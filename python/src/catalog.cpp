// SPDX-License-Identifier: MIT
// meshmark.Catalog: the catalogue of `meshmark catalog ...` (docs/catalog.md), each call returning
// the matching command's --json report.
#include "meshmark/catalog/catalog.h"

#include <chrono>
#include <memory>
#include <optional>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/error.h"
#include "meshmark/pipeline/report_json.h"

namespace meshmark::python
{
namespace
{

using Path = std::filesystem::path;

std::chrono::milliseconds timeout_of(double seconds)
{
    if (!(seconds >= 0.0))
    {
        throw InvalidOption("lock_timeout must be >= 0 seconds.");
    }
    return std::chrono::milliseconds(static_cast<std::int64_t>(1000.0 * seconds));
}

constexpr const char* kCatalogDoc =
    R"(A catalogue of marked assets (an SQLite file): `meshmark catalog ...`.

Catalog(path, create=False, lock_timeout=60): opens the catalogue (a file, or a PostgreSQL
database given as "postgresql://..."); create=True makes it when missing (as `catalog add` does). Safe to use from several threads and processes at once. Each
method returns the matching command's --json report as a dict (list: the list of assets).)";

}  // namespace

void bind_catalog(py::module_& m)
{
    py::class_<Catalog, std::shared_ptr<Catalog>>(m, "Catalog", kCatalogDoc)
        .def(py::init(
                 [](const Path& path, bool create, double lock_timeout)
                 {
                     return std::make_shared<Catalog>(
                         path, create ? Catalog::Open::CreateIfMissing : Catalog::Open::Existing,
                         timeout_of(lock_timeout));
                 }),
             py::arg("path"), py::kw_only(), py::arg("create") = false,
             py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count())
        .def_property_readonly("path", &Catalog::path)
        .def(
            "add",
            [](Catalog& catalog, const std::vector<Path>& inputs, const Path& output,
               py::object seed, py::object strength, py::object message, int jobs, bool force,
               int threads)
            {
                CatalogAddOptions options;
                if (!seed.is_none())
                {
                    options.embed.seed = seed.cast<std::uint64_t>();
                }
                if (!strength.is_none())
                {
                    options.embed.embed.strength = strength.cast<double>();
                }
                if (!message.is_none())
                {
                    options.embed.message = message.cast<std::string>();
                }
                options.jobs = jobs;
                options.force = force;
                options.embed.threads = threads;
                std::optional<std::vector<CatalogAddOutcome>> outcomes;
                {
                    py::gil_scoped_release release;
                    outcomes.emplace(catalog_add(catalog, inputs, output, options));
                }
                return to_python(catalog_add_json(catalog, *outcomes));
            },
            py::arg("inputs"), py::arg("output"), py::kw_only(), py::arg("seed") = py::none(),
            py::arg("strength") = py::none(), py::arg("message") = py::none(), py::arg("jobs") = 0,
            py::arg("force") = false, py::arg("threads") = 0,
            "Mark every mesh file under inputs (files and folders) into the folder output and "
            "record "
            "them: `meshmark catalog add CATALOG INPUTS... -o OUTPUT --json`. One file's failure "
            "is "
            "its outcome; running it again finishes an interrupted call.")
        .def(
            "list",
            [](const Catalog& catalog)
            {
                nlohmann::json assets = nlohmann::json::array();
                for (const CatalogAsset& a : catalog.assets())
                {
                    assets.push_back(catalog_asset_json(a, catalog.recipients(a.id)));
                }
                return to_python(assets);
            },
            "The assets, as `meshmark catalog list --json` lists them (no key material).")
        .def(
            "issue",
            [](Catalog& catalog, const std::string& asset,
               const std::vector<std::string>& recipients, const std::string& output_pattern,
               double lock_timeout, int threads)
            {
                CatalogIssueOptions options;
                options.recipients = recipients;
                options.lock_timeout = timeout_of(lock_timeout);
                options.threads = threads;
                std::optional<EmbedRecipientsReport> report;
                {
                    py::gil_scoped_release release;
                    report.emplace(catalog_issue(catalog, asset, output_pattern, options));
                }
                nlohmann::json out =
                    embed_recipients_report_json(*report, asset, catalog.path().string());
                out.erase("key");
                out["catalog"] = catalog.path().string();
                out["asset"] = asset;
                return to_python(out);
            },
            py::arg("asset"), py::arg("recipients"), py::arg("output_pattern"), py::kw_only(),
            py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
            py::arg("threads") = 0,
            "Issue traceable copies of an asset (output_pattern holds {recipient}): `meshmark "
            "catalog "
            "issue CATALOG ASSET --recipient NAME... -o PATTERN --json`. Each name is recorded "
            "before "
            "any copy is written; a known name gets the same bytes again.")
        .def(
            "scan",
            [](const Catalog& catalog, const std::vector<Path>& suspects, int candidates,
               bool all_candidates, double max_fpp, int threads)
            {
                CatalogScanOptions options;
                options.candidates = candidates;
                options.stop_at_match = !all_candidates;
                options.detect.decision.max_false_positive = max_fpp;
                options.detect.threads = threads;
                std::optional<CatalogScanReport> report;
                {
                    py::gil_scoped_release release;
                    report.emplace(catalog_scan(catalog, suspects, options));
                }
                return to_python(catalog_scan_json(catalog, *report, options));
            },
            py::arg("suspects"), py::kw_only(),
            py::arg("candidates") = CatalogScanOptions{}.candidates,
            py::arg("all_candidates") = false,
            py::arg("max_fpp") = DetectOptions{}.max_false_positive, py::arg("threads") = 0,
            "Which assets (and whose copies) suspects were made from: `meshmark catalog scan "
            "CATALOG "
            "SUSPECT... --json`. The bound max_fpp holds per suspect over the whole catalogue.")
        .def(
            "key",
            [](const Catalog& catalog, const std::string& asset)
            {
                const std::optional<CatalogAsset> found = catalog.asset(asset);
                if (!found)
                {
                    throw InvalidOption(catalog.path().string() + ": no asset '" + asset +
                                        "' in the catalogue.");
                }
                return found->key;
            },
            py::arg("asset"), "The asset's family key (meshmark.Key; key.save(path) exports it).");
}

}  // namespace meshmark::python
