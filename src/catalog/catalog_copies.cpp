// SPDX-License-Identifier: MIT
// `catalog issue`'s tasks: the coordinator's recording and splitting, a worker's copies made in
// a staging folder, the coordinator's delivery (docs/cluster.md).
#include "meshmark/catalog/catalog_copies.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "catalog/catalog_add_impl.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/io/file_sha256.h"

namespace meshmark
{
namespace fs = std::filesystem;

namespace
{

constexpr const char* kTask = "a catalogue copy task";

nlohmann::json copy_json(const IssuedCopy& copy)
{
    return {{"name", copy.name},
            {"index", copy.index},
            {"path", copy.path.string()},
            {"new", copy.is_new}};
}

IssuedCopy parse_copy(const nlohmann::json& json)
{
    try
    {
        IssuedCopy copy;
        copy.name = json.at("name").get<std::string>();
        copy.index = json.at("index").get<std::uint32_t>();
        copy.path = json.at("path").get<std::string>();
        copy.is_new = json.at("new").get<bool>();
        return copy;
    }
    catch (const nlohmann::json::exception& e)
    {
        throw InvalidOption(std::string(kTask) + " with a copy that is not one (" + e.what() +
                            ").");
    }
}

nlohmann::json stats_json(const EmbedStats& s)
{
    return {{"max", s.max_displacement_rel},    {"rms", s.rms_displacement_rel},
            {"surface_rms", s.surface_rms_rel}, {"orthogonality", s.orthogonality_error},
            {"step", s.modulation_step},        {"weak_bits", s.weak_bits},
            {"analysed", s.analysed_vertices},  {"span", s.basis_span},
            {"shortened", s.shortened_to_span}};
}

EmbedStats parse_stats(const nlohmann::json& json)
{
    EmbedStats s;
    s.max_displacement_rel = json.at("max").get<double>();
    s.rms_displacement_rel = json.at("rms").get<double>();
    s.surface_rms_rel = json.at("surface_rms").get<double>();
    s.orthogonality_error = json.at("orthogonality").get<double>();
    s.modulation_step = json.at("step").get<double>();
    s.weak_bits = json.at("weak_bits").get<int>();
    s.analysed_vertices = json.at("analysed").get<int>();
    s.basis_span = json.at("span").get<int>();
    s.shortened_to_span = json.at("shortened").get<bool>();
    return s;
}

// The key store of a worker's copies: the recorded key, which already holds every name.
class RecordedKey final : public FamilyKeyStore
{
public:
    RecordedKey(std::string asset, Key key) : asset_(std::move(asset)), key_(std::move(key)) {}
    [[nodiscard]] std::string name() const override { return "asset " + asset_; }
    [[nodiscard]] std::string single_owner_advice() const override
    {
        return "the catalogue's assets are marked with family keys.";
    }
    [[nodiscard]] std::optional<Key> peek() const override { return key_; }
    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        if (update(key_))
        {
            throw IoError(asset_ + ": a copy task named a recipient its key does not record.");
        }
        return 0.0;
    }

private:
    std::string asset_;
    Key key_;
};

}  // namespace

nlohmann::json CatalogCopyTask::to_json() const
{
    nlohmann::json copies_json = nlohmann::json::array();
    for (const IssuedCopy& copy : copies)
    {
        copies_json.push_back(copy_json(copy));
    }
    return {{"first", first},
            {"asset", asset},
            {"original", original.string()},
            {"original_sha256", original_sha256},
            {"key", meshmark::to_json(key)},
            {"copies", std::move(copies_json)}};
}

std::string CatalogCopyTask::name() const
{
    const std::string text = to_json().dump();
    char name[64];
    std::snprintf(name, sizeof name, "meshmark-issue-%.12s-%016llx", original_sha256.c_str(),
                  static_cast<unsigned long long>(hash_bytes(text.data(), text.size())));
    return name;
}

