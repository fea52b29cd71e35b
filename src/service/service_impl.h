// SPDX-License-Identifier: MIT
// The issuing service's state and what its requests share: service.cpp starts and stops it,
// service_handlers.cpp answers copies and scans, service_routes.cpp holds the routes and the
// access log. Internal to the service module.
#pragma once

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <span>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <openssl/crypto.h>
#include <sys/socket.h>
#include <unistd.h>

#include "asset_cache.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/error.h"
#include "metrics.h"
#include "requests.h"
#include "service.h"
#include "token.h"
#include "workers.h"

// Last: it includes <resolv.h>, whose `_res` macro breaks Eigen's headers included after it.
#include <httplib.h>

namespace meshmark::service
{

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// Largest JSON body of a copy request (an asset id and a recipient name need far less); chosen by
// hand; no study on record.
inline constexpr std::size_t kMaxCopyRequest = 64 * 1024;

// What the request being served on this thread did, for its log line and its metrics (a
// request is read, handled and answered on one thread of the connection pool).
struct RequestInfo
{
    Clock::time_point start;
    std::string route = "other";
    std::string asset;
    std::string record;
    std::string error;
};
inline thread_local RequestInfo current;

inline std::string utc_now()
{
    const auto now = std::chrono::system_clock::now();
    const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
    const auto millis =
        std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() %
        1000;
    std::tm utc{};
    gmtime_r(&seconds, &utc);
    char text[40];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
    char full[48];
    std::snprintf(full, sizeof full, "%s.%03dZ", text, static_cast<int>(millis));
    return full;
}

// A JSON error body: {"error": sentence}. The sentence never holds key material (no message
// of this module or of the library below it prints a key's seed or payload).
inline void fail(httplib::Response& res, int status, const std::string& sentence)
{
    res.status = status;
    res.body =
        Json{{"error", sentence}}.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
    res.set_header("Content-Type", "application/json");
    current.error = sentence;
}

inline void send_json(httplib::Response& res, const Json& body)
{
    res.status = 200;
    res.body = body.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
    res.set_header("Content-Type", "application/json");
}

struct Service::Impl
{
    ServiceOptions options;
    std::unique_ptr<Catalog> catalog;
    std::string token;
    fs::path token_path;
    std::unique_ptr<AssetCache> cache;
    Metrics metrics;
    std::unique_ptr<WorkerQueue> slots;
    BufferPool buffers;
    fs::path spool;  // private folder of suspects being scanned
    std::atomic<std::uint64_t> spooled{0};
    httplib::Server server;
    int port = 0;
    std::atomic<bool> stopping{false};

    void log(const std::string& line) const
    {
        if (options.log)
        {
            options.log(line);
        }
        else
        {
            std::fprintf(stderr, "%s\n", line.c_str());
        }
    }

    void notice(const std::string& sentence) const
    {
        log(Json{{"time", utc_now()}, {"notice", sentence}}.dump(-1, ' ', false,
                                                                 Json::error_handler_t::replace));
    }

    bool authorized(const httplib::Request& req) const
    {
        const std::string header = req.get_header_value("Authorization");
        static constexpr std::string_view kBearer = "Bearer ";
        if (header.size() != kBearer.size() + token.size() ||
            header.compare(0, kBearer.size(), kBearer) != 0)
        {
            return false;
        }
        return CRYPTO_memcmp(header.data() + kBearer.size(), token.data(), token.size()) == 0;
    }

    // Runs \p work holding a worker slot; answers 503 when none frees up in time, and turns the
    // library's exceptions into statuses (docs/service.md, "Errors").
    template <class Work>
    void compute(httplib::Response& res, Work&& work)
    {
        const InFlight counted(metrics.in_flight);
        WorkerSlot slot(*slots, options.queue_timeout);
        if (!slot.held())
        {
            res.set_header("Retry-After", "1");
            fail(res, 503,
                 "every worker stayed busy for " +
                     std::to_string(static_cast<double>(options.queue_timeout.count()) / 1000.0)
                         .substr(0, 4) +
                     " s; try again.");
            return;
        }
        try
        {
            work(slot);
        }
        catch (const InvalidOption& e)
        {
            const std::string what = e.what();
            fail(res,
                 what.find("no asset") != std::string::npos      ? 404
                 : what.find("interrupted") != std::string::npos ? 409
                                                                 : 400,
                 what);
        }
        catch (const IoError& e)
        {
            fail(res, 503,
                 std::string(e.what()));  // the catalogue busy, an original missing or changed
        }
        catch (const InvalidMesh& e)
        {
            fail(res, 422, std::string(e.what()));
        }
        catch (const NumericalError& e)
        {
            fail(res, 422, std::string(e.what()));
        }
    }

    void issue_copy(const httplib::Request& req, httplib::Response& res);
    void scan(const httplib::Request& req, httplib::Response& res);
    static Json summary_json(const Catalog::Summary& s);
    void routes();
};

}  // namespace meshmark::service
