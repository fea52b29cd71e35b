// SPDX-License-Identifier: MIT
// `meshmark catalog add|list|issue|scan|reindex|export`: a catalogue of marked assets
// (docs/catalog.md); `catalog migrate`: catalog_migrate.cpp.
#include "meshmark/catalog/catalog.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "catalog_args.h"
#include "commands.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_evidence.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_mark.h"
#include "meshmark/catalog/catalog_reindex.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/report/evidence_report.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

int run_add(const CatalogArgs& args, const GlobalArgs& global)
{
    if (!args.scheduler.empty())
    {
        if (args.jobs != 0)
        {
            throw InvalidOption(
                "--jobs is the local run's: with --scheduler, the workers' "
                "threads decide how many files are marked at once.");
        }
        const nlohmann::json report = run_on_cluster("add", args, global);
        if (args.json)
        {
            print_json(report);
        }
        std::vector<CatalogAddOutcome> outcomes;
        for (const nlohmann::json& file : report.at("files"))
        {
            outcomes.push_back(parse_add_outcome(file));
        }
        return finish_add(report.at("catalog").get<std::string>(), outcomes, global);
    }
    CatalogAddOptions options;
    options.embed.embed.basis_size = args.options.basis_size;
    options.embed.embed.coefficients = args.options.coefficients;
    options.embed.embed.strength = args.strength;
    if (!args.message.empty())
    {
        options.embed.message = args.message;
    }
    if (args.has_seed)
    {
        options.embed.seed = args.seed;
    }
    options.embed.threads = global.threads;
    options.embed.lock_timeout = lock_timeout_of(args.lock_timeout);
    options.jobs = args.jobs;
    options.force = args.force;
    std::vector<std::filesystem::path> inputs(args.inputs.begin(), args.inputs.end());
    Catalog catalog(args.catalog, Catalog::Open::CreateIfMissing,
                    lock_timeout_of(args.lock_timeout));
    const auto outcomes =
        with_progress("meshmark catalog add", global.quiet, options.progress,
                      [&] { return catalog_add(catalog, inputs, args.output, options); });
    if (args.json)
    {
        print_json(catalog_add_json(catalog, outcomes));
    }
    return finish_add(catalog.path().string(), outcomes, global);
}

int run_reindex(const CatalogArgs& args, const GlobalArgs& global)
{
    CatalogReindexOptions options;
    options.all = args.all;
    options.threads = global.threads;
    Catalog catalog(args.catalog, Catalog::Open::Existing, lock_timeout_of(args.lock_timeout));
    const auto outcomes = with_progress("meshmark catalog reindex", global.quiet, options.progress,
                                        [&] { return catalog_reindex(catalog, options); });
    if (args.json)
    {
        print_json(catalog_reindex_json(catalog, outcomes));
    }
    int counts[3] = {0, 0, 0};
    for (const CatalogReindexOutcome& o : outcomes)
    {
        ++counts[static_cast<int>(o.status)];
        if (!global.quiet && o.status == CatalogReindexOutcome::Status::Failed)
        {
            std::fprintf(stderr, "meshmark: %s: %s\n", o.asset.c_str(), o.reason.c_str());
        }
    }
    if (!global.quiet)
    {
        std::fprintf(stderr, "meshmark: %zu assets: %d updated, %d already current, %d failed\n",
                     outcomes.size(), counts[1], counts[0], counts[2]);
    }
    return counts[2] > 0 ? static_cast<int>(ExitCode::InvalidInput) : 0;
}

int run_list(const CatalogArgs& args, const GlobalArgs& /*global*/)
{
    const Catalog catalog(args.catalog, Catalog::Open::Existing,
                          lock_timeout_of(args.lock_timeout));
    const std::vector<CatalogAsset> assets = catalog.assets();
    if (args.json)
    {
        nlohmann::json list = nlohmann::json::array();
        for (const CatalogAsset& a : assets)
        {
            list.push_back(catalog_asset_json(a, catalog.recipients(a.id)));
        }
        print_json({{"catalog", catalog.path().string()}, {"assets", std::move(list)}});
        return 0;
    }
    for (const CatalogAsset& a : assets)
    {
        std::printf("%s\t%s\t%lld vertices\t%zu recipients%s\n", a.id.c_str(), a.original.c_str(),
                    static_cast<long long>(a.vertex_count),
                    a.key.recipients ? a.key.recipients->recipients.size() : std::size_t{0},
                    a.is_complete ? "" : "\t(interrupted: run its `catalog add` again)");
    }
    return 0;
}

