// SPDX-License-Identifier: MIT
// `meshmark serve`: the issuing service over a catalogue (docs/service.md).
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "meshmark/core/file_lock.h"

namespace meshmark::service
{

/// Options of Service (`meshmark serve`'s flags).
struct ServiceOptions
{
    std::filesystem::path catalog;
    std::string host = "127.0.0.1";  ///< Loopback unless told otherwise.
    int port = 8750;                 ///< 0: any free port (Service::port() tells which).
    /// The bearer token's file; empty: CATALOG.token. Created (mode 0600, 256 random bits) when
    /// missing; refused when others may read it.
    std::filesystem::path token_file;
    /// The defaults below (budget, connections, upload, timeouts) were chosen by hand; no study
    /// on record (the service study ran at them: bench/results/2026-11-29-service.md).
    /// Bytes of originals and warm bases kept in memory; least recently used assets are dropped.
    std::size_t memory_budget = std::size_t{2} << 30U;
    int workers = 0;       ///< Requests computing at once (copies, scans); 0 = the cores.
    int connections = 64;  ///< Connections served at once (each waits on its client, not the CPU).
    std::size_t max_upload = std::size_t{256} << 20U;  ///< Largest request body (a scan's suspect).
    std::chrono::seconds read_timeout{10};             ///< Longest silence of a client mid-request.
    /// Longest wait of a request for a worker; then 503 with Retry-After.
    std::chrono::milliseconds queue_timeout{30'000};
    std::chrono::milliseconds lock_timeout = kDefaultLockTimeout;  ///< The catalogue's busy wait.
    int scan_candidates = 8;                                       ///< `catalog scan --candidates`.
    int scan_more_candidates = 4;      ///< `catalog scan --more-candidates` (0: no second round).
    double max_false_positive = 1e-6;  ///< `catalog scan --max-fpp`.
    /// Receives one line per request (JSON) and the service's own notices; stderr when empty.
    std::function<void(const std::string&)> log;
};

/// \brief The issuing service: an HTTP/1.1 server on a catalogue (docs/service.md).
/// \details The constructor opens the catalogue, reads (or creates) the token and binds the
/// address, so a failure there is an exception, not a half-started service; run() serves until
/// stop(). Copies are recorded in the catalogue (committed) before their first byte is sent.
class Service
{
public:
    /// \throws IoError (catalogue, token file, address in use), InvalidOption (bad options).
    explicit Service(ServiceOptions options);
    ~Service();
    Service(const Service&) = delete;
    Service& operator=(const Service&) = delete;
    Service(Service&&) = delete;
    Service& operator=(Service&&) = delete;

    /// The port it listens on.
    [[nodiscard]] int port() const noexcept;
    /// The token file in use.
    [[nodiscard]] const std::filesystem::path& token_file() const noexcept;
    /// Serve until stop(); requests in flight finish first.
    void run();
    /// Stop accepting and return from run() once the requests in flight are answered. Safe from
    /// any thread.
    void stop();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// \brief A byte count with an optional unit: "512M", "2G", "1.5GiB", "1000000". \throws
/// InvalidOption naming \p what.
[[nodiscard]] std::size_t parse_bytes(const std::string& text, const std::string& what);

}  // namespace meshmark::service
