// SPDX-License-Identifier: MIT
// The issuing service (docs/service.md): cpp-httplib's server (Debian's libcpp-httplib) on a
// catalogue. Connections are served by a pool of `connections` threads, each of which mostly
// waits on its client; the work (a copy, a scan, warming an asset) runs only while holding one
// of `workers` slots, so 32 keep-alive clients share the cores instead of oversubscribing them.
#include "service.h"

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
#include "token.h"
#include "workers.h"

// Last: it includes <resolv.h>, whose `_res` macro breaks Eigen's headers included after it.
#include <httplib.h>

// cpp-httplib 0.11 ends its accept loop, and with it the service, on any error of accept(2)
// but EMFILE. Linux's accept passes errors of connections that died in the queue (ECONNABORTED,
// EPROTO, the pending network errors) and EINTR, and its manual says to retry on them: this
// definition takes the place of libc's for the library (the executable's symbol comes first in
// the dynamic lookup) and does so, so one client that resets mid-handshake cannot stop the
// service. Every other error is returned as it was.
extern "C" int accept(int fd, struct sockaddr* address, socklen_t* length)
{
    for (;;)
    {
        const int socket = ::accept4(fd, address, length, 0);
        if (socket >= 0)
        {
            return socket;
        }
        switch (errno)
        {
            case EINTR:
            case ECONNABORTED:
            case EPROTO:
            case ENETDOWN:
            case ENOPROTOOPT:
            case EHOSTDOWN:
            case ENONET:
            case EHOSTUNREACH:
            case EOPNOTSUPP:
            case ENETUNREACH:
                continue;
            default:
                return -1;
        }
    }
}

namespace meshmark::service
{
namespace
{

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// Largest JSON body of a copy request (an asset id and a recipient name need far less); chosen by
// hand; no study on record.
constexpr std::size_t kMaxCopyRequest = 64 * 1024;

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
thread_local RequestInfo current;

std::string utc_now()
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
void fail(httplib::Response& res, int status, const std::string& sentence)
{
    res.status = status;
    res.body =
        Json{{"error", sentence}}.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
    res.set_header("Content-Type", "application/json");
    current.error = sentence;
}

void send_json(httplib::Response& res, const Json& body)
{
    res.status = 200;
    res.body = body.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
    res.set_header("Content-Type", "application/json");
}

}  // namespace

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

    void issue_copy(const httplib::Request& req, httplib::Response& res)
    {
        current.route = "copies";
        const std::string id = req.matches[1];
        current.asset = id;
        if (const std::string problem = asset_problem(id); !problem.empty())
        {
            fail(res, 400, problem + ".");
            return;
        }
        if (req.body.size() > kMaxCopyRequest)
        {
            fail(
                res, 413,
                "a copy request's body has at most " + std::to_string(kMaxCopyRequest) + " bytes.");
            return;
        }
        Json body;
        try
        {
            body = Json::parse(req.body);
        }
        catch (const Json::exception&)
        {
            fail(res, 400,
                 "the body is not JSON; send {\"recipient\": NAME, \"format\": \"glb\"} (format "
                 "optional).");
            return;
        }
        if (!body.is_object() || !body.contains("recipient") || !body["recipient"].is_string())
        {
            fail(res, 400, "the body needs \"recipient\": the buyer's name, a string.");
            return;
        }
        for (const auto& [name, value] : body.items())
        {
            if (name != "recipient" && name != "format")
            {
                fail(res, 400,
                     "unknown field \"" + name +
                         "\"; a copy request has \"recipient\" and \"format\".");
                return;
            }
        }
        const std::string recipient = body["recipient"].get<std::string>();
        try
        {
            check_recipient_name(recipient);
        }
        catch (const InvalidOption& e)
        {
            fail(res, 400, e.what());
            return;
        }
        std::optional<MeshFormat> format;
        if (body.contains("format"))
        {
            if (!body["format"].is_string() ||
                !(format = format_named(body["format"].get<std::string>())))
            {
                fail(res, 415, "\"format\" is one of ply, obj, off, stl, gltf, glb, 3mf.");
                return;
            }
        }
        compute(
            res,
            [&](WorkerSlot& slot)
            {
                const std::shared_ptr<const WarmAsset> warm = cache->get(id);
                const MeshFormat chosen = format.value_or(warm->file.format);
                if (const std::string problem = warm->format_problem(chosen); !problem.empty())
                {
                    fail(res, 422, problem);
                    return;
                }
                // Recorded (committed) before a byte of the copy exists: a crash from here on
                // leaves a name without a copy, which accuses nobody.
                const std::optional<std::uint32_t> known = catalog->recipient_index(id, recipient);
                const Catalog::RecordedName recorded =
                    known
                        ? Catalog::RecordedName{*known, false}
                        : slot.lend_while([&] { return catalog->record_recipient(id, recipient); });
                metrics.new_recipients += recorded.is_new ? 1 : 0;
                current.record = id + "#" + std::to_string(recorded.index);
                const BufferPool::Lease positions(buffers);
                const std::uint32_t index = recorded.index;
                warm->copies->make(std::span(&index, 1), *positions, {},
                                   1);  // no distortion figures: not sent
                res.body = mesh_file_bytes(warm->file, (*positions)[0], chosen);
                res.status = 200;
                res.set_header("Content-Type", content_type_of(chosen));
                res.set_header("Content-Disposition",
                               "attachment; filename=\"" +
                                   download_name(warm->file_name, recipient, chosen) + "\"");
                res.set_header("X-Meshmark-Record", std::to_string(recorded.index));
                res.set_header("X-Meshmark-Recipient-New", recorded.is_new ? "true" : "false");
                ++metrics.copies;
            });
    }