int run_issue(const CatalogArgs& args, const GlobalArgs& global)
{
    if (!args.scheduler.empty())
    {
        const nlohmann::json report = run_on_cluster("issue", args, global);
        if (args.json)
        {
            print_json(report);
        }
        finish_issue(report, args.asset, " on the cluster", global);
        return 0;
    }
    CatalogIssueOptions options;
    options.recipients = args.recipients;
    if (!args.recipients_file.empty())
    {
        const std::vector<std::string> listed = read_recipients_file(args.recipients_file);
        options.recipients.insert(options.recipients.end(), listed.begin(), listed.end());
    }
    options.lock_timeout = lock_timeout_of(args.lock_timeout);
    options.threads = global.threads;
    Catalog catalog(args.catalog, Catalog::Open::Existing, options.lock_timeout);
    const EmbedRecipientsReport report =
        with_progress("meshmark catalog issue", global.quiet, options.progress,
                      [&] { return catalog_issue(catalog, args.asset, args.output, options); });
    const nlohmann::json json = catalog_issue_report_json(catalog, args.asset, report);
    if (args.json)
    {
        print_json(json);
    }
    finish_issue(json, args.asset, "", global);
    return 0;
}

// `catalog scan --report`: one evidence report per suspect (docs/evidence.md).
void write_scan_reports(const CatalogArgs& args, const Catalog& catalog,
                        const CatalogScanReport& report, const CatalogScanOptions& options,
                        const GlobalArgs& global)
{
    DetectionReportOptions evidence;
    evidence.pictures.threads = global.threads;
    evidence.version = kVersion;
    std::vector<std::filesystem::path> suspects;
    for (const SuspectScan& scan : report.suspects)
    {
        suspects.push_back(scan.path);
    }
    const std::vector<std::filesystem::path> paths =
        scan_report_paths(args.report, suspects, catalog.path());
    for (std::size_t s = 0; s < report.suspects.size(); ++s)
    {
        const SuspectScan& scan = report.suspects[s];
        if (!scan.error.empty())
        {
            continue;
        }
        const std::filesystem::path& path = paths[s];
        evidence.command = "meshmark catalog scan " + shell_word(catalog.path().string()) + " " +
                           shell_word(scan.path) +
                           (args.max_false_positive != DetectOptions{}.max_false_positive
                                ? " --max-fpp " + shortest(args.max_false_positive)
                                : std::string()) +
                           " --json";
        const bool written = write_scan_evidence(path, catalog, report, scan, options, evidence);
        if (!global.quiet)
        {
            if (written)
            {
                std::fprintf(stderr, "meshmark: %s: report written to %s\n", scan.path.c_str(),
                             path.c_str());
            }
            else
            {
                std::fprintf(stderr,
                             "meshmark: %s: no report (no asset of the catalogue could be "
                             "compared)\n",
                             scan.path.c_str());
            }
        }
    }
}

// A catalogue whose signatures a build that fanned concave polygons computed (scan --json's
// "stale_signatures"), whether scanned here or on a cluster.
void warn_stale_signatures(const std::string& shown)
{
    std::fprintf(stderr,
                 "meshmark: warning: %s: its shape signatures were computed by an older build, "
                 "which read polygons that are not convex wrongly; copies of such assets may be "
                 "missed until `meshmark catalog reindex` recomputes them.\n",
                 shown.c_str());
}

