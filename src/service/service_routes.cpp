// SPDX-License-Identifier: MIT
// The service's routes, its authentication and its access log (docs/service.md).
#include "service_impl.h"

namespace meshmark::service
{

Json Service::Impl::summary_json(const Catalog::Summary& s)
{
    return {{"asset", s.id},
            {"vertices", s.vertex_count},
            {"faces", s.face_count},
            {"added", s.added},
            {"complete", s.is_complete},
            {"recipients", s.recipients},
            {"original_sha256", s.original_sha256}};
}

void Service::Impl::routes()
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
    server.Post("/v1/scan",
                [this](const httplib::Request& req, httplib::Response& res) { scan(req, res); });
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

}  // namespace meshmark::service