    void scan(const httplib::Request& req, httplib::Response& res)
    {
        current.route = "scan";
        const std::string name =
            req.has_param("name") ? req.get_param_value("name") : std::string();
        const fs::path given(name);
        if (name.empty() || name.size() > 255 || given.has_parent_path() || name.front() == '.' ||
            name.find_first_of(std::string("\0\r\n", 3)) != std::string::npos ||
            !format_named(given.extension().string().substr(given.extension().empty() ? 0 : 1)))
        {
            fail(res, 400,
                 "name the suspect: POST /v1/scan?name=FILE.EXT, EXT one of ply, obj, off, stl, "
                 "gltf, glb, 3mf "
                 "(a plain file name).");
            return;
        }
        if (req.body.empty())
        {
            fail(res, 400, "the body is the suspect file's bytes; it is empty.");
            return;
        }
        compute(res,
                [&](WorkerSlot&)
                {
                    const fs::path folder = spool / std::to_string(++spooled);
                    struct Cleanup
                    {
                        fs::path folder;
                        ~Cleanup()
                        {
                            std::error_code ignored;
                            fs::remove_all(folder, ignored);
                        }
                    } cleanup{folder};
                    fs::create_directory(folder);
                    const fs::path suspect = folder / given;
                    {
                        std::ofstream out(suspect, std::ios::binary);
                        out.write(req.body.data(), static_cast<std::streamsize>(req.body.size()));
                        if (!out)
                        {
                            throw IoError("cannot store the suspect for scanning (disk full?).");
                        }
                    }
                    CatalogScanOptions scan_options;
                    scan_options.detect.threads = 1;
                    scan_options.detect.decision.max_false_positive = options.max_false_positive;
                    scan_options.candidates = options.scan_candidates;
                    const CatalogScanReport report =
                        catalog_scan(*catalog, {suspect}, scan_options);
                    Json json = catalog_scan_json(*catalog, report, scan_options);
                    json.erase("catalog");  // the server's path (each match keeps its "original":
                                            // the contract's field)
                    strip_payload(json);
                    for (Json& s : json["suspects"])
                    {
                        s["path"] = name;
                    }
                    if (!report.suspects.empty() && !report.suspects[0].error.empty())
                    {
                        fail(res, 422, name + ": " + report.suspects[0].error);
                        return;
                    }
                    send_json(res, json);
                });
    }

    static Json summary_json(const Catalog::Summary& s)
    {
        return {{"asset", s.id},
                {"vertices", s.vertex_count},
                {"faces", s.face_count},
                {"added", s.added},
                {"complete", s.is_complete},
                {"recipients", s.recipients},
                {"original_sha256", s.original_sha256}};
    }