int run_scan(const CatalogArgs& args, const GlobalArgs& global)
{
    if (!args.report.empty())
    {
        (void)scan_report_paths(
            args.report, std::vector<std::filesystem::path>(args.inputs.begin(), args.inputs.end()),
            args.catalog);
    }
    if (!args.scheduler.empty())
    {
        if (!args.report.empty())
        {
            throw InvalidOption(
                "--report is written by a local scan: scan those suspects "
                "without --scheduler for their evidence reports.");
        }
        const nlohmann::json report = run_on_cluster("scan", args, global);
        if (report.value("stale_signatures", false))
        {
            warn_stale_signatures(report.value("catalog", std::string()));
        }
        if (args.json)
        {
            print_json(report);
        }
        return finish_scan(report, global);
    }
    CatalogScanOptions options;
    options.detect.threads = global.threads;
    options.detect.decision.max_false_positive = args.max_false_positive;
    options.candidates = args.candidates;
    options.more_candidates = args.more_candidates;
    options.stop_at_match = !args.all_candidates;
    const Catalog catalog(args.catalog, Catalog::Open::Existing,
                          lock_timeout_of(args.lock_timeout));
    if (catalog.has_stale_signatures())
    {
        warn_stale_signatures(catalog.path().string());
    }
    std::vector<std::filesystem::path> suspects(args.inputs.begin(), args.inputs.end());
    const CatalogScanReport report =
        with_progress("meshmark catalog scan", global.quiet, options.progress,
                      [&] { return catalog_scan(catalog, suspects, options); });
    const nlohmann::json json = catalog_scan_json(catalog, report, options);
    if (args.json)
    {
        print_json(json);
    }
    if (!args.report.empty())
    {
        write_scan_reports(args, catalog, report, options, global);
    }
    return finish_scan(json, global);
}

int run_export(const CatalogArgs& args, const GlobalArgs& global)
{
    const Catalog catalog(args.catalog, Catalog::Open::Existing,
                          lock_timeout_of(args.lock_timeout));
    const std::optional<CatalogAsset> asset = catalog.asset(args.asset);
    if (!asset)
    {
        throw InvalidOption(catalog.path().string() + ": no asset '" + args.asset +
                            "' in the catalogue.");
    }
    if (!args.force && std::filesystem::exists(args.key))
    {
        throw InvalidOption(args.key +
                            ": a file is already there; choose another --key or pass --force.");
    }
    write_key(args.key, asset->key);
    if (!global.quiet)
    {
        std::fprintf(stderr, "meshmark: the key of asset %s (original %s) written to %s\n",
                     args.asset.c_str(), asset->original.c_str(), args.key.c_str());
    }
    return 0;
}

constexpr const char* kCatalogHelp = "Catalogue file or postgresql:// URL";

void add_lock_timeout(CLI::App& command, CatalogArgs& args)
{
    command
        .add_option("--lock-timeout", args.lock_timeout,
                    "Seconds to wait while another call changes the catalogue, then fail")
        ->check(CLI::Range(0.0, 86400.0))
        ->capture_default_str();
}

}  // namespace

