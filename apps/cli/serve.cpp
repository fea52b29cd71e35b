// SPDX-License-Identifier: MIT
// `meshmark serve`: the issuing service over a catalogue (docs/service.md).
#include <csignal>
#include <limits>
#include <memory>
#include <string>
#include <thread>

#include <malloc.h>
#include <pthread.h>

#include "commands.h"
#include "meshmark/core/error.h"
#include "service.h"

namespace meshmark::cli
{
namespace
{

struct ServeArgs
{
    std::string catalog;
    std::string listen = "127.0.0.1:8750";
    std::string token_file;
    std::string memory_budget = "2G";
    std::string max_upload = "256M";
    int workers = 0;
    int connections = service::ServiceOptions{}.connections;
    double read_timeout = 10.0;
    double queue_timeout = 30.0;
    int candidates = service::ServiceOptions{}.scan_candidates;
    int more_candidates = service::ServiceOptions{}.scan_more_candidates;
    double max_false_positive = service::ServiceOptions{}.max_false_positive;
    double lock_timeout = std::chrono::duration<double>(kDefaultLockTimeout).count();
};

// "HOST:PORT", "[V6]:PORT" or ":PORT" (loopback).
void parse_listen(const std::string& text, std::string& host, int& port)
{
    const std::size_t colon = text.rfind(':');
    std::size_t used = 0;
    try
    {
        if (colon == std::string::npos)
        {
            throw std::invalid_argument("no port");
        }
        port = std::stoi(text.substr(colon + 1), &used);
    }
    catch (const std::exception&)
    {
        used = 0;
    }
    if (colon == std::string::npos || used == 0 || used != text.size() - colon - 1 || port < 0 ||
        port > 65535)
    {
        throw InvalidOption(
            "--listen takes HOST:PORT (e.g. 127.0.0.1:8750; port 0: any free one), got '" + text +
            "'.");
    }
    host = text.substr(0, colon);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    {
        host = host.substr(1, host.size() - 2);
    }
    if (host.empty())
    {
        host = "127.0.0.1";
    }
}

int run_serve(const ServeArgs& args, const GlobalArgs& global)
{
    service::ServiceOptions options;
    options.catalog = args.catalog;
    parse_listen(args.listen, options.host, options.port);
    options.token_file = args.token_file;
    options.memory_budget = service::parse_bytes(args.memory_budget, "--memory-budget");
    options.max_upload = service::parse_bytes(args.max_upload, "--max-upload");
    options.workers = args.workers > 0 ? args.workers : global.threads;
    options.connections = args.connections;
    options.read_timeout = std::chrono::seconds(static_cast<long>(std::ceil(args.read_timeout)));
    options.queue_timeout =
        std::chrono::milliseconds(static_cast<long>(args.queue_timeout * 1000.0));
    options.scan_candidates = args.candidates;
    options.scan_more_candidates = args.more_candidates;
    options.max_false_positive = args.max_false_positive;
    options.lock_timeout = lock_timeout_of(args.lock_timeout);
    if (global.quiet)
    {
        options.log = [](const std::string&) {};
    }

#ifdef __GLIBC__
    // A copy of a large asset is a buffer of tens of MB per request (the 437K-vertex dragon's
    // ASCII PLY: 34 MB, built in a 42 MB string). glibc serves blocks over 32 MiB (main() raises
    // the threshold to its maximum) with a fresh mmap() each time, and a thread's own heap holds
    // at most 64 MB, so such blocks got fresh pages, faulted in again, on every request. Here
    // every thread allocates from the main heap, which grows without that limit, blocks are
    // never given their own mapping, and freed memory stays (RSS stays at its peak): one client's
    // dragon copy p50 280-370 ms -> 107-138 ms (bench/service/load.py --single, 3 runs each);
    // 32 clients on the 48K GLB unchanged within the machine's noise (171-203 copies/s both).
    mallopt(M_ARENA_MAX, 1);
    mallopt(M_MMAP_MAX, 0);
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
#endif
    // SIGTERM and SIGINT are taken by one thread (blocked everywhere else, before the service
    // starts its threads), which stops the service: requests in flight are answered first.
    sigset_t stopping;
    sigemptyset(&stopping);
    sigaddset(&stopping, SIGTERM);
    sigaddset(&stopping, SIGINT);
    pthread_sigmask(SIG_BLOCK, &stopping, nullptr);
    std::signal(SIGPIPE, SIG_IGN);  // a client gone mid-answer is an error on its socket only

    service::Service server(options);
    std::thread waiter(
        [&]
        {
            int signal = 0;
            sigwait(&stopping, &signal);
            server.stop();
        });
    server.run();
    pthread_kill(waiter.native_handle(), SIGTERM);  // wakes it when run() ended on its own
    waiter.join();
    return 0;
}

}  // namespace

void register_serve(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<ServeArgs>();
    auto* serve = app.add_subcommand(
        "serve", "Serve a catalogue over HTTP: a marked copy per buyer, scans (docs/service.md)");
    serve
        ->add_option("--catalog", args->catalog,
                     "Catalogue file (meshmark catalog add) or postgresql:// URL")
        ->required();
    serve->add_option("--listen", args->listen, "HOST:PORT to listen on; port 0 picks a free one")
        ->capture_default_str();
    serve->add_option(
        "--token-file", args->token_file,
        "Bearer token file (default CATALOG.token, required with a postgresql:// catalogue; "
        "created, mode 0600, when missing)");
    serve
        ->add_option("--memory-budget", args->memory_budget,
                     "Memory for warm assets (originals and bases)")
        ->capture_default_str();
    serve
        ->add_option("--workers", args->workers,
                     "Requests computed at once (0: --threads, or the cores)")
        ->check(CLI::NonNegativeNumber);
    serve->add_option("--connections", args->connections, "Client connections served at once")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str();
    serve->add_option("--max-upload", args->max_upload, "Largest request body (a suspect to scan)")
        ->capture_default_str();
    serve
        ->add_option("--read-timeout", args->read_timeout,
                     "Seconds a client may stay silent mid-request")
        ->check(CLI::Range(1.0, 3600.0))
        ->capture_default_str();
    serve
        ->add_option("--queue-timeout", args->queue_timeout,
                     "Seconds a request may wait for a worker before a 503")
        ->check(CLI::Range(0.0, 3600.0))
        ->capture_default_str();
    serve->add_option("--candidates", args->candidates, "Scans: assets tried per suspect")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    serve
        ->add_option("--more-candidates", args->more_candidates,
                     "Scans: tried after a wider fit when none of those matched (0: none)")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    serve
        ->add_option("--max-fpp", args->max_false_positive,
                     "Scans: bound on a false claim per suspect")
        ->check(CLI::Range(1e-300, 1.0))
        ->capture_default_str();
    serve->add_option("--lock-timeout", args->lock_timeout, "Seconds to wait for a busy catalogue")
        ->check(non_negative())
        ->capture_default_str();
    add_global_flags(*serve, global);
    serve->callback([args, &global, &runner]
                    { runner = [args, &global] { return run_serve(*args, global); }; });
}

}  // namespace meshmark::cli