    void routes()
    {
        server.set_pre_routing_handler(
            [this](const httplib::Request& req, httplib::Response& res)
            {
                current = RequestInfo{};
                current.start = Clock::now();
                if (req.path == "/healthz")
                {
                    current.route = "healthz";
                    return httplib::Server::HandlerResponse::Unhandled;
                }
                if (!authorized(req))
                {
                    res.set_header("WWW-Authenticate", "Bearer");
                    fail(res, 401,
                         "this request needs the service's token: Authorization: Bearer TOKEN.");
                    return httplib::Server::HandlerResponse::Handled;
                }
                return httplib::Server::HandlerResponse::Unhandled;
            });
        server.Get("/healthz",
                   [](const httplib::Request&, httplib::Response& res) {
                       send_json(res, {{"status", "ok"}});
                   });
        server.Get("/metrics",
                   [this](const httplib::Request&, httplib::Response& res)
                   {
                       current.route = "metrics";
                       res.status = 200;
                       res.body = metrics.text(cache->stats(), cache->budget());
                       res.set_header("Content-Type", "text/plain; version=0.0.4");
                   });
        server.Get("/v1/assets",
                   [this](const httplib::Request&, httplib::Response& res)
                   {
                       current.route = "assets";
                       Json list = Json::array();
                       for (const Catalog::Summary& s : catalog->summaries())
                       {
                           list.push_back(summary_json(s));
                       }
                       send_json(res, {{"assets", list}});
                   });
        server.Get(R"(/v1/assets/(.+))",
                   [this](const httplib::Request& req, httplib::Response& res)
                   {
                       current.route = "asset";
                       const std::string id = req.matches[1];
                       current.asset = id;
                       if (const std::string problem = asset_problem(id); !problem.empty())
                       {
                           fail(res, 400, problem + ".");
                           return;
                       }
                       const std::vector<Catalog::Summary> found = catalog->summaries(id);
                       if (found.empty())
                       {
                           fail(res, 404, "no asset '" + id + "' in the catalogue.");
                           return;
                       }
                       send_json(res, summary_json(found[0]));
                   });
        server.Post(R"(/v1/assets/(.+)/copies)",
                    [this](const httplib::Request& req, httplib::Response& res)
                    { issue_copy(req, res); });
        server.Post("/v1/scan", [this](const httplib::Request& req, httplib::Response& res)
                    { scan(req, res); });
        server.set_error_handler(httplib::Server::HandlerWithResponse(
            [](const httplib::Request& req, httplib::Response& res)
            {
                if (!res.body.empty())
                {
                    return httplib::Server::HandlerResponse::Unhandled;  // a handler's own error
                }
                if (res.status == 404)
                {
                    fail(res, 404,
                         "no such route: " + req.method + " " + req.path + " (docs/service.md).");
                }
                else if (res.status == 413)
                {
                    // cpp-httplib caps form-encoded bodies (curl's --data-binary default) at 8 KiB.
                    const bool form =
                        req.get_header_value("Content-Type") == "application/x-www-form-urlencoded";
                    fail(res, 413,
                         form ? "a suspect is sent as Content-Type: application/octet-stream, not "
                                "as a form."
                              : "the request's body is larger than the service accepts "
                                "(--max-upload).");
                }
                else if (res.status == 405 || res.status == 400)
                {
                    fail(res, res.status,
                         "the request is not one the service understands (docs/service.md).");
                }
                return httplib::Server::HandlerResponse::Handled;
            }));
        server.set_exception_handler(
            [this](const httplib::Request&, httplib::Response& res, std::exception_ptr error)
            {
                std::string what = "unknown error";
                try
                {
                    std::rethrow_exception(error);
                }
                catch (const std::exception& e)
                {
                    what = e.what();
                }
                catch (...)
                {
                }
                fail(res, 500, "internal error: " + what);
                notice("request failed inside the service: " + what);
            });
        server.set_logger(
            [this](const httplib::Request& req, const httplib::Response& res)
            {
                // A request refused before routing (a body over the limit, a malformed request
                // line) never set `current`: it is the empty one the previous request left.
                const double seconds =
                    current.start == Clock::time_point{}
                        ? 0.0
                        : std::chrono::duration<double>(Clock::now() - current.start).count();
                metrics.observe(current.route, res.status, seconds);
                Json line{{"time", utc_now()},
                          {"remote", req.remote_addr},
                          {"method", req.method},
                          {"path", req.path},
                          {"status", res.status},
                          {"bytes", res.body.size()},
                          {"ms", std::round(seconds * 1e5) / 100.0}};
                if (!current.record.empty())
                {
                    line["record"] = current.record;
                }
                if (!current.error.empty())
                {
                    line["error"] = current.error;
                }
                log(line.dump(-1, ' ', false, Json::error_handler_t::replace));
                current = RequestInfo{};  // nothing of this request carried into the next one
            });
    }
};

