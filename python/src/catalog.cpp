// SPDX-License-Identifier: MIT
// meshmark.Catalog: the catalogue of `meshmark catalog ...` (docs/catalog.md), each call returning
// the matching command's --json report.
#include "meshmark/catalog/catalog.h"

#include <chrono>
#include <memory>
#include <optional>

#include <pybind11/stl.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_evidence.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_reindex.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/error.h"
#include "meshmark/pipeline/report_json.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

using Path = std::filesystem::path;

constexpr const char* kCatalogDoc =
    R"(A catalogue of marked assets (an SQLite file): `meshmark catalog ...`.

Catalog(path, create=False, lock_timeout=60): opens the catalogue (a file, or a PostgreSQL
database given as "postgresql://..."); create=True makes it when missing (as `catalog add` does). Safe to use from several threads and processes at once. Each
method returns the matching command's --json report as a dict (list: the list of assets).)";

}  // namespace

std::chrono::milliseconds timeout_of(double seconds)
{
    if (!(seconds >= 0.0))
    {
        throw InvalidOption("lock_timeout must be >= 0 seconds.");
    }
    return std::chrono::milliseconds(static_cast<std::int64_t>(1000.0 * seconds));
}

CatalogAddOptions catalog_add_options(const OptionalInt& seed, const OptionalFloat& strength,
                                      const OptionalStr& message, int basis_size, int coefficients,
                                      bool force)
{
    CatalogAddOptions options;
    options.embed.seed = seed_from(seed.handle());
    if (const std::optional<double> given = number_from(strength.handle(), "strength"))
    {
        options.embed.embed.strength = *given;
    }
    options.embed.message = text_from(message.handle(), "message");
    options.embed.embed.basis_size = basis_size;
    options.embed.embed.coefficients = coefficients;
    options.force = force;
    return options;
}

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
        .def_property_readonly(
            "path", [](const Catalog& catalog) -> PathlibPath { return py::cast(catalog.path()); },
            "The catalogue's file.")
        .def(
            "add",
            [](const std::shared_ptr<Catalog>& self, const std::vector<Path>& inputs,
               const Path& output, const OptionalInt& seed, const OptionalFloat& strength,
               const OptionalStr& message, int basis_size, int coefficients, int jobs, bool force,
               double lock_timeout, int threads, const OptionalClient& client) -> Report
            {
                if (!client.object.is_none())  // the marking on a Dask cluster (meshmark.cluster)
                {
                    return py::module_::import("meshmark.cluster")
                        .attr("catalog_add")(
                            self, inputs, output, py::arg("client") = client.object,
                            py::arg("seed") = seed, py::arg("strength") = strength,
                            py::arg("message") = message, py::arg("basis_size") = basis_size,
                            py::arg("coefficients") = coefficients, py::arg("force") = force);
                }
                Catalog& catalog = *self;
                CatalogAddOptions options =
                    catalog_add_options(seed, strength, message, basis_size, coefficients, force);
                options.embed.lock_timeout = timeout_of(lock_timeout);
                options.jobs = jobs;
                options.embed.threads = threads;
                std::optional<std::vector<CatalogAddOutcome>> outcomes;
                {
                    py::gil_scoped_release release;
                    outcomes.emplace(catalog_add(catalog, inputs, output, options));
                }
                return to_python(catalog_add_json(catalog, *outcomes));
            },
            py::arg("inputs"), py::arg("output"), py::kw_only(), py::arg("seed") = py::none(),
            py::arg("strength") = py::none(), py::arg("message") = py::none(),
            py::arg("basis_size") = EmbedOptions{}.basis_size,
            py::arg("coefficients") = EmbedOptions{}.coefficients, py::arg("jobs") = 0,
            py::arg("force") = false,
            py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
            py::arg("threads") = 0, py::arg("client") = py::none(),
            "Mark every mesh file under inputs (files and folders) into the folder output and "
            "record them: `meshmark catalog add CATALOG INPUTS... -o OUTPUT --json`. One file's "
            "failure is its outcome; running it again finishes an interrupted call. seed, "
            "strength, message, basis_size, coefficients: as embed's (a seed is mixed with each "
            "asset's id); lock_timeout: seconds to wait for a key another call writes. client: a "
            "dask.distributed Client: the files are marked on its workers, this process records "
            "them (meshmark.cluster; same bytes as a local run with a seed).")
        .def(
            "list",
            [](const Catalog& catalog) -> ReportList
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
            [](const std::shared_ptr<Catalog>& self, const std::string& asset,
               const std::vector<std::string>& recipients, const std::string& output_pattern,
               const OptionalPath& recipients_file, double lock_timeout, int threads,
               const OptionalClient& client) -> Report
            {
                if (!client.object.is_none())  // the copies made on a Dask cluster
                {
                    return py::module_::import("meshmark.cluster")
                        .attr("catalog_issue")(py::cast(self), asset, recipients, output_pattern,
                                               py::arg("client") = client.object,
                                               py::arg("recipients_file") = recipients_file.object,
                                               py::arg("lock_timeout") = lock_timeout);
                }
                Catalog& catalog = *self;
                CatalogIssueOptions options;
                options.recipients = recipients;
                if (const auto file = path_from(recipients_file.handle(), "recipients_file"))
                {
                    // As the program's --recipients: the file's names after the list's.
                    const std::vector<std::string> listed = read_recipients_file(*file);
                    options.recipients.insert(options.recipients.end(), listed.begin(),
                                              listed.end());
                }
                options.lock_timeout = timeout_of(lock_timeout);
                options.threads = threads;
                std::optional<EmbedRecipientsReport> report;
                {
                    py::gil_scoped_release release;
                    report.emplace(catalog_issue(catalog, asset, output_pattern, options));
                }
                return to_python(catalog_issue_report_json(catalog, asset, *report));
            },
            py::arg("asset"), py::arg("recipients"), py::arg("output_pattern"), py::kw_only(),
            py::arg("recipients_file") = py::none(),
            py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
            py::arg("threads") = 0, py::arg("client") = py::none(),
            "Issue traceable copies of an asset (output_pattern holds {recipient}): `meshmark "
            "catalog "
            "issue CATALOG ASSET --recipient NAME... -o PATTERN --json`. Each name is recorded "
            "before "
            "any copy is written; a known name gets the same bytes again. recipients_file: a file "
            "of names, one per line ('#' comments), added after recipients (--recipients). "
            "client: a dask.distributed Client: the names recorded here, the copies made on its "
            "workers (meshmark.cluster).")
        .def(
            "scan",
            [](const std::shared_ptr<Catalog>& self, const std::vector<Path>& suspects,
               int candidates, int more_candidates, bool all_candidates, double max_fpp, bool trace,
               int threads, const OptionalClient& client, const OptionalPath& report_arg) -> Report
            {
                const std::optional<Path> evidence = path_from(report_arg.handle(), "report");
                if (!client.object.is_none())  // the suspects read on a Dask cluster
                {
                    if (evidence)
                    {
                        throw InvalidOption(
                            "report= is written by a local scan: scan those suspects without "
                            "client= for their evidence reports.");
                    }
                    return py::module_::import("meshmark.cluster")
                        .attr("catalog_scan")(
                            py::cast(self), suspects, py::arg("client") = client.object,
                            py::arg("candidates") = candidates,
                            py::arg("more_candidates") = more_candidates,
                            py::arg("all_candidates") = all_candidates,
                            py::arg("max_fpp") = max_fpp, py::arg("trace") = trace);
                }
                const Catalog& catalog = *self;
                CatalogScanOptions options;
                options.detect.trace = trace;
                options.candidates = candidates;
                options.more_candidates = more_candidates;
                options.stop_at_match = !all_candidates;
                options.detect.decision.max_false_positive = max_fpp;
                options.detect.threads = threads;
                // As `catalog scan --report`: one .html or .pdf file per suspect, checked first.
                const std::vector<Path> reports =
                    evidence ? scan_report_paths(evidence->string(), suspects, catalog.path())
                             : std::vector<Path>();
                std::optional<CatalogScanReport> report;
                nlohmann::json json;
                {
                    py::gil_scoped_release release;
                    report.emplace(catalog_scan(catalog, suspects, options));
                    json = catalog_scan_json(catalog, *report, options);
                    for (std::size_t s = 0; s < reports.size(); ++s)
                    {
                        DetectionReportOptions made;
                        made.pictures.threads = threads;
                        made.version = std::string("meshmark ") + MESHMARK_VERSION;
                        made.command = "meshmark.Catalog(" + shell_word(catalog.path().string()) +
                                       ").scan([" + shell_word(suspects[s].string()) +
                                       "], max_fpp=" + shortest(max_fpp) + ")";
                        if (report->suspects[s].error.empty() &&
                            write_scan_evidence(reports[s], catalog, *report, report->suspects[s],
                                                options, made))
                        {
                            json["suspects"][s]["report"] = reports[s].string();
                        }
                    }
                }
                return to_python(json);
            },
            py::arg("suspects"), py::kw_only(),
            py::arg("candidates") = CatalogScanOptions{}.candidates,
            py::arg("more_candidates") = CatalogScanOptions{}.more_candidates,
            py::arg("all_candidates") = false,
            py::arg("max_fpp") = DetectOptions{}.max_false_positive, py::arg("trace") = true,
            py::arg("threads") = 0, py::arg("client") = py::none(), py::arg("report") = py::none(),
            "Which assets (and whose copies) suspects were made from: `meshmark catalog scan "
            "CATALOG SUSPECT... --json`. The bound max_fpp holds per suspect over the whole "
            "catalogue. trace=False: decide on the owners' marks alone, naming no recipient "
            "(detect's --no-trace). client: a dask.distributed Client: the suspects are read on "
            "its workers, each opening the catalogue (meshmark.cluster). report: an evidence "
            "report per suspect, a .html or .pdf path ({suspect} in it for several; --report), "
            "its path then in the suspect's 'report'.")
        .def(
            "reindex",
            [](Catalog& catalog, bool all, int threads) -> Report
            {
                CatalogReindexOptions options;
                options.all = all;
                options.threads = threads;
                std::optional<std::vector<CatalogReindexOutcome>> outcomes;
                {
                    py::gil_scoped_release release;
                    outcomes.emplace(catalog_reindex(catalog, options));
                }
                return to_python(catalog_reindex_json(catalog, *outcomes));
            },
            py::kw_only(), py::arg("all") = false, py::arg("threads") = 0,
            "Recompute from the originals the shape signatures an older build wrote (all=True: "
            "every asset's): `meshmark catalog reindex CATALOG [--all] --json`. One asset's "
            "failure (its original missing or changed) is its outcome.")
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