void register_catalog(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<CatalogArgs>();
    auto* catalog =
        app.add_subcommand("catalog",
                           "A catalogue of marked assets (SQLite file or PostgreSQL): add, list, "
                           "issue copies, scan suspects (docs/catalog.md)");
    catalog->require_subcommand(1);

    auto* add = catalog->add_subcommand(
        "add", "Mark every mesh file found (folders recursively) into -o and record it; resumable");
    add->add_option("CATALOG", args->catalog,
                    "Catalogue file (created when missing) or postgresql:// URL")
        ->required();
    add->add_option("INPUTS", args->inputs, "Mesh files and folders")
        ->required()
        ->check(CLI::ExistingPath);
    add->add_option("-o,--output", args->output, "Folder of the marked copies")->required();
    add->add_option("--jobs", args->jobs, "Files marked at once (0 = one more than the cores)")
        ->capture_default_str();
    add->add_option("--strength", args->strength, "As embed's (default: embed's)");
    add->add_option("--basis-size", args->options.basis_size, "As embed's")->capture_default_str();
    add->add_option("--coefficients", args->options.coefficients, "As embed's")
        ->capture_default_str();
    add->add_option("--message", args->message, "Payload text (default: random per asset)");
    add->add_option("--seed", args->seed,
                    "Secret seed, mixed with each asset's id (default: random)");
    add->add_flag("--force", args->force,
                  "Mark again, with a new key, originals changed since they were added");
    add->add_option(
        "--scheduler", args->scheduler,
        "Mark on the Dask cluster of this scheduler, tcp://HOST:PORT (docs/cluster.md)");
    add_lock_timeout(*add, *args);
    add->add_flag("--json", args->json, "Print every file's outcome as JSON on stdout");
    add_global_flags(*add, global);
    add->callback(
        [args, &global, &runner, add]
        {
            args->has_seed = add->count("--seed") > 0;
            runner = [args, &global] { return run_add(*args, global); };
        });

    auto* list =
        catalog->add_subcommand("list", "List the catalogue's assets and their recipients");
    list->add_option("CATALOG", args->catalog, kCatalogHelp)->required();
    list->add_flag("--json", args->json, "Print JSON on stdout");
    add_lock_timeout(*list, *args);
    add_global_flags(*list, global);
    list->callback([args, &global, &runner]
                   { runner = [args, &global] { return run_list(*args, global); }; });

    auto* issue = catalog->add_subcommand(
        "issue",
        "Issue traceable copies of an asset to recipients (recorded before they are written)");
    issue->add_option("CATALOG", args->catalog, kCatalogHelp)->required();
    issue->add_option("ASSET", args->asset, "Asset id (catalog list)")->required();
    issue->add_option("--recipient", args->recipients, "Recipient name (repeatable)");
    issue->add_option("--recipients", args->recipients_file, "File of names, one per line")
        ->check(CLI::ExistingFile);
    issue->add_option("-o,--output", args->output, "Copy path pattern containing {recipient}")
        ->required();
    add_lock_timeout(*issue, *args);
    issue->add_option("--scheduler", args->scheduler,
                      "Make the copies on the Dask cluster of this scheduler (docs/cluster.md)");
    issue->add_flag("--json", args->json, "Print a JSON report on stdout");
    add_global_flags(*issue, global);
    issue->callback([args, &global, &runner]
                    { runner = [args, &global] { return run_issue(*args, global); }; });

    auto* scan = catalog->add_subcommand(
        "scan",
        "Find which assets (and whose copies) suspects were made from. Exit 0 when any suspect "
        "matched, 1 when none did");
    scan->add_option("CATALOG", args->catalog, kCatalogHelp)->required();
    scan->add_option("SUSPECTS", args->inputs, "Suspect mesh files")->required();
    scan->add_option("--candidates", args->candidates,
                     "Assets tried per suspect: same numbering, then best shape fit")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    scan->add_option("--more-candidates", args->more_candidates,
                     "Tried after a wider fit when none of those matched (0: none)")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    scan->add_flag("--all-candidates", args->all_candidates,
                   "Try every candidate, not only until one matches");
    scan->add_option("--max-fpp", args->max_false_positive,
                     "Bound on a false claim per suspect over the whole catalogue")
        ->check(CLI::Range(1e-300, 1.0))
        ->capture_default_str();
    add_lock_timeout(*scan, *args);
    scan->add_option("--scheduler", args->scheduler,
                     "Read the suspects on the Dask cluster of this scheduler (docs/cluster.md)");
    scan->add_option(
        "--report", args->report,
        "Write an evidence report per suspect, FILE.html or FILE.pdf; several suspects: "
        "{suspect} in it");
    scan->add_flag("--json", args->json, "Print a JSON report on stdout");
    add_global_flags(*scan, global);
    scan->callback([args, &global, &runner]
                   { runner = [args, &global] { return run_scan(*args, global); }; });

    auto* reindex = catalog->add_subcommand(
        "reindex", "Recompute from the originals the shape signatures an older build wrote");
    reindex->add_option("CATALOG", args->catalog, kCatalogHelp)->required();
    reindex->add_flag("--all", args->all, "Recompute every asset's signature");
    add_lock_timeout(*reindex, *args);
    reindex->add_flag("--json", args->json, "Print every asset's outcome as JSON on stdout");
    add_global_flags(*reindex, global);
    reindex->callback([args, &global, &runner]
                      { runner = [args, &global] { return run_reindex(*args, global); }; });

    auto* exported =
        catalog->add_subcommand("export", "Write an asset's key as a key file (detect --key)");
    exported->add_option("CATALOG", args->catalog, kCatalogHelp)->required();
    exported->add_option("ASSET", args->asset, "Asset id")->required();
    exported->add_option("--key", args->key, "Key file to write (mode 0600)")->required();
    exported->add_flag("--force", args->force, "Replace an existing file");
    add_global_flags(*exported, global);
    exported->callback([args, &global, &runner]
                       { runner = [args, &global] { return run_export(*args, global); }; });

    register_catalog_migrate(*catalog, global, runner);
}

}  // namespace meshmark::cli
