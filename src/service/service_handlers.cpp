// SPDX-License-Identifier: MIT
// The service's work: a recipient's copy (POST /assets/{id}/copies) and a scan (POST /scan).
#include "service_impl.h"

namespace meshmark::service
{

void Service::Impl::issue_copy(const httplib::Request& req, httplib::Response& res)
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
        fail(res, 413,
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
            fail(
                res, 400,
                "unknown field \"" + name + "\"; a copy request has \"recipient\" and \"format\".");
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
    compute(res,
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

void Service::Impl::scan(const httplib::Request& req, httplib::Response& res)
{
    current.route = "scan";
    const std::string name = req.has_param("name") ? req.get_param_value("name") : std::string();
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
                scan_options.more_candidates = options.scan_more_candidates;
                const CatalogScanReport report = catalog_scan(*catalog, {suspect}, scan_options);
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

}  // namespace meshmark::service
