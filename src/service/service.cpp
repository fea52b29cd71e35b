// SPDX-License-Identifier: MIT
// The issuing service (docs/service.md): cpp-httplib's server (Debian's libcpp-httplib) on a
// catalogue. Connections are served by a pool of `connections` threads, each of which mostly
// waits on its client; the work (a copy, a scan, warming an asset) runs only while holding one
// of `workers` slots, so 32 keep-alive clients share the cores instead of oversubscribing them.
#include "service.h"

#include "service_impl.h"

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

Service::Service(ServiceOptions options) : impl_(std::make_unique<Impl>())
{
    Impl& s = *impl_;
    s.options = std::move(options);
    const ServiceOptions& o = s.options;
    if (o.port < 0 || o.port > 65535)
    {
        throw InvalidOption("--listen's port must be 0 to 65535.");
    }
    if (o.workers < 0 || o.connections < 1 || o.connections > 4096)
    {
        throw InvalidOption("--workers must be >= 0, --connections 1 to 4096.");
    }
    if (o.scan_candidates < 1 || o.scan_more_candidates < 0)
    {
        throw InvalidOption("--candidates must be >= 1, --more-candidates >= 0.");
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