CatalogCopyTask parse_copy_task(const nlohmann::json& json)
{
    CatalogCopyTask task;
    try
    {
        task.first = json.at("first").get<std::size_t>();
        task.asset = json.at("asset").get<std::string>();
        task.original = json.at("original").get<std::string>();
        task.original_sha256 = json.at("original_sha256").get<std::string>();
        task.key = parse_key(json.at("key").get<std::string>(), kTask);
        for (const nlohmann::json& copy : json.at("copies"))
        {
            task.copies.push_back(parse_copy(copy));
        }
    }
    catch (const nlohmann::json::exception& e)
    {
        throw InvalidOption(std::string(kTask) + " that is not one (" + e.what() + ").");
    }
    return task;
}

nlohmann::json to_json(const CatalogIssuePlan& plan)
{
    nlohmann::json copies = nlohmann::json::array();
    for (const IssuedCopy& copy : plan.copies)
    {
        copies.push_back(copy_json(copy));
    }
    return {{"key", to_json(plan.key)}, {"copies", std::move(copies)}};
}

CatalogIssuePlan parse_issue_plan(const nlohmann::json& json)
{
    CatalogIssuePlan plan;
    try
    {
        plan.key = parse_key(json.at("key").get<std::string>(), "an issue plan");
        for (const nlohmann::json& copy : json.at("copies"))
        {
            plan.copies.push_back(parse_copy(copy));
        }
    }
    catch (const nlohmann::json::exception& e)
    {
        throw InvalidOption(std::string("an issue plan that is not one (") + e.what() + ").");
    }
    return plan;
}

CatalogIssuePlan catalog_plan_issue(Catalog& catalog, const std::string& asset_id,
                                    const std::string& output_pattern,
                                    const CatalogIssueOptions& options, std::size_t per_task)
{
    if (per_task < 1)
    {
        throw InvalidOption("copies per task must be >= 1.");
    }
    const CatalogAsset asset = catalog_detail::issuable_asset(catalog, asset_id);
    EmbedRecipientsOptions check;
    check.recipients = options.recipients;
    check.validate();
    // The names once each, in the order given (as embed_recipients issues them).
    std::vector<std::string> names;
    std::set<std::string> seen;
    for (const std::string& name : options.recipients)
    {
        if (seen.insert(name).second)
        {
            names.push_back(name);
        }
    }
    CatalogIssuePlan plan;
    const std::unique_ptr<FamilyKeyStore> store = catalog.family_store(asset_id);
    (void)store->change(
        [&](std::optional<Key> now) -> std::optional<Key>
        {
            if (!now || !now->recipients)
            {
                throw IoError(store->name() + ": the asset has no family key.");
            }
            plan.key = std::move(*now);
            plan.copies = assign_recipient_indices(
                plan.key, names,
                [&](const std::string& name) { return recipient_output(output_pattern, name); });
            const bool adds = std::any_of(plan.copies.begin(), plan.copies.end(),
                                          [](const IssuedCopy& copy) { return copy.is_new; });
            return adds ? std::optional<Key>(plan.key) : std::nullopt;
        });
    for (std::size_t first = 0; first < plan.copies.size(); first += per_task)
    {
        CatalogCopyTask task;
        task.first = first;
        task.asset = asset_id;
        task.original = fs::absolute(asset.original).lexically_normal();
        task.original_sha256 = asset.original_sha256;
        task.key = plan.key;
        const std::size_t end = std::min(plan.copies.size(), first + per_task);
        for (std::size_t c = first; c < end; ++c)
        {
            IssuedCopy copy = plan.copies[c];
            copy.path = fs::absolute(copy.path).lexically_normal();  // the workers' folders differ
            task.copies.push_back(std::move(copy));
        }
        plan.tasks.push_back(std::move(task));
    }
    return plan;
}

nlohmann::json CatalogMadeCopies::to_json() const
{
    nlohmann::json list = nlohmann::json::array();
    for (const IssuedCopy& copy : copies)
    {
        nlohmann::json one = copy_json(copy);
        one["stats"] = stats_json(copy.stats);
        list.push_back(std::move(one));
    }
    return {{"copies", std::move(list)}, {"vertices", vertex_count}, {"faces", face_count}};
}

CatalogMadeCopies parse_made_copies(const nlohmann::json& json)
{
    CatalogMadeCopies made;
    try
    {
        for (const nlohmann::json& one : json.at("copies"))
        {
            IssuedCopy copy = parse_copy(one);
            copy.stats = parse_stats(one.at("stats"));
            made.copies.push_back(std::move(copy));
        }
        made.vertex_count = json.at("vertices").get<std::int64_t>();
        made.face_count = json.at("faces").get<std::int64_t>();
    }
    catch (const nlohmann::json::exception& e)
    {
        throw InvalidOption(std::string("made copies that are not (") + e.what() + ").");
    }
    return made;
}