Service::Service(ServiceOptions options) : impl_(std::make_unique<Impl>())
{
    Impl& s = *impl_;
    s.options = std::move(options);
    const ServiceOptions& o = s.options;
    if (o.port < 0 || o.port > 65535)
    {
        throw InvalidOption("--listen's port must be 0 to 65535.");
    }
    if (o.workers < 0 || o.connections < 1 || o.connections > 4096 || o.scan_candidates < 1)
    {
        throw InvalidOption("--workers must be >= 0, --connections 1 to 4096.");
    }
    s.catalog = std::make_unique<Catalog>(o.catalog, Catalog::Open::Existing, o.lock_timeout);
    if (o.token_file.empty() && o.catalog.string().find("://") != std::string::npos)
    {
        throw InvalidOption("--token-file is needed with a catalogue in a database (" +
                            s.catalog->path().string() + "): the token is kept in a file.");
    }
    s.token_path = o.token_file.empty() ? fs::path(o.catalog.string() + ".token") : o.token_file;
    bool created = false;
    s.token = load_token(s.token_path, &created);
    if (created)
    {
        s.notice("created the token file " + s.token_path.string() +
                 " (mode 0600): clients send its line as "
                 "Authorization: Bearer TOKEN.");
    }
    s.cache = std::make_unique<AssetCache>(*s.catalog, o.memory_budget);
    const int workers = o.workers > 0
                            ? o.workers
                            : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
    s.slots = std::make_unique<WorkerQueue>(workers);
    std::string spool_template = (fs::temp_directory_path() / "meshmark-serve-XXXXXX").string();
    if (::mkdtemp(spool_template.data()) == nullptr)
    {
        throw IoError("cannot create a private folder under " + fs::temp_directory_path().string() +
                      " for scans.");
    }
    s.spool = spool_template;
    const int connections = o.connections;
    s.server.new_task_queue = [connections]
    { return new httplib::ThreadPool(static_cast<std::size_t>(connections)); };
    s.server.set_read_timeout(o.read_timeout.count());
    s.server.set_write_timeout(30);
    s.server.set_keep_alive_timeout(5);
    s.server.set_keep_alive_max_count(100000);
    s.server.set_payload_max_length(o.max_upload);
    s.server.set_tcp_nodelay(true);
    s.routes();
    if (o.port == 0)
    {
        s.port = s.server.bind_to_any_port(o.host);
    }
    else
    {
        s.port = s.server.bind_to_port(o.host, o.port) ? o.port : -1;
    }
    if (s.port <= 0)
    {
        std::error_code ignored;
        fs::remove_all(s.spool, ignored);
        throw IoError("cannot listen on " + o.host + ":" + std::to_string(o.port) +
                      " (in use, or not an address of this machine).");
    }
}

Service::~Service()
{
    std::error_code ignored;
    fs::remove_all(impl_->spool, ignored);
}

int Service::port() const noexcept
{
    return impl_->port;
}

const std::filesystem::path& Service::token_file() const noexcept
{
    return impl_->token_path;
}

void Service::run()
{
    impl_->notice("serving " + impl_->catalog->path().string() + " on http://" +
                  impl_->options.host + ":" + std::to_string(impl_->port) + " (token in " +
                  impl_->token_path.string() + ")");
    const bool listened = impl_->server.listen_after_bind();
    const int error = errno;
    if (!listened && !impl_->stopping)
    {
        // Not a stop(): the listening socket failed (see accept() above). The requests in flight
        // were answered; a supervisor restarts the service.
        const std::string why =
            std::string("the listening socket failed (") + std::strerror(error) + ")";
        impl_->notice(why + "; stopped");
        throw IoError("meshmark serve: " + why + ".");
    }
    impl_->notice("stopped");
}

void Service::stop()
{
    impl_->stopping = true;
    impl_->server.stop();
}

}  // namespace meshmark::service
