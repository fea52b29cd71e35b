// SPDX-License-Identifier: MIT
// `meshmark catalog migrate SOURCE DESTINATION`: a catalogue copied into a new one, e.g. an
// SQLite file into a PostgreSQL database (docs/catalog.md, "On PostgreSQL").
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "meshmark/catalog/catalog.h"
#include "meshmark/core/error.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct MigrateArgs
{
    std::string source;
    std::string destination;
    bool json = false;
    double lock_timeout = std::chrono::duration<double>(kDefaultLockTimeout).count();
};

bool is_file_location(const std::string& location)
{
    return location.find("://") == std::string::npos;
}

int run_migrate(const MigrateArgs& args, const GlobalArgs& global)
{
    const auto timeout = lock_timeout_of(args.lock_timeout);
    const Catalog source(args.source, Catalog::Open::Existing, timeout);
    // A file this call creates is removed again when the copy fails (nothing half-made is left).
    std::error_code error;
    const bool new_file =
        is_file_location(args.destination) && !std::filesystem::exists(args.destination, error);
    std::size_t assets = 0;
    std::string shown;
    try
    {
        Catalog destination(args.destination, Catalog::Open::CreateIfMissing, timeout);
        shown = destination.path().string();
        assets = destination.copy_from(source);
    }
    catch (...)
    {
        if (new_file)
        {
            for (const char* suffix : {"", "-wal", "-shm"})
            {
                std::filesystem::remove(args.destination + suffix, error);
            }
        }
        throw;
    }
    std::size_t recipients = 0;
    const Catalog copied(args.destination, Catalog::Open::Existing, timeout);
    for (const Catalog::Summary& s : copied.summaries())
    {
        recipients += static_cast<std::size_t>(s.recipients);
    }
    if (args.json)
    {
        print_json({{"source", source.path().string()},
                    {"destination", shown},
                    {"assets", assets},
                    {"recipients", recipients}});
    }
    if (!global.quiet)
    {
        std::fprintf(stderr, "meshmark: %zu assets (%zu recipients) copied from %s into %s\n",
                     assets, recipients, source.path().c_str(), shown.c_str());
    }
    return 0;
}

}  // namespace

void register_catalog_migrate(CLI::App& catalog, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<MigrateArgs>();
    auto* migrate = catalog.add_subcommand(
        "migrate",
        "Copy a whole catalogue into a new one in one transaction (e.g. a file into "
        "postgresql://)");
    migrate->add_option("SOURCE", args->source, "Catalogue file or postgresql:// URL")->required();
    migrate
        ->add_option("DESTINATION", args->destination,
                     "Catalogue file (created when missing) or postgresql:// URL; it must "
                     "hold no asset")
        ->required();
    migrate
        ->add_option("--lock-timeout", args->lock_timeout,
                     "Seconds to wait while another call changes a catalogue, then fail")
        ->check(CLI::Range(0.0, 86400.0))
        ->capture_default_str();
    migrate->add_flag("--json", args->json, "Print what was copied as JSON on stdout");
    add_global_flags(*migrate, global);
    migrate->callback([args, &global, &runner]
                      { runner = [args, &global] { return run_migrate(*args, global); }; });
}

}  // namespace meshmark::cli