CatalogMadeCopies catalog_make_copies(const CatalogCopyTask& task, int threads)
{
    if (file_sha256(task.original) != task.original_sha256)
    {
        throw IoError(task.original.string() + ": the original of asset '" + task.asset +
                      "' changed since it was added; copies are made from the original.");
    }
    const catalog_detail::StagingFolder staging;
    // Copy c is staged in its own folder, under its final name; what its format writes beside
    // it goes to the final folder's same place.
    std::map<std::string, std::size_t> copy_of;
    for (std::size_t c = 0; c < task.copies.size(); ++c)
    {
        copy_of[task.copies[c].name] = c;
    }
    const auto staged = [&](std::size_t c)
    { return staging.path() / std::to_string(c) / task.copies[c].path.filename(); };
    std::map<fs::path, fs::path> final_folder;
    for (std::size_t c = 0; c < task.copies.size(); ++c)
    {
        final_folder[staged(c)] = task.copies[c].path.parent_path();
    }
    EmbedRecipientsOptions embed;
    for (const IssuedCopy& copy : task.copies)
    {
        embed.recipients.push_back(copy.name);
    }
    embed.threads = threads;
    embed.link_folder = [&](const fs::path& path) { return final_folder.at(path); };
    RecordedKey store(task.asset, task.key);
    const EmbedRecipientsReport report = embed_recipients(
        task.original, nullptr, [&](const std::string& name) { return staged(copy_of.at(name)); },
        store, embed);
    CatalogMadeCopies made;
    made.vertex_count = report.vertex_count;
    made.face_count = report.face_count;
    for (std::size_t c = 0; c < report.copies.size(); ++c)
    {
        IssuedCopy copy = report.copies[c];
        copy.path = task.copies[copy_of.at(copy.name)].path;
        copy.is_new = task.copies[copy_of.at(copy.name)].is_new;
        made.copies.push_back(std::move(copy));
    }
    std::vector<std::pair<fs::path, std::string>> copies;
    for (std::size_t c = 0; c < task.copies.size(); ++c)
    {
        const fs::path folder = staging.path() / std::to_string(c);
        for (auto it = fs::recursive_directory_iterator(folder);
             it != fs::recursive_directory_iterator(); ++it)
        {
            if (!it->is_regular_file())
            {
                continue;
            }
            const fs::path to =
                task.copies[c].path.parent_path() / it->path().lexically_relative(folder);
            (it->path() == staged(c) ? copies : made.files)
                .emplace_back(to, catalog_detail::read_staged(it->path()));
        }
    }
    made.files.insert(made.files.end(), copies.begin(), copies.end());
    return made;
}

void catalog_deliver(Catalog& catalog, const CatalogCopyTask& task, const CatalogMadeCopies& made)
{
    for (const auto& [path, bytes] : made.files)
    {
        catalog_detail::write_unless_same(path, bytes);
    }
    const std::unique_ptr<FamilyKeyStore> store = catalog.family_store(task.asset);
    store->delivered(made.copies);
}

nlohmann::json catalog_issue_json(const Catalog& catalog, const std::string& asset,
                                  const CatalogIssuePlan& plan,
                                  const std::vector<CatalogMadeCopies>& made, double seconds)
{
    EmbedRecipientsReport report;
    report.key = plan.key;
    for (const CatalogMadeCopies& m : made)
    {
        report.copies.insert(report.copies.end(), m.copies.begin(), m.copies.end());
        report.vertex_count = m.vertex_count;
        report.face_count = m.face_count;
    }
    if (report.copies.size() != plan.copies.size())
    {
        throw InvalidOption("an issue report of other copies than its plan's.");
    }
    for (std::size_t c = 0; c < report.copies.size(); ++c)
    {
        report.copies[c].path = plan.copies[c].path;  // as named, not as the workers wrote it
    }
    report.seconds.total = seconds;
    return catalog_issue_report_json(catalog, asset, report);
}

}  // namespace meshmark
